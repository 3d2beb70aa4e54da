"""``eddi.splines`` reproduces SciPy's splines (the reference it replaces on the hot path)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid as scipy_cumtrapz
from scipy.interpolate import BSpline, CubicHermiteSpline, make_interp_spline

from eddi.conditioning import cumulative_trapezoid
from eddi.splines import Spline, basis_rows, cubic_hermite, interpolating_spline


@pytest.mark.parametrize("n", [6, 7, 12, 200])
@pytest.mark.parametrize("k", [3, 5])
def test_interpolating_spline_equals_scipys_make_interp_spline(n: int, k: int) -> None:
    rng = np.random.default_rng(n + k)
    x = np.cumsum(rng.random(n) + 0.1)  # non-uniform sites
    y = np.column_stack((np.sin(x), np.cos(2 * x) * x, np.exp(-x / 5)))
    ref = make_interp_spline(x, y, k=k, axis=0)
    ours = interpolating_spline(x, y, k)
    xq = np.linspace(x[0] - 0.3, x[-1] + 0.3, 501)  # inside and extrapolated
    scale = float(np.max(np.abs(y)))
    assert np.max(np.abs(ours(xq) - ref(xq))) < 1e-12 * scale
    assert np.max(np.abs(ours(x) - y)) < 1e-12 * scale  # it interpolates
    assert np.max(np.abs(ours.antiderivative()(xq) - ref.antiderivative()(xq))) < 1e-11 * scale * x[-1]
    assert np.max(np.abs(ours.derivative()(xq) - ref.derivative()(xq))) < 1e-10 * scale
    one = interpolating_spline(x, y[:, 0], k)
    assert one(xq).shape == xq.shape and one.antiderivative()(xq).shape == xq.shape
    assert ours.antiderivative()(np.array([x[0]])) == pytest.approx(0.0, abs=1e-15)


def test_long_uniform_record_matches_scipy() -> None:
    t = np.arange(20000) / 1e4
    p = np.column_stack((np.sin(2 * np.pi * 35 * t) ** 2 * np.exp(-t), np.cos(2 * np.pi * 35 * t) ** 4))
    ref = make_interp_spline(t, p, k=5, axis=0).antiderivative()
    ours = interpolating_spline(t, p, 5).antiderivative()
    tq = np.sort(np.random.default_rng(1).random(3000)) * t[-1]
    assert np.max(np.abs(ours(tq) - ref(tq))) < 1e-13 * float(np.max(np.abs(ref(tq))))


def test_interpolating_spline_refuses_bad_input() -> None:
    with pytest.raises(ValueError, match="odd degree"):
        interpolating_spline(np.arange(10.0), np.arange(10.0), 4)
    with pytest.raises(ValueError, match="strictly increasing"):
        interpolating_spline(np.array([0.0, 1, 1, 2, 3, 4, 5]), np.zeros(7), 5)
    with pytest.raises(ValueError, match=">= 6"):
        interpolating_spline(np.arange(5.0), np.zeros(5), 5)


def test_cubic_hermite_equals_scipys() -> None:
    rng = np.random.default_rng(2)
    x = np.cumsum(rng.random(40) + 0.05)
    xq = np.linspace(x[0] - 0.5, x[-1] + 0.5, 999)
    ref = CubicHermiteSpline(x, np.sin(x), np.cos(x))(xq)
    assert np.max(np.abs(cubic_hermite(x, np.sin(x), np.cos(x), xq) - ref)) < 1e-13


def test_basis_rows_and_evaluation_equal_scipys_bspline() -> None:
    rng = np.random.default_rng(3)
    knots = np.concatenate(([0.0] * 3, np.linspace(0.0, 7.0, 12), [7.0] * 3))
    xq = np.concatenate((np.sort(rng.random(300) * 7.0), [0.0, 7.0]))
    spans, vals = basis_rows(knots, 3, xq)
    dense = np.zeros((xq.size, knots.size - 4))
    for j, (s, row) in enumerate(zip(spans, vals)):
        dense[j, s - 3: s + 1] = row
    assert np.max(np.abs(dense - BSpline.design_matrix(xq, knots, 3).toarray())) < 1e-15
    c = rng.standard_normal(knots.size - 4)
    ref = BSpline(knots, c, 3)
    ours = Spline(knots, c, 3)
    assert np.max(np.abs(ours(xq) - ref(xq))) < 1e-13
    assert np.max(np.abs(ours.derivative()(xq) - ref.derivative()(xq))) < 1e-12


def test_cumulative_trapezoid_equals_scipys() -> None:
    rng = np.random.default_rng(4)
    x = np.cumsum(rng.random(500))
    y = rng.standard_normal(500)
    assert np.array_equal(cumulative_trapezoid(y, x), scipy_cumtrapz(y, x, initial=0.0))
