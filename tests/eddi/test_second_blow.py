"""A second hammer blow inside a capture (struck again while recording) ends the record used:
the impact is the first blow, the free response is its ring-down, and a warning says so."""

from __future__ import annotations

import numpy as np
import pytest

from eddi import EquationOfMotion, simulate
from eddi.conditioning import condition
from eddi.fit_record import cond_warnings, identify_measurement
from tests.eddi.impact_cases import half_sine_pulse

RATE = 4000.0
EOM = EquationOfMotion.create(mass=0.5, damping={"v": 0.8}, stiffness={"x": 2.0e3, "x^3": 4.0e7})


def _record(second_s: float | None, second_n: float, seed: int = 3) -> tuple[np.ndarray, ...]:
    t = np.arange(int(6.0 * RATE)) / RATE
    f = half_sine_pulse(t, 0.25, 2e-3, 150.0)
    if second_s is not None:
        f = f + half_sine_pulse(t, second_s, 2e-3, second_n)
    s = simulate(EOM, t, force=f)
    rng = np.random.default_rng(seed)
    acc = s.a + rng.normal(0.0, 1e-3 * np.max(np.abs(s.a)), t.size)
    return t, f + rng.normal(0.0, 0.02, t.size), acc


@pytest.mark.parametrize("second_n", [150.0, 220.0])  # the same blow again, and a harder one
def test_the_record_ends_before_a_second_blow(second_n: float) -> None:
    t, f, acc = _record(3.5, second_n)
    cond = condition(t, acc=acc, force=f, pretrigger_samples=int(0.2 * RATE))
    assert cond.impact_start < int(0.25 * RATE) < cond.impact_end < int(0.26 * RATE)  # the first blow
    assert int(3.49 * RATE) <= cond.t.size <= int(3.5 * RATE)  # cut at the second's foot
    (warning,) = [w for w in cond_warnings(cond) if "second blow" in w]
    assert "3.5 s" in warning
    res = identify_measurement(cond, 0.5, damping=("v",), stiffness=("x", "x^3"), refine=False)
    k = res.model.eom.stiffness
    assert abs(k["x"] / 2.0e3 - 1) < 0.01 and abs(k["x^3"] / 4.0e7 - 1) < 0.05


def test_one_blow_is_left_whole() -> None:
    t, f, acc = _record(None, 0.0)
    cond = condition(t, acc=acc, force=f, pretrigger_samples=int(0.2 * RATE))
    assert cond.t.size == t.size
    assert not [w for w in cond_warnings(cond) if "second blow" in w]


def test_a_continuous_drive_is_not_a_second_blow() -> None:
    """A force that never goes quiet after the blow (a shaker left on) is not cut."""
    t, f, acc = _record(None, 0.0)
    drive = np.where(t > 0.26, 5.0 * np.sin(2 * np.pi * 37.0 * t), 0.0)
    cond = condition(t, acc=acc, force=f + drive, pretrigger_samples=int(0.2 * RATE))
    assert cond.t.size == t.size
