"""A held-out part's simulation on the dense grid where the record samples the motion finely.

``eddi.diagnosis.show.simulate_part_xv`` simulates a finely sampled part as the pipeline's
validation does (``eddi.simulate.simulate_dense``: every sample while the force acts, then RK4
steps of ``omega h <= 0.05`` on a grid of ``omega q dt <= 0.2``, cubic Hermite back onto the
samples) and keeps every sample for models with effects and for coarsely sampled records.
Systems of my own: a 0.3 kg, 9 Hz hardening oscillator at 20 kHz and a 50 g, 180 Hz one at 2 kHz.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddi.conditioning import condition
from eddi.diagnosis import Record
from eddi.diagnosis.records import Part
from eddi.diagnosis.show import drive_force, simulate_part_xv
from eddi.model import Effect, EquationOfMotion
from eddi.simulate import simulate, simulate_dense
from simulated_rig.bench import impact_test


def _system(mass: float, f1: float) -> EquationOfMotion:
    k1 = mass * (2 * math.pi * f1) ** 2
    return EquationOfMotion.create(mass=mass, damping={"v": 2 * 0.01 * math.sqrt(k1 * mass)},
                                   stiffness={"x": k1, "x^3": 0.3 * k1 / 0.004 ** 2})


def _record(eom: EquationOfMotion, rate: float, force: float) -> Record:
    r = impact_test(eom, force, rate_hz=rate, pretrigger_s=0.1, record_s=2.0, snr_db=50.0, seed=91)
    c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
    return Record.from_conditioned(c, label="hit", pretrigger_samples=r.pretrigger_samples)


def _every_sample(eom: EquationOfMotion, rec: Record, part: Part) -> tuple[np.ndarray, np.ndarray]:
    s0, e = rec.impact_start, part.stop
    sim = simulate(eom, rec.t[s0:e] - rec.t[s0], force=drive_force(eom, rec)[s0:e], x0=float(rec.x[s0]),
                   v0=float(rec.v[s0]), x_scale=float(np.max(np.abs(rec.x[s0:e]))),
                   v_scale=float(np.max(np.abs(rec.v[s0:e]))))
    return sim.x[part.start - s0:], sim.v[part.start - s0:]


@pytest.fixture(scope="module")
def fine() -> tuple[EquationOfMotion, Record, Part]:
    eom = _system(0.3, 9.0)
    rec = _record(eom, 20000.0, 40.0)
    return eom, rec, Part(record=0, start=rec.free_start, stop=rec.free_stop, from_rest=True, label="p")


def test_a_finely_sampled_part_is_simulated_on_the_dense_grid_within_1e_5_of_every_sample(fine) -> None:
    eom, rec, part = fine
    x, v = simulate_part_xv(eom, rec, part)
    s0, e = rec.impact_start, part.stop
    dense = simulate_dense(eom, rec.t[s0:e] - rec.t[s0], force=drive_force(eom, rec)[s0:e], x0=float(rec.x[s0]),
                           v0=float(rec.v[s0]), x_scale=float(np.max(np.abs(rec.x[s0:e]))),
                           v_scale=float(np.max(np.abs(rec.v[s0:e]))))
    np.testing.assert_array_equal(x, dense.x[part.start - s0:])  # the dense path was taken
    xf, vf = _every_sample(eom, rec, part)
    assert not np.array_equal(x, xf)
    assert np.max(np.abs(x - xf)) <= 1e-5 * np.max(np.abs(xf))
    assert np.max(np.abs(v - vf)) <= 1e-5 * np.max(np.abs(vf))


def test_a_model_with_an_effect_keeps_every_sample(fine) -> None:
    eom, rec, part = fine
    eff = eom.with_effect(Effect(name="clearance", params={"gap_m": 0.5 * float(np.max(np.abs(rec.x))),
                                                           "stiffness_n_per_m": 0.2 * eom.linear_stiffness()}))
    x, v = simulate_part_xv(eff, rec, part)
    xf, vf = _every_sample(eff, rec, part)
    np.testing.assert_array_equal(x, xf)
    np.testing.assert_array_equal(v, vf)


def test_a_coarsely_sampled_part_keeps_every_sample() -> None:
    eom = _system(0.05, 180.0)  # 11 samples a cycle at 2 kHz: no grid of >= 4 samples fits
    rec = _record(eom, 2000.0, 10.0)
    part = Part(record=0, start=rec.free_start, stop=rec.free_stop, from_rest=True, label="p")
    x, v = simulate_part_xv(eom, rec, part)
    xf, vf = _every_sample(eom, rec, part)
    np.testing.assert_array_equal(x, xf)
    np.testing.assert_array_equal(v, vf)
