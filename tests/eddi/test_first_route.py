"""The pipeline seeds its refinement from one phase-two route (eddi.fit_record.FIRST_ROUTE).

From either route the output-error refinement reaches the same optimum (<= 5e-6 of its ci95
on 55 records, docs/speed.md), so with ``route="auto"`` and the refinement the pipeline fits
the Lagrangian route alone (the potential route and the two route-scoring simulations were
~28 of 150 ms on the 45 s record), on a grid three times coarser (SEED_H_OMEGA: EDDI 22 -> 10 ms). When the refinement is not kept, EDDI's estimate is
delivered and must be the one ``route="auto"`` picks: both routes are scored then, and the
result is the scored pipeline's exactly.
"""

from dataclasses import replace

import pytest

import eddi.fit_record as fit_record
from eddi.fit_record import Pipeline
from tests.eddi.impact_cases import SYSTEMS, impact_record

SPEC = SYSTEMS["paper_do"]


def _fit(seed: int):
    r = impact_record(SPEC, rate_hz=4000.0, duration_s=2.0, pretrigger_s=0.2, snr_db=40.0, seed=seed)
    pipe = Pipeline(damping=tuple(SPEC["damping"]), stiffness=tuple(SPEC["stiffness"]))
    return pipe.fit(pipe.condition(r.t, acc=r.acc, force=r.force), SPEC["mass"])


def _coefficients(res) -> dict[str, float]:
    return {**res.model.eom.damping, **res.model.eom.stiffness}


@pytest.mark.parametrize("seed, scored_best", [(0, "potential"), (1, "lagrangian")])
def test_one_route_seeds_the_refinement_and_reaches_the_scored_pipelines_optimum(monkeypatch, seed, scored_best):
    one = _fit(seed)
    assert one.choices.refinement == "kept"
    assert one.model.route == "lagrangian" and one.model.route_scores == {}  # the scored pipeline: both
    monkeypatch.setattr(fit_record, "FIRST_ROUTE", "")
    both = _fit(seed)
    # the seed on ~21 samples a cycle of the fastest oscillation, the delivered EDDI estimate on ~63
    assert one.choices.decimation >= 3 * both.choices.decimation - 2 and both.choices.decimation >= 5
    assert both.model.route == scored_best and set(both.model.route_scores) == {"potential", "lagrangian"}
    assert both.choices.refinement == "kept"
    half = {**both.ci95["damping"], **both.ci95["stiffness"]}
    got, want = _coefficients(one), _coefficients(both)
    assert set(got) == set(want)
    for term, c in want.items():
        assert abs(got[term] - c) <= 1e-4 * half[term], term


def _rejecting(real):
    """judge_refinement that rejects every refinement (EDDI's estimate delivered)."""

    def judge(model, cond, held_out, val, held, judged_on, eddi_vals=None, off_reason="", ee_vals=None):
        got = real(model, cond, held_out, val, held, judged_on, eddi_vals, off_reason)
        eddi_val, eddi_held = eddi_vals
        return (replace(got[0], eom=got[0].unrefined), eddi_val, eddi_held, eddi_held, "rejected", "test",
                got[6], got[7])

    return judge


@pytest.mark.parametrize("seed, scored_best", [(0, "potential"), (1, "lagrangian")])
def test_a_rejected_refinement_delivers_the_scored_routes_estimate(monkeypatch, seed, scored_best):
    monkeypatch.setattr(fit_record, "judge_refinement", _rejecting(fit_record.judge_refinement))
    one = _fit(seed)
    monkeypatch.setattr(fit_record, "FIRST_ROUTE", "")
    both = _fit(seed)
    assert one.choices.refinement == both.choices.refinement == "rejected"
    assert one.model.route == both.model.route == scored_best
    assert one.model.route_scores == both.model.route_scores and len(one.model.route_scores) == 2
    assert one.choices.route_scores == both.choices.route_scores
    assert _coefficients(one) == _coefficients(both)  # bit for bit: the same EDDI estimate
    assert one.ci95 == both.ci95 and one.validation.nrmse == both.validation.nrmse


@pytest.mark.parametrize("friction_n", [0.1, 0.2])
def test_a_poor_or_diverging_fit_is_the_scored_pipelines(monkeypatch, friction_n):
    """Coulomb friction outside the default library (tests/eddi/test_stability.py's record): the
    seeded fit was poor (0.1 N: nrmse 0.54) or its seed and its refined model both blew up in the
    validation (0.2 N: the judge kept the refinement, no poor-fit warning). Both symptoms bring
    back the scored pipeline, whose result this is bit for bit."""
    from eddi.conditioning import condition

    base = dict(SYSTEMS["paper_do"], damping={"v": 0.3, "sign(v)": friction_n})
    r = impact_record(base, snr_db=45.0, seed=2)
    cond = condition(r.t, acc=r.acc, force=r.force)
    one = Pipeline.create().fit(cond, base["mass"])
    monkeypatch.setattr(fit_record, "FIRST_ROUTE", "")
    both = Pipeline.create().fit(cond, base["mass"])
    assert len(one.model.route_scores) == 2 and one.model.route == both.model.route
    assert _coefficients(one) == _coefficients(both) and one.choices.warnings == both.choices.warnings
    assert any(w.startswith("poor fit") for w in one.warnings)
