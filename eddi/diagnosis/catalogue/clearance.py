"""Contact beyond a gap: an extra spring acting only when ``|x| > g``."""

from __future__ import annotations

import numpy as np

from eddi.diagnosis.catalogue.base import Mechanism, MechanismFit
from eddi.identify_many import gap_basis
from eddi.model import Effect

class Clearance(Mechanism):
    name = "clearance"
    lookalikes = ("smooth_stiffening",)
    strength = "stiffness_n_per_m"
    refine = ("gap_m",)
    physics = ("contact beyond a gap g: an extra spring k_c (|x| - g) sign(x) acts only when "
               "|x| > g")

    def shape_grid(self, ctx):
        # gaps between 5 % and 90 % of the largest training amplitude, denser at small gaps
        return [{"gap_m": float(ctx.x_peak * f)} for f in np.linspace(0.05, 0.9, 20)]

    native = "stiffness"

    def bases(self, shape, stiffness):
        return (gap_basis(shape["gap_m"]),)

    def columns(self, sig, shape, stiffness):
        g = shape["gap_m"]
        return (np.sign(sig.x) * np.maximum(np.abs(sig.x) - g, 0.0))[:, None]

    def to_fit(self, coefs, shape, mass, stiffness):
        if not coefs[0] > 0:
            return None
        return MechanismFit(Effect(name=self.name, params={
            "gap_m": shape["gap_m"], "stiffness_n_per_m": float(coefs[0])}))

    def symptom(self, fit):
        g = fit.effect.params["gap_m"]
        k = fit.effect.params["stiffness_n_per_m"]
        return (f"gets the frequency wrong once the amplitude passes about {g * 1e3:.3g} mm: the "
                f"stiffness steps up by about {k:.3g} N/m beyond a gap: clearance (contact)")
