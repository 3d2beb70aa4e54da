"""Even-order stiffness ``k2 x^2 + k4 x^4``: a spring stiffer on one side."""

from __future__ import annotations

import numpy as np

from eddi.diagnosis.catalogue.base import Mechanism, MechanismFit, _has
from eddi.identify_many import term_basis
from eddi.model import Effect

class AsymmetricStiffness(Mechanism):
    name = "asymmetric_stiffness"
    strength = "k2"
    physics = "even-order stiffness k2 x^2 + k4 x^4: the spring is stiffer on one side"

    def _missing(self, stiffness: tuple[str, ...]) -> list[int]:
        return [p for p in (2, 4) if not _has(stiffness, f"x^{p}")]

    def strength_key(self, stiffness):
        missing = self._missing(stiffness)
        return f"k{missing[0]}" if missing else "k2"

    def skip_reason(self, damping, stiffness, effects):
        if not self._missing(stiffness):
            return "x^2 and x^4 are already stiffness terms"
        return super().skip_reason(damping, stiffness, effects)

    native = "stiffness"

    def bases(self, shape, stiffness):
        return tuple(term_basis(f"x^{p}") for p in self._missing(stiffness))

    def columns(self, sig, shape, stiffness):
        return np.column_stack([sig.x**p for p in self._missing(stiffness)])

    def to_fit(self, coefs, shape, mass, stiffness):
        params = {"k2": 0.0, "k4": 0.0}
        for p, c in zip(self._missing(stiffness), coefs):
            params[f"k{p}"] = float(c)
        return MechanismFit(Effect(name=self.name, params=params))

    def symptom(self, fit):
        k2 = fit.effect.params["k2"]
        side = "positive" if k2 > 0 else "negative"
        return ("drifts in phase and its response is lopsided: the restoring force is larger on "
                f"the {side} side than on the other (even-order stiffness, k2 about {k2:.3g} "
                "N/m^2): asymmetric stiffness")
