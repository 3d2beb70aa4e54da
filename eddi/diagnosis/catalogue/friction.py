"""Dry (Coulomb) friction: a force of constant size opposing the motion."""

from __future__ import annotations

import numpy as np

from eddi.diagnosis.catalogue.base import Mechanism, MechanismFit, _has
from eddi.identify_many import tanh_basis
from eddi.model import Effect

class CoulombFriction(Mechanism):
    name = "coulomb_friction"
    strength = "force_n"
    physics = "dry (Coulomb) friction: a force of constant size opposing the motion, F_c sign(v)"

    def skip_reason(self, damping, stiffness, effects):
        if _has(damping, "sign(v)"):
            return "sign(v) is already a damping term"
        return super().skip_reason(damping, stiffness, effects)

    def shape_grid(self, ctx):
        # tanh regularisation well below the velocities that matter
        return [{"velocity_scale": float(np.clip(1e-3 * ctx.v_peak, 1e-7, 1e-4))}]

    native = "damping"

    def bases(self, shape, stiffness):
        return (tanh_basis(shape["velocity_scale"]),)

    def columns(self, sig, shape, stiffness):
        return np.tanh(sig.v / shape["velocity_scale"])[:, None]

    def to_fit(self, coefs, shape, mass, stiffness):
        if not coefs[0] > 0:
            return None
        return MechanismFit(Effect(name=self.name, params={
            "force_n": float(coefs[0]), "velocity_scale": shape["velocity_scale"]}))

    def symptom(self, fit):
        f = fit.effect.params["force_n"]
        return ("loses energy per cycle in proportion to amplitude, so the loss dominates at low "
                f"amplitude and the ring-down ends in a straight-line decay: dry friction "
                f"(about {f:.3g} N)")
