"""Stable or flagged: growing, non-decaying and negative-stiffness/damping models are flagged.

Records: the simulated acceleration-only impacts of :mod:`tests.eddi.impact_cases` (true
models known). Validation starts at the first free-response sample whatever the layout.
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

from eddi.conditioning import condition
from eddi.fit_record import Pipeline, validate_conditioned
from eddi.stability import model_warnings, response_warnings
from tests.eddi.impact_cases import SYSTEMS, impact_record


def _variant(eom, **update):
    return eom.model_copy(update=update)


@pytest.mark.parametrize("system", ["paper_do", "nl_damping"])
def test_acc_only_record_with_pretrigger_validates_the_true_model(system: str) -> None:
    r = impact_record(system, snr_db=45.0, seed=3)
    for pre in (r.pretrigger_samples, None):  # given, or detected
        cond = condition(r.t, acc=r.acc, pretrigger_samples=pre)
        # the free response starts after the impact (x is no longer ~0 there)
        assert cond.free_start > r.pretrigger_samples
        val, by_force = validate_conditioned(r.eom, cond)
        assert not by_force and not val.diverged and val.warnings == ()
        assert val.nrmse < 0.02  # measured 0.001-0.005 (0.9985 before: started at the onset)


def test_growing_and_non_decaying_models_are_flagged() -> None:
    r = impact_record("paper_do", snr_db=45.0, seed=1)
    cond = condition(r.t, acc=r.acc, force=r.force)
    b = r.eom.damping["v"]
    growing = _variant(r.eom, damping={"v": -1.0 * b})
    steady = _variant(r.eom, damping={"v": 0.0})
    val, _ = validate_conditioned(growing, cond)
    assert val.diverged and any("grows" in w or "measured peak" in w for w in val.warnings)
    peak = float(np.max(np.abs(val.x_simulated))) / float(np.max(np.abs(val.x_measured)))
    assert peak > 4  # a simulation growing to more than 4x the measurement ...
    val, _ = validate_conditioned(steady, cond)
    assert val.diverged and any("does not decay" in w for w in val.warnings)
    # the true model: silent
    val, _ = validate_conditioned(r.eom, cond)
    assert not val.diverged and val.warnings == ()


def test_response_warnings_thresholds_from_the_contract() -> None:
    t = np.linspace(0, 10, 5001)
    decay = np.exp(-0.3 * t) * np.sin(2 * np.pi * 3 * t)
    assert response_warnings(decay, 1.01 * decay) == ()
    assert "blows up" in response_warnings(decay, decay, blew_up=True)[0]
    assert "reaches" in response_warnings(decay, 4 * np.sin(2 * np.pi * 3 * t))[0]  # ~4x the measured peak
    assert "does not decay" in response_warnings(decay, np.sin(2 * np.pi * 3 * t))[0]
    grow = np.exp(0.05 * t) * np.sin(2 * np.pi * 3 * t)
    assert "grows" in response_warnings(decay, grow)[0]


def test_negative_linear_stiffness_and_damping_are_named() -> None:
    r = impact_record("nl_damping", snr_db=45.0, seed=2)
    w0 = int(np.argmax(np.abs(r.x)))
    x, v = r.x[w0:], r.v[w0:]
    assert model_warnings(r.eom, x, v) == ()  # b1 v + b2 x^2 v: positive
    bad_k = _variant(r.eom, stiffness={"x": -14684.0, "x^3": 1.5e8})
    assert any("negative linear stiffness" in w for w in model_warnings(bad_k, x, v))
    bad_b = _variant(r.eom, damping={"v": -0.45, "x^2*v": 1.0e4})
    assert any("negative damping" in w for w in model_warnings(bad_b, x, v))
    # the paper's b1 v - b2 x^2 v + b3 v^3 (negative x^2*v, energy still dissipated per half cycle)
    paper = _variant(r.eom, damping={"v": 0.45, "x^2*v": -1.0e4, "v^3": 0.0})
    amp = float(np.max(np.abs(x)))
    assert 1.0e4 * amp**2 < 0.45 or any("negative damping" in w for w in model_warnings(paper, x, v))


def test_pipeline_flags_a_model_that_does_not_decay_and_validate_says_diverged(tmp_path: Path) -> None:
    from station.cli import main

    r = impact_record("paper_do", snr_db=45.0, seed=2)
    csv = tmp_path / "rec.csv"
    np.savetxt(csv, np.column_stack((r.t, r.force, r.acc)), delimiter=",", header="t,force,acc", comments="")
    model = tmp_path / "m.json"
    model.write_text(_variant(r.eom, damping={"v": -0.3 * r.eom.damping["v"]}).to_json())
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        # a diverging model is flagged: exit 1 (station.cli.EXIT_FLAGGED), the result still printed
        assert main(["validate", str(model), str(csv), "--json"]) == 1
    rec = json.loads(buf.getvalue())["records"][0]
    assert rec["diverged"] is True and rec["warnings"]
    # the pipeline on the same record: a sound model, nothing to flag
    cond = condition(r.t, acc=r.acc, force=r.force)
    res = Pipeline(damping=("v",), stiffness=("x", "x^3"), refine=False).fit(cond, r.eom.mass)
    assert res.warnings == () and not res.validation.diverged and not res.unstable


def test_poor_fit_warnings_thresholds_from_the_contract() -> None:
    from eddi.stability import POOR_FIT_NRMSE, poor_fit_warnings

    assert poor_fit_warnings(0.5 * POOR_FIT_NRMSE, [0.9 * POOR_FIT_NRMSE]) == ()
    assert poor_fit_warnings(float("inf")) == ()  # left to the divergence warnings
    (fit,) = poor_fit_warnings(2 * POOR_FIT_NRMSE)
    assert fit.startswith("poor fit") and "0.2" in fit
    (held,) = poor_fit_warnings(0.01, [0.05, 3 * POOR_FIT_NRMSE, float("nan")])
    assert "up to 0.3" in held and "1 of 3" in held


@pytest.mark.parametrize("friction_n", [0.1, 0.2])
def test_dry_friction_outside_the_library_is_flagged_and_its_null_is_silent(friction_n: float) -> None:
    """Strong Coulomb friction identified with the default (smooth) library: a poor fit that
    exits 0 must say so; the same oscillator without friction must not."""
    from eddi.fit_record import Pipeline
    from tests.eddi.impact_cases import SYSTEMS

    base = dict(SYSTEMS["paper_do"], damping={"v": 0.3})
    for damping, flagged in (({"v": 0.3, "sign(v)": friction_n}, True), ({"v": 0.3}, False)):
        r = impact_record(dict(base, damping=damping), snr_db=45.0, seed=2)
        res = Pipeline.create().fit(condition(r.t, acc=r.acc, force=r.force), base["mass"])
        poor = [w for w in res.warnings if w.startswith("poor fit")]
        assert bool(poor) == flagged, (damping, res.validation.nrmse, res.warnings)


def test_damping_power_by_products_matches_the_kernel_and_skips_it(monkeypatch) -> None:
    """model_warnings' damping force (session 11: powers as repeated products, not the
    simulator's general kernel nor numpy's pow) equals the kernel's to rounding, for every
    kind of factor, and the check no longer calls the kernel."""
    import importlib
    from eddi.model import EquationOfMotion
    from eddi.stability import _damping_force

    n = 50_000
    t = np.arange(n) / 5000.0
    x = 1e-2 * np.sin(2 * np.pi * 12 * t) * np.exp(-t / 4)
    v = np.gradient(x, t)
    eom = EquationOfMotion.create(mass=0.8, damping={"v": 0.2, "x^2*v": -2.0e4, "v^3": 9.9, "sign(v)": 0.01,
                                                     "abs(v)*v": 0.3, "abs(x)*v": 2.0},
                                  stiffness={"x": 390.0, "x^3": 1.3e7})
    sim_mod = importlib.import_module("eddi.simulate")
    ref = sim_mod.internal_force(eom.model_copy(update={"stiffness": {}, "effects": ()}), x, v)
    got = _damping_force(eom, x, v)
    assert np.max(np.abs(got - ref)) <= 1e-14 * np.max(np.abs(ref))

    def refuse(*_a, **_k):
        raise AssertionError("the compiled kernel was called")

    monkeypatch.setattr(sim_mod, "internal_force", refuse)
    bad = EquationOfMotion.create(mass=0.8, damping={"v": -0.05}, stiffness={"x": 390.0})
    (msg,) = model_warnings(bad, x, v)
    assert msg.startswith("negative damping: the model feeds energy in over ")
    assert model_warnings(eom.model_copy(update={"damping": {"v": 0.2}}), x, v) == ()


def _damping_force_filled(eom, x, v):
    """eddi.stability._damping_force as it was before session 18 (filled arrays, a sum from zeros)."""
    from eddi.terms import parse_term

    out = np.zeros_like(v)
    ax, av = np.abs(x), np.abs(v)
    for text, c in eom.damping.items():
        px, pv, pax, pav, sx, sv = parse_term(text).exponents
        f = np.full_like(v, c)
        for base, p in ((x, px), (v, pv), (ax, pax), (av, pav)):
            for _ in range(p):
                f *= base
        if sx % 2:
            f *= np.sign(x)
        if sv % 2:
            f *= np.sign(v)
        out += f
    return out


@pytest.mark.parametrize("damping", [{"v": 0.196, "x^2*v": -20441.0, "v^3": 9.96}, {"v": 0.1}, {"v": -0.2},
                                     {"sign(v)": 0.3, "v": 0.1, "abs(x)*v": 2.0}, {"abs(v)*v": 1.0, "x^2*v": 2.0}])
def test_damping_force_is_the_filled_products_bit_for_bit(damping):
    # session 18 forms c * base directly and starts the sum with the first term (+ 0.0): the same
    # bytes, signed zeros included (x, v hold 0.0 and -0.0 samples)
    from eddi.model import EquationOfMotion
    from eddi.stability import _damping_force

    rng = np.random.default_rng(5)
    x, v = rng.standard_normal(5000) * 0.01, rng.standard_normal(5000) * 0.4
    x[::50], v[::37], v[::91] = 0.0, -0.0, 0.0
    eom = EquationOfMotion.create(mass=1.0, damping=damping, stiffness={"x": 100.0})
    assert _damping_force(eom, x, v).tobytes() == _damping_force_filled(eom, x, v).tobytes()
