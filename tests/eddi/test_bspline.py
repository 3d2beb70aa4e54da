"""eddi.bspline: numpy B-splines against scipy.interpolate's (to rounding) and exact cases."""

import numpy as np
import pytest

from eddi import bspline as B
from eddi.calculus import bspline_design_matrix


def _points(n, uniform, seed=1):
    if uniform:
        return np.linspace(0.0, 3.0, n)
    x = np.sort(np.random.default_rng(seed).uniform(0.0, 3.0, n))
    return x


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / max(float(np.max(np.abs(b))), 1e-300))


@pytest.mark.parametrize("k", [3, 5])
@pytest.mark.parametrize("n", [6, 9, 50, 2001])
@pytest.mark.parametrize("uniform", [True, False])
def test_interpolation_derivative_and_antiderivative_follow_scipy(k, n, uniform):
    from scipy.interpolate import make_interp_spline

    x = _points(n, uniform)
    y = np.column_stack((np.sin(5.0 * x), x * np.cos(x), np.random.default_rng(2).standard_normal(n)))
    ref = make_interp_spline(x, y, k=k, axis=0)
    mine = B.interpolate(x, y, k)
    np.testing.assert_array_equal(mine.t, ref.t)
    q = np.concatenate((x, np.random.default_rng(3).uniform(-0.1, 3.1, 300)))
    assert _rel(mine(x), y) <= 10 * _rel(ref(x), y) + 1e-14  # it interpolates as well as scipy's
    assert _rel(mine.c, ref.c) < 1e-10
    assert _rel(mine(q), ref(q)) < 1e-12
    assert _rel(mine.derivative()(q), ref.derivative()(q)) < 1e-11
    # the antiderivative sums 2000 pieces: 1.50e-11 on this machine's numpy 2.4.6 / scipy 1.17.1 (k 5,
    # 2001 random points; session 19's fresh venv and main alike), rounding either way
    assert _rel(mine.antiderivative()(q), ref.antiderivative()(q)) < 5e-11
    # one column alone: the same spline (inside: extrapolation ~0.1 beyond 2000 points amplifies rounding)
    inside = q[(q >= x[0]) & (q <= x[-1])]
    assert _rel(B.interpolate(x, y[:, 0], k)(inside), mine(inside)[:, 0]) < 1e-12


@pytest.mark.parametrize("k", [3, 5])
def test_a_polynomial_of_the_spline_degree_is_reproduced_exactly(k):
    x = _points(40, False, seed=7)
    y = 1.0 - 2.0 * x + 0.5 * x**k
    s = B.interpolate(x, y, k)
    q = np.linspace(0.0, 3.0, 77)
    np.testing.assert_allclose(s(q), 1.0 - 2.0 * q + 0.5 * q**k, rtol=0, atol=1e-11)
    np.testing.assert_allclose(s.derivative()(q), -2.0 + 0.5 * k * q ** (k - 1), rtol=0, atol=1e-9)
    anti = s.antiderivative()
    np.testing.assert_allclose(anti(q) - anti(x[0]), (q - 2 * q**2 / 2 + 0.5 * q ** (k + 1) / (k + 1))
                               - (x[0] - x[0] ** 2 + 0.5 * x[0] ** (k + 1) / (k + 1)), rtol=0, atol=1e-10)


def test_the_design_matrix_is_scipys():
    from scipy.interpolate import BSpline

    knots = np.concatenate(([0.0] * 3, np.linspace(0.0, 3.0, 11), [3.0] * 3))
    x = np.sort(np.random.default_rng(4).uniform(0.0, 3.0, 500))
    x[0], x[-1] = 0.0, 3.0
    mine = bspline_design_matrix(x, knots, 3)
    ref = BSpline.design_matrix(x, knots, 3)
    assert mine.shape == ref.shape
    assert _rel(mine.toarray(), ref.toarray()) < 1e-14
    np.testing.assert_allclose(mine.toarray().sum(axis=1), 1.0, rtol=1e-14)  # a partition of unity
    with pytest.raises(ValueError, match="outside"):
        bspline_design_matrix(np.array([3.5]), knots, 3)


def test_the_piecewise_form_is_scipys_from_spline():
    from scipy.interpolate import BSpline, PPoly

    knots = np.concatenate(([0.0] * 3, np.linspace(0.0, 3.0, 11), [3.0] * 3))
    c = np.random.default_rng(5).standard_normal(knots.size - 4)
    ref = PPoly.from_spline(BSpline(knots, c, 3, extrapolate=False), extrapolate=False)
    brk, coef = B.piecewise(B.Spline(knots, c, 3, extrapolate=False))
    keep = np.nonzero(brk[1:] > brk[:-1])[0]
    np.testing.assert_array_equal(brk, ref.x)
    assert _rel(coef[:, keep], ref.c[:, keep]) < 1e-13
    assert np.isnan(B.Spline(knots, c, 3, extrapolate=False)(np.array([-0.5, 3.5]))).all()


