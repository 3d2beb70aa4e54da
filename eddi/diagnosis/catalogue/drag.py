"""Quadratic (aerodynamic) drag ``c_q |v| v``."""

from __future__ import annotations

import numpy as np

from eddi.diagnosis.catalogue.base import Mechanism, MechanismFit, _has
from eddi.identify_many import term_basis
from eddi.model import Effect

class QuadraticDamping(Mechanism):
    name = "quadratic_damping"
    lookalikes = ("cubic_damping", "amplitude_damping", "hysteresis")
    strength = "coefficient"
    physics = "quadratic (aerodynamic, turbulent) drag: c_q |v| v"

    def skip_reason(self, damping, stiffness, effects):
        if _has(damping, "abs(v)*v"):
            return "abs(v)*v is already a damping term"
        return super().skip_reason(damping, stiffness, effects)

    native = "damping"

    def bases(self, shape, stiffness):
        return (term_basis("abs(v)*v"),)

    def columns(self, sig, shape, stiffness):
        return (np.abs(sig.v) * sig.v)[:, None]

    def to_fit(self, coefs, shape, mass, stiffness):
        if not coefs[0] > 0:
            return None
        return MechanismFit(Effect(name=self.name, params={"coefficient": float(coefs[0])}))

    def symptom(self, fit):
        c = fit.effect.params["coefficient"]
        return ("loses energy per cycle growing like amplitude cubed, so it decays fast at high "
                f"amplitude and slows down at low amplitude: quadratic drag (about {c:.3g} N s^2/m^2)")
