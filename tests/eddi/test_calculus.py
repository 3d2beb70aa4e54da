"""The numerical toolbox (:mod:`eddi.calculus`): accuracy at the sampling a bench gives.

Exact references: sinusoids (closed-form integrals and derivatives) and simulated Duffing
impacts sampled at 41 samples per period (2048 Hz, 50 Hz), the case where the trapezoid
rule biased k3 by percents.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddi.calculus import (
    bspline_design_matrix,
    common_rate, cumulative_trapezoid, differentiate, integrate, resample, samples_per_cycle_note, spline_cumulative_integral,
    decimate_centred, spline_derivative,
)
from eddi.conditioning import condition
from eddi.fit_record import Pipeline
from tests.eddi.impact_cases import impact_record

FS = 5120.3277  # sample rate of the double-beam records [Hz]


@pytest.mark.parametrize("f_hz", [122.4, 243.4])
def test_high_order_calculus_is_exact_at_the_modal_frequencies(f_hz: float) -> None:
    dt = 1.0 / FS
    t = np.arange(20000) * dt
    w = 2 * math.pi * f_hz
    v = np.cos(w * t)
    x = integrate(v, dt)
    a = differentiate(v, dt)
    inner = slice(50, -50)
    exact_x = np.sin(w * t[inner]) / w
    dx = x[inner] - exact_x
    # up to the integration constant
    assert np.max(np.abs(dx - np.mean(dx))) * w < 2e-4
    assert np.max(np.abs(a[inner] + w * np.sin(w * t[inner]))) / w < 1e-5
    # a trapezoid would be off by (w dt)^2 / 12 = 1.9e-3 at 122 Hz: the reason for the stencils
    trap = np.concatenate(([0.0], np.cumsum(0.5 * dt * (v[1:] + v[:-1]))))
    dt_x = trap[inner] - exact_x
    assert np.max(np.abs(dt_x - np.mean(dt_x))) * w > 1e-3


@pytest.mark.parametrize("spc", [20.0, 41.0])
def test_integrals_at_20_and_41_samples_per_cycle(spc: float) -> None:
    dt = 1.0 / spc  # 1 Hz
    t = np.arange(int(40 * spc)) * dt
    w = 2 * math.pi
    y = np.cos(w * t)
    exact = np.sin(w * t) / w
    trap = np.concatenate(([0.0], np.cumsum(0.5 * dt * (y[1:] + y[:-1]))))
    inner = slice(3, -3)
    for got in (integrate(y, dt), spline_cumulative_integral(t, y), trap):
        d = (got - exact)[inner]
        err = np.max(np.abs(d - np.mean(d))) * w  # relative to the amplitude, up to the constant
        if got is trap:
            assert err > 0.9 * (w * dt) ** 2 / 12  # the trapezoid's loss, 0.8 % at 20 per cycle
        else:
            assert err < 2e-4 * (20.0 / spc) ** 4  # (w h)^4 terms: 1e-4 at 20, 6e-6 at 41


def test_spline_derivative_on_a_non_uniform_grid() -> None:
    # 20 samples per period, jittered times: the quintic spline's derivative is sixth-order
    # accurate inside (a central difference on these times would be off by ~1e-2)
    rng = np.random.default_rng(3)
    t = np.sort(np.arange(400) * 0.05 + rng.uniform(-0.01, 0.01, 400))
    w = 2 * math.pi
    d = spline_derivative(t, np.sin(w * t))
    inner = slice(10, -10)
    assert np.max(np.abs(d[inner] - w * np.cos(w * t[inner]))) / w < 2e-4
    assert np.max(np.abs(spline_derivative(t, np.sin(w * t), degree=1)[inner] - w * np.cos(w * t[inner]))) / w > 1e-3


def test_resample_36_and_200_ppm_onto_one_grid() -> None:
    rate = 2048.0
    for ppm in (36.0, 200.0, -200.0):
        r = rate * (1 + ppm * 1e-6)
        t = np.arange(8192) / r
        y = np.sin(2 * math.pi * 50.0 * t) * np.exp(-t)
        tn, yn = resample(t, y, rate)
        assert np.allclose(np.diff(tn), 1 / rate) and tn[0] == 0.0 and tn[-1] <= t[-1]
        exact = np.sin(2 * math.pi * 50.0 * tn) * np.exp(-tn)
        assert np.max(np.abs(yn - exact)[5:-5]) < 1e-5
    assert common_rate([rate, rate * (1 + 36e-6)]) == rate
    assert common_rate([rate, rate * (1 + 0.5e-6)]) is None
    with pytest.raises(ValueError, match="ppm"):
        common_rate([rate, rate * (1 + 300e-6)])


def test_coarse_sampling_warning_states_the_accuracy() -> None:
    assert samples_per_cycle_note(2048.0, 50.0) is None  # 41 per cycle: handled
    note = samples_per_cycle_note(1000.0, 80.0)  # 12.5 per cycle
    assert note is not None and "12.5 samples per cycle" in note and "%" in note


#: 50 Hz hardening oscillator, weakly nonlinear (k3 x^2 / k1 ~ 0.1 at the first peak), so
#: that a small bias of x shows as a large relative error of k3.
COARSE = dict(mass=1.0, damping={"v": 6.28}, stiffness={"x": 98696.0, "x^3": 2.8e8}, peak_n=1000.0)


@pytest.mark.parametrize("snr_db", [None, 45.0])
def test_41_samples_per_period_k3_within_1_percent(snr_db: float | None) -> None:
    r = impact_record(COARSE, rate_hz=2048.0, duration_s=3.0, pretrigger_s=0.5, pulse_s=3e-3,
                      snr_db=snr_db, seed=4)
    cond = condition(r.t, acc=r.acc, force=r.force)
    res = Pipeline(damping=("v",), stiffness=("x", "x^3")).fit(cond, 1.0)
    eom = res.model.eom
    assert eom.stiffness["x^3"] == pytest.approx(2.8e8, rel=0.01)
    assert eom.stiffness["x"] == pytest.approx(98696.0, rel=0.002)
    assert eom.damping["v"] == pytest.approx(6.28, rel=0.01)
    # noisy: only the sampling-kernel margin's note (session 12: x^3's interval holds interval means
    # too); clean: the harmonics show point samples (kernel ~0), no margin worth a sentence
    if snr_db is None:
        assert res.warnings == ()
    else:
        assert len(res.warnings) == 1 and res.warnings[0].startswith("coarse sampling: 40 samples per cycle")


def test_pipeline_warns_below_20_samples_per_cycle() -> None:
    # the same 50 Hz oscillator sampled at 800 Hz: 16 samples per cycle
    r = impact_record(COARSE, rate_hz=800.0, duration_s=3.0, pretrigger_s=0.5, pulse_s=5e-3, snr_db=45.0, seed=5)
    cond = condition(r.t, acc=r.acc, force=r.force)
    res = Pipeline(damping=("v",), stiffness=("x", "x^3"), refine=False).fit(cond, 1.0)
    coarse = [w for w in res.warnings if "samples per cycle" in w]
    assert len(coarse) == 1 and "fewer than 20" in coarse[0]


def test_dense_record_eddi_on_a_decimated_grid_gives_the_same_coefficients() -> None:
    # paper_do at 20 kHz (~5000 samples a cycle): EDDI runs on block centres (q >= 5) and must
    # give what it gives on every sample, within a small part of its own error at 45 dB
    from eddi.identify import identify
    from tests.eddi.impact_cases import SYSTEMS

    spec = SYSTEMS["paper_do"]
    r = impact_record(spec, rate_hz=20000.0, duration_s=4.0, pretrigger_s=0.3, snr_db=45.0, seed=2)
    cond = condition(r.t, acc=r.acc, force=r.force)
    res = Pipeline(damping=("v",), stiffness=("x", "x^3"), refine=False).fit(cond, spec["mass"])
    assert res.choices.decimation >= 5
    every = identify(cond.t, cond.x, cond.v, spec["mass"], damping="v", stiffness="x,x^3", a=cond.a,
                     window=cond.window)
    for group in ("damping", "stiffness"):
        for term, c in spec[group].items():
            dec, full = getattr(res.model.eom, group)[term], getattr(every.eom, group)[term]
            assert abs(dec - full) <= 0.1 * abs(full - c) + 1e-4 * abs(c), (term, dec, full, c)
    # the block means of the acceleration: centre values with 1/q of the noise
    q = res.choices.decimation
    w0, w1 = cond.window
    _, _, _, ad, idx = decimate_centred(cond.t[w0:w1], cond.x[w0:w1], cond.v[w0:w1], r.acc[w0:w1], q)
    exact = r.a[w0:w1][idx]
    ratio = np.std(ad - exact) / (np.std(r.acc[w0:w1] - r.a[w0:w1]) / math.sqrt(q))
    assert 0.9 < ratio < 1.25  # the curvature correction adds ~10 % to the block mean's noise


def test_free_drift_slope_removes_the_impact_step_from_x() -> None:
    # clean record at 41 samples a period: the integral over the impact leaves a small velocity
    # step; a drift clamped flat at the motion's start spreads it over the first knot
    # intervals (x off by 1.7e-3 of its RMS), a free slope takes it (3.9e-4)
    r = impact_record(COARSE, rate_hz=2048.0, duration_s=3.0, pretrigger_s=0.5, pulse_s=3e-3, snr_db=None, seed=4)
    errs = {}
    for free in (False, True):
        cond = condition(r.t, acc=r.acc, force=r.force, free_drift_slope=free)
        w0, w1 = cond.window
        errs[free] = np.linalg.norm(cond.x[w0:w1] - r.x[w0:w1]) / np.linalg.norm(r.x[w0:w1])
    assert errs[True] < 6e-4 < 1.2e-3 < errs[False]


def test_cumulative_trapezoid_is_scipys_bit_for_bit() -> None:
    """The conditioner's trapezoid (no scipy.integrate import) is scipy's arithmetic exactly."""
    from scipy.integrate import cumulative_trapezoid as scipy_ct

    rng = np.random.default_rng(7)
    t = np.cumsum(rng.uniform(0.5, 1.5, 1001)) * 1e-3  # a non-uniform grid
    y = np.sin(40.0 * t) + 0.01 * rng.normal(size=t.size)
    np.testing.assert_array_equal(cumulative_trapezoid(y, t), scipy_ct(y, t, initial=0.0))
    np.testing.assert_array_equal(cumulative_trapezoid(y[:1], t[:1]), [0.0])
    with pytest.raises(ValueError):
        cumulative_trapezoid(y, t[:-1])


@pytest.mark.parametrize("n", [2, 3, 4, 5, 9, 2000])
def test_integrate_stencil_and_trapezoid_split(n: int) -> None:
    """``integrate`` = trapezoid before ``smooth_from`` (and on the last interval), the 4th-order
    stencil between, for every split (written out term by term here)."""
    rng = np.random.default_rng(n)
    y, dt = rng.normal(size=n), 0.003
    for smooth_from in sorted({0, 1, 2, n // 2, n - 3, n - 2, n - 1, n, n + 5}):
        inc = 0.5 * dt * (y[:-1] + y[1:])
        k = max(1, smooth_from)
        for j in range(k, n - 2):
            inc[j] = dt / 24.0 * (-y[j - 1] + 13.0 * y[j] + 13.0 * y[j + 1] - y[j + 2])
        expect = np.concatenate(([0.0], np.cumsum(inc)))
        np.testing.assert_allclose(integrate(y, dt, smooth_from), expect, rtol=0, atol=1e-13 * n * dt)


def test_trapezoid_is_the_trapezoid_rule_on_uniform_and_uneven_points() -> None:
    from eddi.calculus import trapezoid

    rng = np.random.default_rng(3)
    y = rng.normal(size=501)
    x = np.sort(rng.uniform(0.0, 2.0, 501))
    ref = 0.5 * np.sum(np.diff(x) * (y[1:] + y[:-1]))
    assert trapezoid(y, x) == pytest.approx(ref, rel=1e-14, abs=1e-14)
    assert trapezoid(y, dx=0.01) == pytest.approx(0.01 * (np.sum(y) - 0.5 * (y[0] + y[-1])), rel=1e-12, abs=1e-14)
    # exact for a straight line: integral of 3 t + 1 over [0, 2] is 8
    t = np.linspace(0.0, 2.0, 7)
    assert trapezoid(3 * t + 1, t) == pytest.approx(8.0, rel=1e-15)
    assert trapezoid(np.array([5.0])) == 0.0


def test_decimation_factor_reads_the_working_rate_at_the_call(monkeypatch):
    """benchmarks/bench_eddi_rate.py compares EDDI's working rates by setting
    DECIMATE_H_OMEGA: the factor follows it (it was bound at definition before session 11)."""
    import eddi.calculus as ec

    omega = 2 * np.pi * 12.0 * 1.5
    assert ec.decimation_factor(19200.0, omega) == 15  # 0.1 rad a step: ~63 samples a cycle of 1.5 omega
    monkeypatch.setattr(ec, "DECIMATE_H_OMEGA", 0.2)
    assert ec.decimation_factor(19200.0, omega) == 33
    assert ec.decimation_factor(19200.0, omega, h_omega=0.1) == 15


@pytest.mark.parametrize("k", [1, 3, 5])
def test_bspline_design_matrix_is_scipys_bit_for_bit(k: int) -> None:
    """The same CSR entries as ``BSpline.design_matrix`` (its own bounds check), points on the knots
    and at both ends included, clamped and uniform knots; out of the base interval or NaN: ValueError.
    And no interpreted pass over the points (scipy's ``min(x)``/``max(x)``): the session-12 speed-up."""
    import builtins

    from scipy.interpolate import BSpline

    rng = np.random.default_rng(7)
    inner = np.linspace(0.3, 45.3, 91)
    for knots in (np.concatenate(([inner[0]] * k, inner, [inner[-1]] * k)), np.linspace(-1.0, 2.0, 40)):
        lo, hi = knots[k], knots[knots.size - k - 1]
        x = np.sort(np.concatenate((rng.uniform(lo, hi, 5000), knots[(knots >= lo) & (knots <= hi)], [lo, hi])))
        want = BSpline.design_matrix(x, knots, k)
        got = bspline_design_matrix(x, knots, k)
        assert got.shape == want.shape
        for name in ("data", "indices", "indptr"):
            assert np.array_equal(getattr(got, name), getattr(want, name)), name
        for bad in (np.append(x, hi + 1e-9), np.insert(x, 0, lo - 1e-9), np.append(x, np.nan)):
            with pytest.raises(ValueError):
                bspline_design_matrix(bad, knots, k)
    seen = []
    real_min = builtins.min

    def counting_min(*a, **kw):
        seen.append(a)
        return real_min(*a, **kw)

    builtins.min = counting_min
    try:
        bspline_design_matrix(x, knots, k)
    finally:
        builtins.min = real_min
    assert not any(len(a) == 1 and isinstance(a[0], np.ndarray) for a in seen)



def test_integrate_into_a_slice_is_the_same_bits_and_refuses_overlap() -> None:
    """``integrate(..., out=)`` (the conditioning integrates into its record's arrays: no
    temporary of the record's length, no copy): the same bits as the returned array."""
    rng = np.random.default_rng(5)
    y = np.cumsum(rng.standard_normal(10_001)) * 1e-3
    for smooth in (0, 7, 500):
        want = integrate(y[3:], 1e-4, smooth_from=smooth)
        buf = np.full(y.size, 9.0)
        got = integrate(y[3:], 1e-4, smooth_from=smooth, out=buf[3:])
        assert np.shares_memory(got, buf) and np.array_equal(buf[3:], want) and np.all(buf[:3] == 9.0)
    with pytest.raises(ValueError):
        integrate(y, 1e-4, out=y)
    with pytest.raises(ValueError):
        integrate(y, 1e-4, out=np.empty(y.size - 1))
    assert np.array_equal(integrate(y[:1], 1e-4, out=np.full(1, 3.0)), [0.0])
