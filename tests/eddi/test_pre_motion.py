"""A capture struck before the last ring-down died is warned about (session 19: the README's tour
struck the simulated rig every 19.5 s while it still rang at 12x its noise, and the captures read
only as a "poor fit"); a capture from rest is not."""

from __future__ import annotations

import numpy as np
import pytest

from eddi import EquationOfMotion, simulate
from eddi.conditioning import condition
from eddi.fit_record import cond_warnings
from tests.eddi.impact_cases import SYSTEMS, half_sine_pulse, impact_record, ringdown_rms

RATE = 10_000.0


def _struck_while_ringing(system: str, gap_s: float, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """A blow ``gap_s`` before the captured one, its ring-down still in the pre-trigger (0.3 s)."""
    spec = SYSTEMS[system]
    eom = EquationOfMotion.create(mass=spec["mass"], damping=spec["damping"], stiffness=spec["stiffness"])
    t = np.arange(int(7.0 * RATE)) / RATE
    first = 1.0 - gap_s
    force = half_sine_pulse(t, first, 1e-3, spec["peak_n"]) + half_sine_pulse(t, 1.0, 1e-3, spec["peak_n"])
    sim = simulate(eom, t, force=force)
    keep = slice(int(0.7 * RATE), None)  # the capture: 0.3 s before the second blow onwards
    rng = np.random.default_rng(seed)
    noise = 10 ** (-45 / 20) * ringdown_rms(sim.a, int(1.0 * RATE) + 11)
    acc = sim.a[keep] + noise * rng.standard_normal(t[keep].size)
    f = force[keep] + 1e-3 * spec["peak_n"] * rng.standard_normal(t[keep].size)
    return t[keep] - t[keep][0], f, acc, int(0.3 * RATE)


@pytest.mark.parametrize("system", ["paper_do", "nl_damping"])
def test_a_blow_into_a_ringing_structure_is_warned(system: str) -> None:
    t, f, acc, pre = _struck_while_ringing(system, gap_s=0.6, seed=1)
    c = condition(t, acc=acc, force=f, pretrigger_samples=pre)
    said = [w for w in cond_warnings(c) if w.startswith("not at rest before the blow")]
    assert len(said) == 1, cond_warnings(c)


@pytest.mark.parametrize("system", sorted(SYSTEMS))
@pytest.mark.parametrize("snr_db", [30.0, 60.0])
def test_a_capture_from_rest_is_not(system: str, snr_db: float) -> None:
    r = impact_record(system, snr_db=snr_db, seed=4)
    for pre in (r.pretrigger_samples, None):
        c = condition(r.t, acc=r.acc, force=r.force, pretrigger_samples=pre)
        assert not [w for w in cond_warnings(c) if "not at rest" in w], cond_warnings(c)


@pytest.mark.parametrize("end", ["zeros", "held"])
def test_a_record_whose_end_does_not_move_is_conditioned_without_the_claim(end: str) -> None:
    """A logger's zero padding or held last value at the end measures no noise: no claim (session
    20: the warning's ratio divided by zero, ZeroDivisionError out of the conditioning)."""
    r = impact_record("paper_do", snr_db=40.0, seed=4)
    acc = r.acc.copy()
    k = acc.size - acc.size // 8
    acc[k:] = 0.0 if end == "zeros" else acc[k]
    c = condition(r.t, acc=acc, force=r.force, pretrigger_samples=r.pretrigger_samples)
    assert not [w for w in cond_warnings(c) if "not at rest" in w], cond_warnings(c)
