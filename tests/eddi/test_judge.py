"""The refinement's judge on the fit record (eddi/judge.py): measurably worse, or within its errors."""

from __future__ import annotations

import numpy as np
import pytest

from eddi.conditioning import condition
from eddi.fit_record import Pipeline, fused_impact_force, validate_conditioned
from eddi.judge import WHITE_SIGMAS, impulse_uncertainty, judge_fit_record
from eddi.model import EquationOfMotion
from tests.eddi.impact_cases import SYSTEMS, half_sine_pulse, impact_record

SPEC = SYSTEMS["paper_do"]


def _eom(scale_k3: float = 1.0) -> EquationOfMotion:
    k = dict(SPEC["stiffness"], **{"x^3": SPEC["stiffness"]["x^3"] * scale_k3})
    return EquationOfMotion.create(mass=SPEC["mass"], damping=SPEC["damping"], stiffness=k)


@pytest.fixture(scope="module")
def record45():
    r = impact_record("paper_do", snr_db=45.0, seed=1)
    return condition(r.t, acc=r.acc, force=r.force)


def test_a_refined_model_far_off_is_rejected_and_the_true_one_kept(record45):
    # k3 3 % off: its simulation drifts in phase cycle after cycle, far beyond the noise
    bad = judge_fit_record(_eom(1.03), _eom(), record45)
    assert bad.refined_worse and bad.excess_sigmas > 10 * WHITE_SIGMAS
    assert bad.nrmse_refined > bad.nrmse_eddi
    good = judge_fit_record(_eom(), _eom(1.03), record45)
    assert not good.refined_worse and good.excess_sigmas < -10 * WHITE_SIGMAS


def test_validations_handed_in_give_the_same_judgement(record45):
    # the pipeline hands over the two validations it already ran: the judge does not simulate
    # them again, and says exactly what it says when it simulates them itself
    for refined, eddi in ((_eom(1.03), _eom()), (_eom(1.00002), _eom())):
        vals = (validate_conditioned(refined, record45)[0], validate_conditioned(eddi, record45)[0])
        assert judge_fit_record(refined, eddi, record45, validations=vals) == judge_fit_record(refined, eddi, record45)


def test_models_closer_than_the_noise_resolves_are_not_told_apart(record45):
    # k3 2e-5 off: the two simulations differ far less than the noise
    jd = judge_fit_record(_eom(1.00002), _eom(), record45)
    assert not jd.refined_worse and abs(jd.excess_sigmas) < WHITE_SIGMAS
    assert jd.nrmse_refined == pytest.approx(jd.nrmse_eddi, rel=1e-3)


def test_impulse_uncertainty_matches_the_spread_over_noise_seeds():
    # the fused drive's impulse over 12 noise draws of one impact spreads as the judge says
    eom = _eom()
    got, said = [], []
    for seed in range(12):
        r = impact_record("paper_do", snr_db=30.0, seed=seed)
        cond = condition(r.t, acc=r.acc, force=r.force)
        s0, s1 = cond.impact_start, cond.impact_end
        true = half_sine_pulse(r.t, 1.0, 1e-3, SPEC["peak_n"])  # impact_record's defaults
        got.append(float(np.sum(fused_impact_force(cond, eom)[s0:s1])) / float(np.sum(true[s0:s1])))
        said.append(impulse_uncertainty(cond, eom))
    spread = float(np.std(got, ddof=1))
    assert 0.5 * np.median(said) < spread < 2.0 * np.median(said)
    clean = impact_record("paper_do", snr_db=None)
    assert impulse_uncertainty(condition(clean.t, acc=clean.acc, force=clean.force), eom) == 0.0


def test_the_drive_profile_keeps_a_better_refinement_of_a_short_pulse():
    # benchmarks/bench_vs_sindy.py's held-out fast_hard (80 Hz, a 1 ms pulse of 8 samples) at
    # 45 dB: the refined coefficients are 3.7x closer than EDDI's, yet on the nominal drive
    # they simulated 3 % worse (0.00854 vs 0.00827) and the refinement was rejected
    spec = dict(mass=0.05, damping={"v": 1.0}, stiffness={"x": 12633.0, "x^3": 3.16e11}, peak_n=7.9)
    r = impact_record(spec, rate_hz=8000.0, duration_s=1.2, pretrigger_s=0.2, pulse_s=1e-3, snr_db=45.0, seed=3)
    cond = condition(r.t, acc=r.acc, force=r.force)
    res = Pipeline(damping=("v",), stiffness=("x", "x^3")).fit(cond, spec["mass"])
    assert res.choices.refinement == "kept", res.choices.refinement_reason
    eom = res.model.eom
    assert eom.stiffness["x^3"] == pytest.approx(spec["stiffness"]["x^3"], rel=1e-3)
    assert abs(res.model.unrefined.stiffness["x^3"] / spec["stiffness"]["x^3"] - 1) > 1e-3
