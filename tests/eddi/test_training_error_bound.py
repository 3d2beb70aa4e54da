"""A fold's training error decided with fewer simulations (``fitter.TrainingError``), same answers.

Each fold judges the refined baseline against EDDI's and the equation-error contender against
the one kept, by their mean displacement nrmse over the fold's other training records. Every
nrmse is >= 0, so once the records simulated so far hold a model's mean at or above the other's,
the rest cannot reverse it (``TrainingError.below``); the contender is fitted on the fold's fit
record alone, so folds with the same fit record share it and its simulations
(``Fitter.ee_fits`` / ``ee_errors``). Issue 13 item 2, docs/speed.md (session 16).
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.conditioning import condition
from eddi.diagnosis import Record
from eddi.diagnosis import fitter as fitter_mod
from eddi.diagnosis.extend import Setup
from eddi.diagnosis.fitter import Fitter, TrainingError
from eddi.diagnosis.records import split
from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test

SYSTEM = EquationOfMotion.create(mass=0.1, damping={"v": 0.06}, stiffness={"x": 600.0, "x^3": 2e7})


def _records() -> list[Record]:
    out = []
    for i, f in enumerate((15.0, 20.0, 25.0, 30.0, 35.0)):
        r = impact_test(SYSTEM, f, rate_hz=4000.0, pretrigger_s=0.2, record_s=1.0, snr_db=40.0, seed=i)
        c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
        out.append(Record.from_conditioned(c, label=f"c{i}", pretrigger_samples=r.pretrigger_samples))
    return out


@pytest.fixture(scope="module")
def recs() -> list[Record]:
    return _records()


def _counting(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    calls: list[int] = []
    real = fitter_mod.simulate_part

    def counted(model, rec, part):  # type: ignore[no-untyped-def]
        calls.append(part.record)
        return real(model, rec, part)

    monkeypatch.setattr(fitter_mod, "simulate_part", counted)
    return calls


def _off(eom: EquationOfMotion, k: float) -> EquationOfMotion:
    return eom.model_copy(update={"stiffness": {t: c * k for t, c in eom.stiffness.items()}})


def test_below_answers_as_the_whole_mean_and_stops_early(recs, monkeypatch: pytest.MonkeyPatch) -> None:
    _, _, fold_masks = split(recs, 3)
    masks = fold_masks[0]
    calls = _counting(monkeypatch)
    models = [SYSTEM, _off(SYSTEM, 0.9), _off(SYSTEM, 0.6)]
    full = [TrainingError(recs, masks)(m) for m in models]
    n = len(TrainingError(recs, masks).judges)
    assert n == 3  # five records, one held out, the fit record not a judge
    assert full[0] < 0.05 < full[1] < full[2]  # the truth fits; a stiffness off by 10 %, 40 % does not
    early = 0
    for m, e in zip(models, full):
        for limit in (0.0, full[0], 0.5 * e, e, np.nextafter(e, np.inf), 2 * e, np.inf, np.nan):
            calls.clear()
            assert TrainingError(recs, masks).below(m, limit) == (e < limit)
            assert len(calls) <= n
            early += len(calls) < n
    # the truth's error as the limit: a model off by 40 % is decided on its first record
    calls.clear()
    assert not TrainingError(recs, masks).below(models[2], full[0])
    assert len(calls) == 1
    assert early >= 6


def test_judges_known_from_another_fold_are_not_simulated_again(recs, monkeypatch: pytest.MonkeyPatch) -> None:
    _, _, fold_masks = split(recs, 3)
    calls = _counting(monkeypatch)
    shared: dict = {}
    a = TrainingError(recs, fold_masks[0], shared)
    b = TrainingError(recs, fold_masks[1], shared)
    model = _off(SYSTEM, 0.9)
    ea = a(model, "m")
    assert len(calls) == 3
    calls.clear()
    eb = b(model, "m")
    # the two folds share two judging records (the same runs): only the third is simulated
    assert len(calls) == 1
    assert eb == TrainingError(recs, fold_masks[1])(model)  # the same number, not a close one
    assert ea == TrainingError(recs, fold_masks[0])(model)


def test_folds_with_one_fit_record_share_the_contender_and_judge_as_before(recs, monkeypatch) -> None:
    _, _, fold_masks = split(recs, 3)
    setup = Setup(mass=0.1, damping=("v",), stiffness=("x", "x^3"), base=None,
                  coordinate="displacement [m]", ee_contender=True)
    calls = _counting(monkeypatch)
    shared_fitter = Fitter([r.signal() for r in recs], setup, recs)
    chosen, per_fold, ee_fits = [], [], []
    for masks in fold_masks:
        ff = shared_fitter(masks)
        calls.clear()
        chosen.append(ff.refined(ff(None, None)))
        per_fold.append(len(calls))
        ee_fits.append(ff.ee_fit_record())
    # without sharing (a new fitter per fold, the contender judged on every judge): as before session 16
    before, before_calls = [], []
    for masks in fold_masks:
        ff = Fitter([r.signal() for r in recs], setup, recs)(masks)
        fit = ff(None, None)
        err = TrainingError(recs, masks)
        ee = ff.ee_fit_record()
        calls.clear()
        out = fit if ee is None or not err(ee.eom) < err(fit.eom) else ee
        before.append(out.eom)
        before_calls.append(len(calls))
    for got, want in zip(chosen, before):
        assert got.eom.model_dump() == want.model_dump()  # the same choice, bit for bit
    fit_records = [fitter_mod.fit_record_of(recs, m) for m in fold_masks]
    assert len(set(fit_records)) < len(fold_masks)  # some folds share their fit record ...
    for i in range(len(fold_masks)):
        for j in range(i):
            if fit_records[i] == fit_records[j] and np.array_equal(fold_masks[i][fit_records[i]],
                                                                   fold_masks[j][fit_records[j]]):
                assert ee_fits[i] is ee_fits[j]  # ... and so the contender's fit
    assert sum(per_fold) < sum(before_calls)
