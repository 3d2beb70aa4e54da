"""Candidates tested against the judged baseline when EDDI's per-fold fit departs from it, the
measurement chain's untested reference, and an error below the main frequency (session 18, s18ee;
docs/diagnosis.md "Session 18 (helper s18ee)").

A blind four-capture set (0.862 kg, 54.6 Hz) read `unexplained` because every candidate extended
EDDI's per-fold fit (0.133) instead of the judged baseline (0.0571): only the candidates that beat
that fit on every part were refined, none did. Rebuilt here with a lightly damped mode at 0.66 f1
(the profile of the blind set: too much loss at small amplitude, error power near 0.64 f1).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddi.conditioning import condition
from eddi.diagnosis import Record, diagnose
from eddi.diagnosis.decide import decide
from eddi.diagnosis.measure import data_floor
from eddi.diagnosis.pipeline_base import pipeline_baseline
from eddi.diagnosis.results import Candidate, NoiseFloor
from eddi.diagnosis.settings import COUPLING_CUT, EDDI_REFERENCE, REFINE_DEPARTED
from eddi.diagnosis.symptoms import _lower_motion
from eddi.model import Effect, EquationOfMotion
from eddi.terms import DEFAULT_STIFFNESS
from simulated_rig.bench import impact_test

MASS, F1 = 0.862, 54.6
NATIVE = ("quadratic_damping", "cubic_damping", "amplitude_damping", "coulomb_friction",
          "asymmetric_stiffness", "clearance", "smooth_stiffening")


def _records(lower_mode: bool, seed: int = 1) -> list[Record]:
    """Three blows (5 kHz, 1.5 s, 33 dB) on a 0.862 kg, 54.6 Hz oscillator (zeta 0.4 %), with a
    mode at 0.66 f1 (modal mass 0.1 m, coupling 0.03 k1, zeta 0.3 %) when ``lower_mode``."""
    k1 = MASS * (2 * math.pi * F1) ** 2
    eom = EquationOfMotion.create(mass=MASS, damping={"v": 2 * 0.004 * math.sqrt(k1 * MASS)}, stiffness={"x": k1})
    if lower_mode:
        m2, kc = 0.1 * MASS, 0.03 * k1
        kt = m2 * (0.66 * 2 * math.pi * F1) ** 2
        eom = eom.with_effect(Effect(name="second_mode", params={
            "mass_kg": m2, "stiffness_n_per_m": kt - kc, "damping_n_s_per_m": 2 * 0.003 * math.sqrt(kt * m2),
            "coupling_n_per_m": kc}))
    out = []
    for i, f in enumerate((200.0, 240.0, 280.0)):
        r = impact_test(eom, f * MASS, rate_hz=5000.0, pretrigger_s=0.2, record_s=1.5, snr_db=33.0,
                        seed=1000 * seed + 10 * i + 7)
        c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
        out.append(Record.from_conditioned(c, label=f"impact {i + 1}", pretrigger_samples=r.pretrigger_samples))
    return out


def _diagnose(recs):
    pipe = pipeline_baseline(recs, MASS, stiffness=DEFAULT_STIFFNESS)
    return diagnose(recs, MASS, stiffness=DEFAULT_STIFFNESS, pipeline=pipe)


@pytest.fixture(scope="module")
def lower():
    return _diagnose(_records(True))


def _peak(d):
    return next(s for s in d.symptoms if s.kind == "residual_peak")


def test_candidates_are_judged_against_the_judged_baseline_when_eddi_departs(lower):
    # EDDI's per-fold fit 0.261 against the judged 0.0573: before, every native candidate was
    # judged unrefined against it ("unrefined baseline", drag 0.0573 -> -0 %...+5 %), now refined
    # per fold and judged against the judged baseline
    d = lower
    assert float(np.mean(d.reference_fold)) > 3 * d.judged.nrmse
    tried = {c.name: c for c in d.candidates if not c.skipped and c.model is not None}
    natives = [tried[n] for n in NATIVE if n in tried]
    assert len(natives) >= 5
    assert all(c.reference == "baseline" for c in natives), [(c.name, c.reference) for c in natives]
    # the mode the model lacks halves the judged baseline on every part. With the `none` limit at
    # 3.5x (s18ee's branch) the baseline sat within it and the verdict read `unexplained` with it the
    # partial; at 2.5x (s18none, merged after) the baseline is beyond the limit and the records name
    # the mode the system has: `second_mode`, the true cause
    assert d.cause == "second_mode"
    assert tried["second_mode"].nrmse < 0.5 * d.judged.nrmse


def test_the_session_17_rule_judged_them_against_the_departed_fit():
    # the switch off (same-run comparison): the candidates keep EDDI's per-fold fit as reference
    old = REFINE_DEPARTED["factor"]
    REFINE_DEPARTED["factor"] = None
    try:
        d = _diagnose(_records(True))
    finally:
        REFINE_DEPARTED["factor"] = old
    refs = {c.name: c.reference for c in d.candidates if not c.skipped and c.model is not None and c.name in NATIVE}
    assert "unrefined baseline" in refs.values(), refs


def test_an_error_below_the_main_frequency_points_at_a_lower_mode(lower):
    peak = _peak(lower)
    assert 0.6 < peak.values["ratio_to_main"] < 0.7
    assert peak.values["lower_motion"] == 1.0
    assert "a second, lower mode" in peak.text


def test_the_null_of_the_same_rig_stays_silent():
    d = _diagnose(_records(False))
    assert d.cause == "none", d.verdict
    peak = _peak(d)
    assert peak.values["lower_motion"] == 0.0 and "lower mode" not in peak.text


def test_lower_motion_needs_the_band_and_every_part_at_the_same_frequency():
    assert _lower_motion([35.4, 35.9, 36.0], 0.66)
    assert not _lower_motion([20.0, 35.9, 44.0], 0.66)  # wanders from part to part: the noise
    assert not _lower_motion([15.2, 15.4, 15.3], 0.28)  # the drift band (the nulls' slow error)
    assert not _lower_motion([52.0, 52.3], 0.96)  # the main peak's skirt
    assert not _lower_motion([35.9], 0.66)  # one part says nothing about agreement


def _floor() -> NoiseFloor:
    fold, cond, pred = [0.02, 0.02, 0.02], [0.01, 0.01, 0.01], [0.005, 0.005, 0.005]
    return NoiseFloor(nrmse=0.02, fold_nrmse=tuple(fold), noise_rms=(0.0,) * 3, conditioning_nrmse=tuple(cond),
                      method="test", prediction_nrmse=tuple(pred), part_conditioning_nrmse=tuple(cond),
                      data_fold_nrmse=data_floor(fold, cond, pred, ()))


def test_none_above_the_floor_needs_the_chain_tested_against_the_judged_baseline():
    # s17ee's held-out ownC 1.2 Hz coupling (seed 2): the native candidates tested against the judged
    # baseline, the coupling only against EDDI's per-fold fit far beyond the factor: `none (uncertain)`
    # at 2.9x claimed that no mechanism earns its place, which the chain's candidate did not test
    base = (0.05, 0.055, 0.051)
    eom = EquationOfMotion.create(mass=1.0, damping={"v": 1.0}, stiffness={"x": 1e4})  # a fitted model
    drag = Candidate("quadratic_damping", 0.048, (0.047, 0.05, 0.048), 0.1, True, True, {}, {}, eom,
                     reference="baseline")

    def chain(eddi: float) -> Candidate:
        return Candidate("sensor_highpass", 0.045, (0.044, 0.046, 0.045), 0.1, True, True,
                         {"corner_hz": 1.2, COUPLING_CUT: 0.15, "uncoupled_nrmse": 0.05, EDDI_REFERENCE: eddi}, {},
                         eom, reference="baseline")

    dec = decide([drag, chain(0.133)], base, _floor(), 0.5, 3.5, 10.0, strong_margin=0.6, eddi_fold=base)
    assert dec.cause == "unexplained"
    assert "the chain was not tested against it" in dec.reason and "0.133" in dec.reason
    # the chain's reference within the factor: the candidates were a test, `none` stands
    dec = decide([drag, chain(0.06)], base, _floor(), 0.5, 3.5, 10.0, strong_margin=0.6, eddi_fold=base)
    assert dec.cause == "none"
    # no sign of a coupling (the noisy nulls of the suite): ruled out by the records, the coupling
    # itself no help, or its model worse than the judged baseline: `none` stands
    c = chain(0.133)
    for other in (Candidate(**{**c.__dict__, "contradicted": "the damping ratio per cycle grows with the amplitude"}),
                  Candidate(**{**c.__dict__, "params": {**c.params, COUPLING_CUT: -0.14}}),
                  Candidate(**{**c.__dict__, "nrmse": 0.0973, "fold_nrmse": (0.09, 0.1, 0.1)})):
        assert decide([drag, other], base, _floor(), 0.5, 3.5, 10.0, strong_margin=0.6).cause == "none"
    # below the floor of the data nothing is claimed missing: `none`
    low = (0.015, 0.016, 0.014)
    assert decide([drag, chain(0.133)], low, _floor(), 0.5, 3.5, 10.0, strong_margin=0.6).cause == "none"


def test_a_motion_below_the_main_frequency_forbids_none_above_the_floor():
    # the blind set's profile: 1.8x the floor, the error's power at 0.66 f1; before, `residual_peak`
    # never counted (the noise's own peak on almost every null), so `none (uncertain)` once every
    # candidate was tested against the judged baseline and none earned its place
    from eddi.diagnosis.earn import earn
    from eddi.diagnosis.name import Decision
    from eddi.diagnosis.results import Symptom

    none = Decision("none", None, None, True, "within the noise floor")

    def peak(lower: float) -> Symptom:
        return Symptom("residual_peak", "near 35.9 Hz", {"frequency_hz": 35.9, "ratio_to_main": 0.66,
                                                         "main_frequency_hz": 54.6, "lower_motion": lower})

    dec = earn(none, 1.8, [peak(1.0)])
    assert dec.cause == "unexplained" and "35.9 Hz" in dec.reason
    assert earn(none, 1.8, [peak(0.0)]).cause == "none"  # a peak that wanders from part to part
    assert earn(none, 0.9, [peak(1.0)]).cause == "none"  # at or below the floor `none` stands
    # the best partial explanation decide held under `none` is kept (the catalogue's second mode)
    mode = Candidate("second_mode", 0.0331, (0.025, 0.03, 0.037), 0.75, True, True, {}, {}, None)
    held = Decision("none", None, None, True, "within the noise floor", helpful=mode)
    assert earn(held, 2.5, [peak(1.0)]).partial is mode
    assert earn(held, 2.5, [peak(0.0)]).partial is None


def test_the_chain_clause_needs_every_held_out_part_better():
    # s18noisy: the bench_diagnose_none_limit `noisy` null, seed 10 (20.3 dB, nothing hidden), judged
    # 1.4x the floor of the data; sensor_highpass extends EDDI's per-fold fit at 10x the floor, its
    # coupling cuts 14 % and its mean beats the judged baseline, but it loses held-out part 1: a
    # sensor's coupling is in every capture, the noise's refit is not. `unexplained` before, `none` now
    floor = NoiseFloor(nrmse=0.0412, fold_nrmse=(0.0412,) * 3, noise_rms=(0.0,) * 3,
                       conditioning_nrmse=(0.03,) * 3, method="test", prediction_nrmse=(0.01,) * 3,
                       part_conditioning_nrmse=(0.03,) * 3,
                       data_fold_nrmse=data_floor([0.0412] * 3, [0.03] * 3, [0.01] * 3, ()))
    base = (0.033, 0.0446, 0.0967)
    eom = EquationOfMotion.create(mass=1.0, damping={"v": 1.0}, stiffness={"x": 1e4})
    native = Candidate("asymmetric_stiffness", 0.0812, (0.0349, 0.0418, 0.1669), -0.398, False, False, {}, {},
                       eom, reference="baseline")
    params = {"corner_hz": 0.3, COUPLING_CUT: 0.144, "uncoupled_nrmse": 0.0537, EDDI_REFERENCE: 0.412}
    noisy = Candidate("sensor_highpass", 0.046, (0.0379, 0.0331, 0.0669), 0.208, False, True, params, {}, eom,
                      reference="baseline")
    dec = decide([noisy, native], base, floor, 0.5, 2.5, 10.0, strong_margin=0.6, eddi_fold=(0.034, 0.1547, 1.0472))
    assert dec.cause == "none" and dec.within_floor
    # the same candidate better on every part (a coupling's signature): the chain was not tested
    coupled = Candidate(**{**noisy.__dict__, "fold_nrmse": (0.032, 0.0331, 0.0669)})
    dec = decide([coupled, native], base, floor, 0.5, 2.5, 10.0, strong_margin=0.6, eddi_fold=(0.034, 0.1547, 1.0472))
    assert dec.cause == "unexplained" and "the chain was not tested against it" in dec.reason
