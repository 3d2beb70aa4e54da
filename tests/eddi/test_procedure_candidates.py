"""Candidates fitted by the fold's own procedure (session 17; docs/diagnosis.md "Session 17").

Where a fold is judged with its equation-error contender (it reproduced the fold's other training
records better than EDDI's fit and its refinement), a native candidate is now the better, by those
same records, of EDDI + mechanism refined as the fold refines and the contender + mechanism fitted
on the contender's rows (:meth:`FoldFitter.procedure`), measured against the judged baseline.
Before: EDDI + mechanism measured against EDDI's per-fold fit (session 15 rule; a fold where
EDDI's fit is lost makes that reference meaningless), or (session 16, off by default) the
contender + mechanism alone (it cut less than EDDI + mechanism refined).

The system is s16ee's held-out family "ownC" (benchmarks/bench_diagnose_own16.py): 0.05 kg,
15 Hz, softening, 8 kHz, 42 dB, three 2.5 s blows; the hidden effects as the calibration's ladders
hide them (benchmarks/bench_diagnose_calibration.py ``ladder_case``).
"""

from __future__ import annotations

import math

import numpy as np

from eddi.conditioning import condition
from eddi.diagnosis import Record, diagnose
from eddi.diagnosis.pipeline_base import pipeline_baseline
from eddi.diagnosis.tolerance import ChainTolerance
from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test

MASS, RATE, SNR, RECORD_S = 0.05, 8000.0, 42.0, 2.5
K1 = MASS * (2 * math.pi * 15.0) ** 2
SYSTEM = EquationOfMotion.create(mass=MASS, damping={"v": 2 * 0.007 * math.sqrt(K1 * MASS)},
                                 stiffness={"x": K1, "x^3": -1e6})
FORCES = (10.0, 12.5, 15.0)  # the ladders' 20, 25, 30 N scaled by mass / 0.1 kg


def _typical() -> tuple[float, float]:
    r = impact_test(SYSTEM, FORCES[1], rate_hz=RATE, pretrigger_s=0.05, record_s=0.5, snr_db=None, seed=0)
    return float(np.max(np.abs(r.truth_x))), float(np.max(np.abs(r.truth_v)))


def _truth(name: str, magnitude: float, seed: int) -> EquationOfMotion:
    from simulated_rig.systems import hide_effect

    amp, vel = _typical()
    if name == "amplitude_damping":  # c |x| v, jittered 0.8-1.2 by the seed as the ladders do
        c = magnitude * float(np.random.default_rng(seed).uniform(0.8, 1.2)) * K1 / vel
        return SYSTEM.model_copy(update={"damping": {**SYSTEM.damping, "abs(x)*v": c}})
    return hide_effect(SYSTEM, name, magnitude, seed, amplitude_m=amp, velocity_m_s=vel)


def _diagnosis(name: str, magnitude: float, seed: int):
    truth, recs = _truth(name, magnitude, seed), []
    for i, f in enumerate(FORCES):
        r = impact_test(truth, f, rate_hz=RATE, pretrigger_s=0.2, record_s=RECORD_S, snr_db=SNR,
                        seed=1000 * seed + 10 * i + 7)
        c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
        recs.append(Record.from_conditioned(c, label=f"impact {i + 1}", pretrigger_samples=r.pretrigger_samples))
    return diagnose(recs, MASS, pipeline=pipeline_baseline(recs, MASS), chain=ChainTolerance())


def test_hidden_amplitude_damping_named_against_the_judged_baseline():
    # before (main 24ec089, session-15 rule): `unexplained`, the candidate (0.0044, 86 % under the
    # judged 0.0317) measured against EDDI's per-fold fits (0.62 / lost / 0.52), which every fold
    # had rejected for its equation-error contender
    d = _diagnosis("amplitude_damping", 0.06, 1)
    judged = d.judging.fold_nrmse
    assert list(d.reference_fold) == list(judged)  # every fold judged with its contender
    assert 1.0 < d.judging.nrmse / d.noise_floor.nrmse < 3.5  # within the none factor, above the floor
    assert d.cause == "amplitude_damping", d.verdict
    cand = next(c for c in d.candidates if c.name == "amplitude_damping")
    assert cand.wins_every_part and all(c < 0.3 * j for c, j in zip(cand.fold_nrmse, judged))
    assert cand.nrmse < 0.2 * d.judging.nrmse


def test_hidden_drag_named_where_the_contender_plus_drag_cuts_less(monkeypatch):
    # the ownC drag case: with session 16's rule (EXTEND_JUDGED on, the contender + drag alone;
    # main 24ec089 with the switch set) `unexplained`, 0.0214 (56 % cut, short of the strong 60 %);
    # the fold's procedure keeps EDDI + drag refined where the other training records prefer it
    from eddi.diagnosis.settings import EXTEND_JUDGED

    monkeypatch.setitem(EXTEND_JUDGED, "on", True)
    d = _diagnosis("quadratic_damping", 0.06, 1)
    assert d.cause == "quadratic_damping", d.verdict
    drag = next(c for c in d.candidates if c.name == "quadratic_damping")
    assert drag.wins_every_part and drag.nrmse < 0.2 * d.judging.nrmse  # 0.0065 of 0.0486