def test_the_cubic_hermite_is_scipys():
    from scipy.interpolate import CubicHermiteSpline

    x = _points(300, False, seed=6)
    q = np.random.default_rng(8).uniform(0.0, 3.0, 1000)
    assert _rel(B.hermite(x, np.sin(x), np.cos(x))(q), CubicHermiteSpline(x, np.sin(x), np.cos(x))(q)) < 1e-14


def test_bad_points_are_value_errors():
    with pytest.raises(ValueError, match="strictly increasing"):
        B.interpolate(np.array([0.0, 1.0, 1.0, 2.0, 3.0, 4.0]), np.zeros(6), 3)
    with pytest.raises(ValueError, match="odd"):
        B.interpolate(np.arange(8.0), np.zeros(8), 4)
    with pytest.raises(ValueError, match="strictly increasing"):
        B.hermite(np.array([1.0, 0.0]), np.zeros(2), np.zeros(2))


def _basis_values_numpy(t, k, x, ell):
    """basis_values as numpy column passes (sessions 17): the reference of the compiled pass."""
    b = np.zeros((x.size, k + 1))
    b[:, 0] = 1.0
    for j in range(1, k + 1):
        saved = np.zeros(x.size)
        for r in range(j):
            lo, hi = t[ell + 1 - j + r], t[ell + 1 + r]
            den = hi - lo
            term = np.divide(b[:, r], den, out=np.zeros(x.size), where=den != 0)
            b[:, r] = saved + (hi - x) * term
            saved = (x - lo) * term
        b[:, j] = saved
    return b


@pytest.mark.parametrize("k", [1, 3, 5])
def test_the_compiled_basis_values_are_the_numpy_passes_bit_for_bit(k):
    """Session 18: the Cox-de Boor recurrence as one compiled pass; repeated knots (zero spans) included."""
    rng = np.random.default_rng(9 + k)
    inner = np.sort(np.concatenate((rng.uniform(0.0, 3.0, 30), [1.0, 1.0, 2.0])))
    t = np.concatenate(([0.0] * (k + 1), inner, [3.0] * (k + 1)))
    x = np.concatenate((rng.uniform(0.0, 3.0, 4000), [0.0, 1.0, 2.0, 3.0]))
    ell = B._interval(t, k, x)
    np.testing.assert_array_equal(B.basis_values(t, k, x, ell), _basis_values_numpy(t, k, x, ell))
    # the design matrix holds them, as scipy's does (a partition of unity)
    rows = B.design_rows(x, t, k)
    np.testing.assert_allclose(rows.toarray().sum(axis=1), 1.0, rtol=1e-14)


def _random_rows(rng, n, q, w):
    return B.BandedRows(np.sort(rng.integers(0, q - w + 1, n)), rng.normal(size=(n, w)), q)


def test_banded_products_are_scipy_sparse_bit_for_bit():
    """BandedRows' products sum as scipy's CSR kernels do (row order), so every one is scipy.sparse's
    number exactly: A @ x, A.T @ y (vector and matrix), A.T @ A, A.T @ B, column sums of squares,
    sums and differences (windows joined), rows taken, blocks side by side."""
    from scipy import sparse

    rng = np.random.default_rng(21)
    n, q = 5000, 40
    a, b = _random_rows(rng, n, q, 4), _random_rows(rng, n, q, 6)
    sa, sb = a.tocsr(), b.tocsr()
    x, y, ym = rng.normal(size=q), rng.normal(size=n), rng.normal(size=(n, 3))
    assert np.array_equal(a @ x, sa @ x)
    assert np.array_equal(a.tmul(y), sa.T.tocsr() @ y)
    assert np.array_equal(a.tmul(ym), sa.T.tocsr() @ ym)
    assert np.array_equal(a.gram(), (sa.T.tocsr() @ sa).toarray())
    assert np.array_equal(a.gram(b), (sa.T.tocsr() @ sb).toarray())
    assert np.array_equal(a.column_sumsq(), np.asarray(sa.multiply(sa).sum(axis=0)).ravel())
    for got, ref in ((a + b, sa + sb), (a - b, sa - sb), (a.take(np.arange(n)[::-3]), sa[np.arange(n)[::-3]])):
        assert got.shape == ref.shape and np.array_equal(got.toarray(), ref.toarray())
        assert got.values.shape[1] < got.shape[1]  # still a window a row, not dense
    both = sparse.hstack([sa, sb], format="csr")
    z = rng.normal(size=2 * q)
    acc = a @ z[:q]
    assert np.array_equal(b.add_product(z[q:], acc), both @ z)
    with pytest.raises(ValueError):
        B.BandedRows(np.array([0, q - 3]), np.ones((2, 4)), q)  # a window past the last column
