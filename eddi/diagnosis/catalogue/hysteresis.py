"""A hysteretic restoring force (Bouc-Wen; a bolted joint's micro-slip, an elastic-plastic element)."""

from __future__ import annotations

import numpy as np

from eddi.diagnosis.catalogue.base import Mechanism, MechanismFit
from eddi.hysteresis import bouc_wen_z
from eddi.model import Effect

#: Yield displacements tried, as fractions of the largest training displacement, and exponents.
YIELD_FRACTIONS = (0.03, 0.07, 0.15, 0.3, 0.6, 1.2)
EXPONENTS = (1.0, 2.0, 4.0)


class Hysteresis(Mechanism):
    """A Bouc-Wen element ``F_y z`` in parallel with the baseline (``eddi.hysteresis``).

    For a fixed yield displacement ``d_y`` and exponent ``n`` the variable ``z`` follows from
    the measured displacement path alone (the law is rate independent), so the force is one
    column with coefficient ``F_y``. Like the second mode its force depends on the history of
    ``x``, not on ``(x, v)``: it is not a single-coordinate term and is refitted jointly with
    the baseline terms by equation error, judged against the baseline fitted the same way
    (``native`` empty). What tells it from drag, cubic damping or friction: besides a loss per
    cycle, it lowers the frequency as the amplitude grows past ``d_y`` (loading is softer than
    unloading), which no damping term does; judged held out against those candidates.
    """

    name = "hysteresis"
    lookalikes = ("quadratic_damping", "cubic_damping", "amplitude_damping")
    strength = "yield_force_n"
    refine = ("yield_displacement_m", "exponent")
    physics = ("a hysteretic restoring force (Bouc-Wen: F_y z, dz = dx/d_y (1 - |z|^n (sign(dx z) + 1)/2)),"
               " as in a bolted joint's micro-slip")

    def shape_grid(self, ctx):
        return [{"yield_displacement_m": float(f * ctx.x_peak), "exponent": float(n)}
                for f in YIELD_FRACTIONS for n in EXPONENTS]

    def columns(self, sig, shape, stiffness):
        return bouc_wen_z(sig.x, shape["yield_displacement_m"], min(shape["exponent"], 20.0))[:, None]

    def masked_columns(self, sig, shape, stiffness, mask):
        # z at a sample depends on the path up to it only, and the operator is exact along each
        # monotone stretch: only the training samples and the reversals before them are computed
        idx = np.flatnonzero(mask)
        if idx.size == 0:
            return np.zeros((0, 1))
        stop = int(idx[-1]) + 1
        return bouc_wen_z(sig.x[:stop], shape["yield_displacement_m"], min(shape["exponent"], 20.0),
                          at=idx)[:, None]

    def to_fit(self, coefs, shape, mass, stiffness):
        fy = float(coefs[0])
        if not fy > 0 or not 0.3 <= shape["exponent"] <= 20.0:
            return None
        return MechanismFit(Effect(name=self.name, params={
            "yield_force_n": fy, "yield_displacement_m": float(shape["yield_displacement_m"]),
            "exponent": float(shape["exponent"])}))

    def symptom(self, fit):
        p = fit.effect.params
        return ("loses energy in a loop whose restoring force depends on the path (loading softer than "
                "unloading), so both the loss per cycle and the frequency change with amplitude: "
                f"hysteresis (yield force about {p['yield_force_n']:.3g} N at "
                f"{1e3 * p['yield_displacement_m']:.3g} mm)")


