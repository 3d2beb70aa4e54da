"""The seeded refinement stops at one unit of chi-square (eddi.fit_record.SEED_MIN_GAIN, session 15).

With ``route="auto"`` and no held-out record the pipeline refines the Lagrangian route's seed
with ``min_gain=SEED_MIN_GAIN``: a stage ends when a step lowers the sum of squares by less
than one mean square per compared value. Once the model fits, the step left moves the
coefficients by far less than their interval (one RK4 sensitivity pass less on the rig's
record); a fit that does not (poor, diverging, not kept) goes on to the scored pipeline, which
runs to rounding (``min_gain=None``), and is then that pipeline's result bit for bit.
Each test fails on the code before (no SEED_MIN_GAIN; every refinement ran to rounding).
"""

from __future__ import annotations

import pytest

import eddi.fit_record as fit_record
import eddi.refine as refine
import eddi.sensitivity as sensitivity
from eddi.conditioning import condition
from eddi.fit_record import Pipeline
from simulated_rig.bench import impact_test
from tests.eddi.impact_cases import SYSTEMS, impact_record


def _spy(monkeypatch) -> tuple[list, list]:
    gains, passes = [], []
    real, real_sens = refine.refine_output_error, sensitivity.free_response_sensitivities

    def spy(*a, **k):
        gains.append(k.get("min_gain"))
        return real(*a, **k)

    def sens(*a, **k):
        passes.append(1)
        return real_sens(*a, **k)

    monkeypatch.setattr(refine, "refine_output_error", spy)
    monkeypatch.setattr(sensitivity, "free_response_sensitivities", sens)
    return gains, passes


def _coefficients(res) -> dict[str, float]:
    return {**res.model.eom.damping, **res.model.eom.stiffness}


def test_the_rig_record_is_refined_with_one_sensitivity_pass_less(monkeypatch) -> None:
    rec = impact_test("duffing-smooth", 600.0, snr_db=45.0, seed=1, record_s=20.0)
    pipe = Pipeline.create("v,x^2*v,v^3", "x,x^2,x^3,x^4,x^5")
    cond = pipe.condition(rec.t, acc=rec.acc_m_s2, force=rec.force_n, pretrigger_samples=rec.pretrigger_samples)
    gains, passes = _spy(monkeypatch)
    fast = pipe.fit(cond, 0.815)
    assert gains == [fit_record.SEED_MIN_GAIN] == [1.0]
    n_fast = len(passes)
    monkeypatch.setattr(fit_record, "SEED_MIN_GAIN", None)
    gains.clear()
    passes.clear()
    full = pipe.fit(cond, 0.815)
    assert gains == [None]
    assert fast.choices.refinement == full.choices.refinement == "kept"
    assert n_fast < len(passes)
    half = {**full.ci95["damping"], **full.ci95["stiffness"]}
    got, want = _coefficients(fast), _coefficients(full)
    assert set(got) == set(want)
    for term, c in want.items():
        assert abs(got[term] - c) <= 1e-3 * half[term], term


def test_a_poor_fit_is_refined_to_rounding_by_the_scored_pipeline(monkeypatch) -> None:
    """The rig's strut-stop system, outside the 8-term library (nrmse ~0.5): the seeded fit stopped
    early fits poorly, the scored pipeline refines to rounding, and its result is delivered."""
    rec = impact_test("duffing-struts", 600.0, snr_db=45.0, seed=2)
    pipe = Pipeline.create("v,x^2*v,v^3", "x,x^2,x^3,x^4,x^5")
    cond = pipe.condition(rec.t, acc=rec.acc_m_s2, force=rec.force_n, pretrigger_samples=rec.pretrigger_samples)
    gains, _ = _spy(monkeypatch)
    one = pipe.fit(cond, rec.eom.mass)
    assert gains == [1.0, None]
    assert any(w.startswith("poor fit") for w in one.warnings)
    monkeypatch.setattr(fit_record, "FIRST_ROUTE", "")
    both = pipe.fit(cond, rec.eom.mass)
    assert _coefficients(one) == _coefficients(both) and one.ci95 == both.ci95


def test_a_sign_term_is_refined_to_rounding(monkeypatch) -> None:
    """test_first_route's Coulomb record: a switching model's sum of squares is rough (secant
    Jacobians), so its refinement is not stopped early (min_gain None in both fits)."""
    base = dict(SYSTEMS["paper_do"], damping={"v": 0.3, "sign(v)": 0.1})
    r = impact_record(base, snr_db=45.0, seed=2)
    cond = condition(r.t, acc=r.acc, force=r.force)
    gains, _ = _spy(monkeypatch)
    Pipeline(damping=("v", "sign(v)"), stiffness=("x", "x^3")).fit(cond, base["mass"])
    assert gains and all(g is None for g in gains)
