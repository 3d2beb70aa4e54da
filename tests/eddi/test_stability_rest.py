"""A model whose rest is unstable (negative damping at small amplitude, dissipating at the
record's) is flagged even though every half cycle of the record dissipates (session 16: blind
unseen9 seed 9393, b[v] = -25 N s/m with a positive x^2 v, exit 0 and no flag)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddi.model import EquationOfMotion
from eddi.stability import model_warnings, self_excited_amplitude

# own numbers (not the blind record's): 3 kg, 40 Hz
M, K = 3.0, 3.0 * (2 * math.pi * 40.0) ** 2


def _eom(damping: dict[str, float]) -> EquationOfMotion:
    return EquationOfMotion.create(mass=M, damping=damping, stiffness={"x": K, "x^3": 1e9})


def _ring(x0: float = 2e-3, rate: float = 1.0, n: int = 4000) -> tuple[np.ndarray, np.ndarray]:
    w = math.sqrt(K / M)
    t = np.arange(n) / 4000.0
    env = x0 * np.exp(-rate * t)
    return env * np.cos(w * t), -env * w * np.sin(w * t)


def test_van_der_pol_like_damping_is_flagged_with_its_limit_cycle() -> None:
    b1, b3 = -12.0, 3.0e7  # limit cycle (harmonic balance) at sqrt(-4 b1 / b3) = 1.26 mm
    eom = _eom({"v": b1, "x^2*v": b3})
    x, v = _ring(x0=2.5e-3, rate=0.4)  # 2.5 -> 1.7 mm: every half cycle above the limit cycle dissipates
    assert not [w for w in model_warnings(eom, x, v) if "half cycles" in w]
    assert self_excited_amplitude(eom, 2.5e-3) == pytest.approx(math.sqrt(-4 * b1 / b3), rel=0.1)
    said = [w for w in model_warnings(eom, x, v) if "small amplitude" in w]
    assert len(said) == 1 and "rest is unstable" in said[0] and " m (the record reaches" in said[0]


@pytest.mark.parametrize("damping", [{"v": 12.0}, {"v": 12.0, "x^2*v": -1e6}, {"sign(v)": 0.5, "v": -2.0},
                                     {"v": -1e-6, "x^2*v": 3e7}])
def test_stable_rests_are_not_flagged(damping: dict[str, float]) -> None:
    # a positive dashpot; a softening one still dissipating over the record; Coulomb friction that
    # outweighs a negative dashpot at small amplitude; a limit cycle below a thousandth of the record's
    eom = _eom(damping)
    x, v = _ring()
    assert not [w for w in model_warnings(eom, x, v) if "small amplitude" in w]
