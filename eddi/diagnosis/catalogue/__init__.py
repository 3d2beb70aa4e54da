"""The catalogue of mechanisms diagnosis can add to an equation of motion, one per module.

:func:`catalogue` lists them in a fixed order; :data:`MECHANISM_NAMES` names them (the
measurement-chain cause ``sensor_highpass`` is tried by :mod:`eddi.diagnosis.chain`, not here,
as it corrects the conditioning rather than the physics). Pure numerics.
"""

from __future__ import annotations

from eddi.diagnosis.catalogue.asymmetric import AsymmetricStiffness
from eddi.diagnosis.catalogue.base import Context, Mechanism, MechanismFit, Signal
from eddi.diagnosis.catalogue.clearance import Clearance
from eddi.diagnosis.catalogue.drag import QuadraticDamping
from eddi.diagnosis.catalogue.friction import CoulombFriction
from eddi.diagnosis.catalogue.hysteresis import Hysteresis
from eddi.diagnosis.catalogue.second_mode import SecondMode
from eddi.diagnosis.catalogue.terms import AmplitudeDamping, CubicDamping, SmoothStiffening
from eddi.model import EquationOfMotion
from eddi.terms import parse_term

__all__ = ["Context", "Mechanism", "MechanismFit", "Signal", "catalogue", "MECHANISM_NAMES",
           "CHAIN_NAMES", "ALL_NAMES", "extend"]


def catalogue() -> tuple[Mechanism, ...]:
    """Every physical mechanism diagnosis tries, in a fixed order."""
    return (CoulombFriction(), QuadraticDamping(), CubicDamping(), Clearance(), SmoothStiffening(),
            AsymmetricStiffness(), SecondMode(), Hysteresis(), AmplitudeDamping())


#: Names of the physical catalogue, in order.
MECHANISM_NAMES: tuple[str, ...] = tuple(m.name for m in catalogue())
#: Measurement-chain causes found and corrected like physical ones.
CHAIN_NAMES: tuple[str, ...] = ("sensor_highpass",)
#: Every name ``diagnose(mechanisms=...)`` accepts.
ALL_NAMES: tuple[str, ...] = MECHANISM_NAMES + CHAIN_NAMES


def extend(base: EquationOfMotion, fit: MechanismFit) -> EquationOfMotion:
    """``base`` with the fitted mechanism added (and its ``x`` coefficient shifted if needed)."""
    eom = base.with_effect(fit.effect) if fit.effect is not None else base
    if fit.damping or fit.stiffness:
        eom = eom.model_copy(update={"damping": {**eom.damping, **fit.damping},
                                     "stiffness": {**eom.stiffness, **fit.stiffness}})
    if fit.linear_stiffness_shift:
        stiff = dict(eom.stiffness)
        for text in stiff:
            if parse_term(text).exponents == (1, 0, 0, 0, 0, 0):
                stiff[text] = stiff[text] - fit.linear_stiffness_shift
                break
        else:
            stiff["x"] = -fit.linear_stiffness_shift
        eom = eom.model_copy(update={"stiffness": stiff})
    return eom
