"""Strongly nonlinear nulls stay silent (session 20, s20strong): the energy-per-cycle symptom reads
the model's loss at the measured cycle's energy level, not at its noisy largest ``|x|``."""

from __future__ import annotations


import numpy as np

from eddi.diagnosis.show import cycle_energies, energy_per_cycle
from eddi.diagnosis.symptoms import _energy_numbers
from eddi.model import EquationOfMotion
from eddi.simulate import simulate

M, K1, C = 13.28, 725779.0, 64.23  # 37 Hz, zeta 1 %


def _softening_ringdown(k3: float, rate: float = 2048.0, dur: float = 1.4):
    eom = EquationOfMotion.create(mass=M, damping={"v": C}, stiffness={"x": K1, "x^3": k3})
    n = int(dur * rate)
    t = np.arange(n) / rate
    s = simulate(eom, t, x0=1.9e-3, v0=0.0)
    return t, np.asarray(s.x), np.asarray(s.v)


def test_cycle_energies_match_energy_per_cycle() -> None:
    t, x, v = _softening_ringdown(-1.2283e10)
    amp, level, lost = cycle_energies(t, x, v, M)
    a2, l2 = energy_per_cycle(t, x, v, M)
    assert np.array_equal(amp, a2) and np.array_equal(lost, l2)
    # the level decays with the ring-down and is at most the peak
    assert np.all(level > 0) and np.all(np.diff(level) < 0) and np.all(level <= amp * (1 + 1e-9))


def test_truth_model_loses_what_the_records_lose_at_small_amplitude() -> None:
    """X1's operating point (13.3 kg, 37 Hz, zeta 1 %, a cubic softening the stiffness 17 % at the
    peak, 2048 Hz, 1.37 s, 40 dB) through the rig and the conditioning, compared with its own truth
    model simulated over the free response: over 6 draws the small-amplitude mismatch averages
    within its standard error. Read at the noisy cycle's largest |x| (before session 20) the same
    draws gave +1..+18 %, mean z +4 (every draw positive), the station's "loses 15 % more per cycle
    at small amplitude" on a null."""
    from eddi.conditioning import condition
    from eddi.diagnosis import Record
    from eddi.diagnosis.records import Part
    from eddi.diagnosis.show import simulate_part_xv
    from simulated_rig.bench import impact_test

    eom = EquationOfMotion.create(mass=M, damping={"v": C}, stiffness={"x": K1, "x^3": -1.2283e10})
    z = []
    for seed in range(6):
        rr = impact_test(eom, 175.0 * M, rate_hz=2048.0, pretrigger_s=0.028, record_s=1.37, snr_db=40.0, seed=seed)
        c = condition(rr.t, acc=rr.acc_m_s2, force=rr.force_n, pretrigger_samples=rr.pretrigger_samples)
        r = Record.from_conditioned(c, label="r", pretrigger_samples=rr.pretrigger_samples)
        p = Part(record=0, start=c.free_start, stop=c.free_stop, from_rest=True, label="r")
        xs, vs = simulate_part_xv(eom, r, p)
        sl = slice(p.start, p.stop)
        noise = 0.019 * float(np.sqrt(np.mean(r.x[sl] ** 2)))  # the floor's draw at 40 dB
        o = _energy_numbers(r.t[sl], r.x[sl], r.v[sl], xs, vs, M, noise)
        z.append(o["energy_mismatch_low_pct"] / o["energy_mismatch_low_se_pct"])
    z = np.array(z)
    assert np.all(np.isfinite(z))
    assert abs(float(z.mean())) < 1.5, z
    assert np.sum(z > 2.0) <= 1, z
