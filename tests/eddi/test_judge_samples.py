"""EDDI's validation on the fit record simulated at the judge's samples alone (session 15, issue 13).

With no held-out record EDDI's driven validation serves only the refinement's judge, which reads
every ``k``-th sample of it (:func:`eddi.judge.judge_stride`): :class:`eddi.fit_record.Pipeline`
has :func:`eddi.simulate.simulate_dense` interpolate it at those samples (``at``), the same
values bit for bit, and validates EDDI's model on every sample again only when it is delivered
(refinement rejected). Each test fails on the code before (no ``at``, no ``every``).
"""

from __future__ import annotations

import numpy as np
import pytest

import eddi.driven_validation as dv
import eddi.fit_record as fit_record
import eddi.judge as judge
from eddi.fit_record import Pipeline
from eddi.simulate import simulate_dense
from tests.eddi.impact_cases import SYSTEMS, impact_record


@pytest.fixture(scope="module")
def record():
    return impact_record(SYSTEMS["paper_do"], rate_hz=20000.0, duration_s=4.0, pretrigger_s=0.2, snr_db=45.0,
                         seed=5)


def test_dense_simulation_at_samples_is_the_whole_one_there(record) -> None:
    t, f = record.t, record.force
    full = simulate_dense(record.eom, t, force=f, x_scale=float(np.max(np.abs(record.x))),
                          v_scale=float(np.max(np.abs(record.v))))
    for at in (np.arange(3, t.size, 23), np.array([0, 1, 2, 4000, 4001, t.size - 1])):
        sub = simulate_dense(record.eom, t, force=f, x_scale=float(np.max(np.abs(record.x))),
                             v_scale=float(np.max(np.abs(record.v))), at=at)
        assert np.array_equal(sub.t, t[at])
        for name in ("x", "v", "a"):
            assert np.array_equal(getattr(sub, name), getattr(full, name)[at]), name


def _fit(record, monkeypatch, reject: bool):
    calls = []
    real = dv.validate_conditioned

    def spy(eom, cond, *a, **k):
        val = real(eom, cond, *a, **k)
        calls.append(val[0].every)
        return val

    monkeypatch.setattr(fit_record, "validate_conditioned", spy)
    monkeypatch.setattr("eddi.refinement_choice.validate_conditioned", spy)
    if reject:
        real_judge = judge.judge_fit_record

        def rejecting(*a, **k):
            jd = real_judge(*a, **k)
            return judge.Judgement(jd.nrmse_eddi, jd.nrmse_refined, 9.0, jd.drive_uncertainty, True)

        monkeypatch.setattr(judge, "judge_fit_record", rejecting)
    pipe = Pipeline(damping=("v",), stiffness=("x", "x^3"))
    cond = pipe.condition(record.t, acc=record.acc, force=record.force)
    return cond, pipe.fit(cond, 0.815), calls


def test_eddis_validation_serves_the_judge_at_its_samples(record, monkeypatch) -> None:
    cond, res, calls = _fit(record, monkeypatch, reject=False)
    k = judge.judge_stride(cond)
    assert k >= 2
    assert calls[:2] == [1, k]  # the refined model on every sample, EDDI's at the judge's
    assert res.choices.refinement == "kept"
    assert res.validation.every == 1
    # the judge's figures are those of the whole validation
    full = dv.validate_conditioned(res.model.unrefined, cond)[0]
    sub = dv.validate_conditioned(res.model.unrefined, cond, every=k)[0]
    assert np.array_equal(sub.x_simulated, full.x_simulated[::k])
    a = judge.judge_fit_record(res.model.eom, res.model.unrefined, cond, validations=(res.validation, full))
    b = judge.judge_fit_record(res.model.eom, res.model.unrefined, cond, validations=(res.validation, sub))
    assert a == b


def test_a_rejected_refinement_delivers_eddis_validation_on_every_sample(record, monkeypatch) -> None:
    cond, res, calls = _fit(record, monkeypatch, reject=True)
    assert res.choices.refinement == "rejected"
    assert res.validation.every == 1
    w0, w1 = cond.window
    assert res.validation.x_simulated.size == w1 - w0
    assert calls.count(1) >= 2  # the refined model's, and EDDI's again on every sample
    full = dv.validate_conditioned(res.model.eom, cond)[0]
    assert res.validation.nrmse == pytest.approx(full.nrmse, rel=1e-12)
