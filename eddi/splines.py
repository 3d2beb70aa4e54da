"""B-splines for the identification hot path, without importing ``scipy.interpolate``.

Why this module exists: ``import scipy.interpolate`` costs ~0.45 s of CPU (SciPy 1.17 also
imports ``scipy.special``, ``scipy.optimize`` and, through its array-API layer,
``numpy.f2py`` and ``numpy.testing``), about a quarter of the whole ``station identify``
budget (< 2 s). The engine needs little of it: an interpolating spline (the quintic of
phase one's quadrature), its antiderivative and derivative, a cubic Hermite interpolant,
and a least-squares cubic spline (conditioning's drift). These are the textbook algorithms
(de Boor, *A Practical Guide to Splines*; Piegl & Tiller, *The NURBS Book*, A2.1-A2.2),
compiled with numba, and they reproduce SciPy's ``make_interp_spline`` (same not-a-knot
knots, same collocation) to rounding (``tests/eddi/test_splines.py`` checks against SciPy).

All splines are clamped: knots ``t`` of length ``n + k + 1`` for ``n`` coefficients of
degree ``k``, the first and last ``k + 1`` knots equal. Outside ``[t[k], t[n]]`` the end
polynomials are extended.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def _span(t: np.ndarray, k: int, n: int, x: float) -> int:  # pragma: no cover - compiled
    """Index ``i`` in ``[k, n - 1]`` with ``t[i] <= x < t[i + 1]`` (ends clamped)."""
    if x >= t[n]:
        return n - 1
    if x <= t[k]:
        return k
    lo, hi = k, n
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if x >= t[mid]:
            lo = mid
        else:
            hi = mid
    return lo


@numba.njit(cache=True, nogil=True)
def _basis(t: np.ndarray, k: int, i: int, x: float, out: np.ndarray,
           left: np.ndarray, right: np.ndarray) -> None:  # pragma: no cover - compiled
    """The ``k + 1`` non-zero B-splines ``N_{i-k..i, k}(x)`` (NURBS Book A2.2)."""
    out[0] = 1.0
    for j in range(1, k + 1):
        left[j] = x - t[i + 1 - j]
        right[j] = t[i + j] - x
        saved = 0.0
        for r in range(j):
            temp = out[r] / (right[r + 1] + left[j - r])
            out[r] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        out[j] = saved


@numba.njit(cache=True, nogil=True)
def _evaluate(t: np.ndarray, c: np.ndarray, k: int, xq: np.ndarray) -> np.ndarray:  # pragma: no cover
    """Spline values at ``xq``; ``c`` has shape (n, m)."""
    n = c.shape[0]
    m = c.shape[1]
    out = np.zeros((xq.size, m))
    nb = np.empty(k + 1)
    left = np.empty(k + 1)
    right = np.empty(k + 1)
    for q in range(xq.size):
        i = _span(t, k, n, xq[q])
        _basis(t, k, i, xq[q], nb, left, right)
        for r in range(k + 1):
            b = nb[r]
            row = i - k + r
            for col in range(m):
                out[q, col] += b * c[row, col]
    return out


@numba.njit(cache=True, nogil=True)
def _basis_rows(t: np.ndarray, k: int, n: int, xq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover
    """Spans and non-zero basis values at ``xq``: shapes (q,) and (q, k + 1)."""
    spans = np.empty(xq.size, dtype=np.int64)
    vals = np.empty((xq.size, k + 1))
    nb = np.empty(k + 1)
    left = np.empty(k + 1)
    right = np.empty(k + 1)
    for q in range(xq.size):
        i = _span(t, k, n, xq[q])
        _basis(t, k, i, xq[q], nb, left, right)
        spans[q] = i
        vals[q, :] = nb
    return spans, vals


@numba.njit(cache=True, nogil=True)
def _solve_collocation(spans: np.ndarray, vals: np.ndarray, k: int, y: np.ndarray) -> np.ndarray:  # pragma: no cover
    """Solve the banded collocation system ``A c = y`` by elimination without pivoting.

    Row ``j`` of ``A`` holds ``vals[j]`` in columns ``spans[j] - k .. spans[j]``. A B-spline
    collocation matrix that satisfies the Schoenberg-Whitney conditions is totally positive,
    so elimination without pivoting is stable (de Boor, Ch. XIII).
    """
    n = spans.size
    w = 2 * k + 1
    band = np.zeros((n, w))  # A[j, col] at band[j, col - j + k]
    for j in range(n):
        for r in range(k + 1):
            col = spans[j] - k + r
            off = col - j + k
            if off < 0 or off >= w:
                if vals[j, r] != 0.0:
                    return np.full(y.shape, np.nan)
                continue
            band[j, off] = vals[j, r]
    c = y.copy()
    m = y.shape[1]
    for j in range(n):
        piv = band[j, k]
        if piv == 0.0:
            return np.full(y.shape, np.nan)
        for r in range(j + 1, min(j + k + 1, n)):
            off = j - r + k
            f = band[r, off] / piv
            if f == 0.0:
                continue
            for cc in range(j, min(j + k + 1, n)):
                band[r, cc - r + k] -= f * band[j, cc - j + k]
            for col in range(m):
                c[r, col] -= f * c[j, col]
    for j in range(n - 1, -1, -1):
        for cc in range(j + 1, min(j + k + 1, n)):
            a = band[j, cc - j + k]
            if a != 0.0:
                for col in range(m):
                    c[j, col] -= a * c[cc, col]
        piv = band[j, k]
        for col in range(m):
            c[j, col] /= piv
    return c


class Spline:
    """A clamped B-spline ``s(x) = sum_i c_i B_{i,k}(x)`` (values may be vectors).

    Parameters
    ----------
    t : ndarray, shape (n + k + 1,)
        Knots (clamped).
    c : ndarray, shape (n,) or (n, m)
        Coefficients.
    k : int
        Degree.
    """

    def __init__(self, t: np.ndarray, c: np.ndarray, k: int) -> None:
        self.t = np.ascontiguousarray(t, dtype=float)
        c = np.asarray(c, dtype=float)
        self._vector = c.ndim == 1
        self.c = np.ascontiguousarray(c.reshape(c.shape[0], -1))
        self.k = int(k)

    def __call__(self, xq: np.ndarray | float) -> np.ndarray:
        """Values at ``xq`` (shape of ``xq``, plus the value dimension for vector splines)."""
        xq_arr = np.asarray(xq, dtype=float)
        out = _evaluate(self.t, self.c, self.k, np.ascontiguousarray(xq_arr.ravel()))
        if self._vector:
            return out[:, 0].reshape(xq_arr.shape)
        return out.reshape(xq_arr.shape + (self.c.shape[1],))

    def antiderivative(self) -> "Spline":
        """The antiderivative that is 0 at ``t[0]`` (degree ``k + 1``)."""
        t, c, k = self.t, self.c, self.k
        dt = t[k + 1:] - t[: -k - 1]
        ci = np.cumsum(c * dt[:, None], axis=0) / (k + 1)
        ci = np.vstack((np.zeros((1, c.shape[1])), ci))
        return Spline(np.concatenate(([t[0]], t, [t[-1]])), ci[:, 0] if self._vector else ci, k + 1)

    def derivative(self) -> "Spline":
        """The derivative (degree ``k - 1``)."""
        t, c, k = self.t, self.c, self.k
        if k == 0:
            return Spline(t, np.zeros_like(c[:, 0] if self._vector else c), 0)
        denom = t[k + 1: k + c.shape[0]] - t[1: c.shape[0]]
        dc = k * np.diff(c, axis=0) / np.where(denom > 0, denom, 1.0)[:, None]
        return Spline(t[1:-1], dc[:, 0] if self._vector else dc, k - 1)


def not_a_knot_knots(x: np.ndarray, k: int) -> np.ndarray:
    """Knots of the odd-degree interpolating spline with not-a-knot ends (as SciPy's).

    Interior knots are the data sites ``x[m+1 : -m-1]``, ``m = (k - 1) / 2``.
    """
    m = (k - 1) // 2
    return np.concatenate(([x[0]] * (k + 1), x[m + 1: x.size - m - 1], [x[-1]] * (k + 1)))


def interpolating_spline(x: np.ndarray, y: np.ndarray, k: int = 5) -> Spline:
    """The interpolating spline of odd degree ``k`` with not-a-knot ends.

    Same knots and conditions as ``scipy.interpolate.make_interp_spline(x, y, k)``.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Increasing sites, ``n >= k + 1``.
    y : ndarray, shape (n,) or (n, m)
        Values.
    k : int
        Odd degree.

    Returns
    -------
    Spline

    Raises
    ------
    ValueError
        Even degree, too few or non-increasing sites, or a singular system.
    """
    x = np.ascontiguousarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if k % 2 != 1:
        raise ValueError(f"odd degree expected, got {k}")
    if x.ndim != 1 or x.size < k + 1 or np.any(np.diff(x) <= 0):
        raise ValueError(f"need >= {k + 1} strictly increasing sites, got {x.size}")
    t = not_a_knot_knots(x, k)
    spans, vals = _basis_rows(t, k, x.size, x)
    y2 = np.ascontiguousarray(y.reshape(x.size, -1))
    c = _solve_collocation(spans, vals, k, y2)
    if not np.all(np.isfinite(c)):
        raise ValueError("singular collocation system")
    return Spline(t, c[:, 0] if y.ndim == 1 else c, k)


def cubic_hermite(x: np.ndarray, y: np.ndarray, dydx: np.ndarray, xq: np.ndarray) -> np.ndarray:
    """The piecewise cubic Hermite interpolant of ``(x, y, dy/dx)`` at ``xq``.

    Same values as ``scipy.interpolate.CubicHermiteSpline(x, y, dydx)(xq)`` (ends extended).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Increasing sites.
    y, dydx : ndarray, shape (n,)
    xq : ndarray, shape (q,)

    Returns
    -------
    ndarray, shape (q,)
    """
    x = np.asarray(x, dtype=float)
    xq = np.asarray(xq, dtype=float)
    i = np.clip(np.searchsorted(x, xq, side="right") - 1, 0, x.size - 2)
    h = x[i + 1] - x[i]
    s = (xq - x[i]) / h
    s2 = s * s
    s3 = s2 * s
    return ((2 * s3 - 3 * s2 + 1) * y[i] + (s3 - 2 * s2 + s) * h * dydx[i]
            + (-2 * s3 + 3 * s2) * y[i + 1] + (s3 - s2) * h * dydx[i + 1])


def basis_rows(t: np.ndarray, k: int, xq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Non-zero B-spline values at ``xq``, for least-squares fits.

    Parameters
    ----------
    t : ndarray, shape (n + k + 1,)
        Clamped knots.
    k : int
        Degree.
    xq : ndarray, shape (q,)

    Returns
    -------
    spans : ndarray of int, shape (q,)
        Row ``j`` is non-zero in columns ``spans[j] - k .. spans[j]``.
    values : ndarray, shape (q, k + 1)
    """
    n = t.size - k - 1
    return _basis_rows(np.ascontiguousarray(t, dtype=float), k, n,
                       np.ascontiguousarray(xq, dtype=float))
