"""B-splines in numpy: design matrices, interpolation, evaluation, calculus, piecewise form.

The engine's splines (the conditioning's drift spline, EDDI's energy integrals and rate
interpolant, :mod:`eddi.calculus`' spline derivative / integral / resampling) as
``scipy.interpolate`` computes them - ``BSpline``, ``BSpline.design_matrix``,
``make_interp_spline`` (not-a-knot), ``.derivative()``, ``.antiderivative()``,
``PPoly.from_spline``, ``CubicHermiteSpline`` - to rounding, not bit for bit.

Why not scipy's: ``scipy.interpolate._bsplines`` imports ``scipy.optimize`` at module
level, and ``scipy.optimize``'s ``__init__`` imports every solver (sparse, special,
spatial, fft): ~0.13 s of CPU of each ``station identify`` process, the engine's only use
of both being these splines and the refinement's least squares (:mod:`eddi.lsq`).

The interpolation's collocation system is banded (at most ``k`` sub- and super-diagonals);
it is solved by a compiled banded elimination without pivoting (:func:`_banded_solve`, as de
Boor's ``banfac``: the collocation matrix is totally positive; :mod:`eddi.kernels`) instead of
LAPACK's pivoted banded LU (scipy's ``gbsv``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eddi.kernels import Kernels


@dataclass(frozen=True, eq=False)
class Spline:
    """``s(x) = sum_j c[j] B_j(x)``: knots ``t`` (non-decreasing), coefficients ``c`` (``n`` or ``(n, m)``),
    degree ``k``; outside ``[t[k], t[n]]`` the end polynomials continue (``extrapolate``) or NaN."""

    t: np.ndarray
    c: np.ndarray
    k: int
    extrapolate: bool = True

    def __call__(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        flat = x.ravel()
        ell = _interval(self.t, self.k, flat)
        b = basis_values(self.t, self.k, flat, ell)
        cols = ell[:, None] - self.k + np.arange(self.k + 1)
        c = self.c[cols]  # (points, k + 1[, m])
        out = np.einsum("pj,pj...->p...", b, c)
        if not self.extrapolate:
            out[(flat < self.t[self.k]) | (flat > self.t[self.t.size - self.k - 1])] = np.nan
        return out.reshape(x.shape + self.c.shape[1:])

    def derivative(self) -> Spline:
        """The derivative (degree ``k - 1``; scipy's ``splder``)."""
        t, c, k = self.t, self.c, self.k
        n = c.shape[0]
        dt = t[k + 1: k + n] - t[1: n]
        dt = np.where(dt > 0, dt, 1.0).reshape((-1,) + (1,) * (c.ndim - 1))
        return Spline(t[1:-1], k * (c[1:] - c[:-1]) / dt, k - 1, self.extrapolate)

    def antiderivative(self) -> Spline:
        """The antiderivative from ``t[0]`` (degree ``k + 1``; scipy's ``splantider``)."""
        t, c, k = self.t, self.c, self.k
        dt = (t[k + 1:] - t[: t.size - k - 1]).reshape((-1,) + (1,) * (c.ndim - 1))
        cs = np.cumsum(c * dt, axis=0) / (k + 1)
        return Spline(np.concatenate(([t[0]], t, [t[-1]])), np.concatenate((np.zeros((1,) + c.shape[1:]), cs)),
                      k + 1, self.extrapolate)


def _interval(t: np.ndarray, k: int, x: np.ndarray) -> np.ndarray:
    """The knot interval ``l`` (``t[l] <= x < t[l+1]``, clipped to ``[k, n - 1]``) of each point."""
    n = t.size - k - 1
    return np.clip(np.searchsorted(t, x, side="right") - 1, k, n - 1)


def basis_values(t: np.ndarray, k: int, x: np.ndarray, ell: np.ndarray) -> np.ndarray:
    """The ``k + 1`` B-splines non-zero in interval ``ell`` at ``x`` (Cox-de Boor): ``(points, k + 1)``,
    column ``j`` being ``B_{ell - k + j}``."""
    x = np.asarray(x, dtype=float)
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


def design_matrix_parts(x: np.ndarray, t: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """``BSpline.design_matrix(x, t, k)`` as CSR parts: (data, indices, indptr, columns); ``x``
    inside ``[t[k], t[n]]`` (checked by the caller), ``k + 1`` entries a row."""
    x = np.asarray(x, dtype=float)
    ell = _interval(t, k, x)
    data = basis_values(t, k, x, ell).ravel()
    indices = (ell[:, None] - k + np.arange(k + 1)).ravel().astype(np.int32)
    indptr = np.arange(0, (k + 1) * x.size + 1, k + 1, dtype=np.int32)
    return data, indices, indptr, t.size - k - 1


def not_a_knot_knots(x: np.ndarray, k: int) -> np.ndarray:
    """scipy's not-a-knot knots for an odd degree ``k``: the data, less ``(k - 1) / 2 + 1`` at each end."""
    m = (k - 1) // 2
    return np.concatenate(([x[0]] * (k + 1), x[m + 1: x.size - m - 1], [x[-1]] * (k + 1)))


def interpolate(x, y, k: int = 3) -> Spline:
    """``make_interp_spline(x, y, k)`` (odd ``k``, not-a-knot ends; ``y`` of shape ``(n,)`` or ``(n, m)``)."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if k % 2 != 1 or k < 1:
        raise ValueError(f"spline degree must be odd, got {k}")
    if x.ndim != 1 or y.shape[:1] != x.shape or x.size < k + 1:
        raise ValueError(f"need {k + 1} or more points with one value each, got x {x.shape} and y {y.shape}")
    if not (np.all(np.isfinite(x)) and np.all(np.diff(x) > 0)):
        raise ValueError("x must be finite and strictly increasing")
    if k == 1:
        return Spline(np.concatenate(([x[0]], x, [x[-1]])), y.copy(), 1)
    t = not_a_knot_knots(x, k)
    n = x.size
    ell = _interval(t, k, x)
    vals = basis_values(t, k, x, ell)
    # the collocation matrix in band storage: row i holds A[i, i - kl + j] at j
    rows = np.repeat(np.arange(n), k + 1)
    cols = (ell[:, None] - k + np.arange(k + 1)).ravel()
    kl, ku = int(np.max(rows - cols)), int(np.max(cols - rows))
    band = np.zeros((n, kl + ku + 1))
    band[rows, kl + cols - rows] = vals.ravel()
    rhs = np.ascontiguousarray(y.reshape(n, -1), dtype=float).copy()
    _KERNELS._banded_solve(band, kl, ku, rhs)
    if not np.all(np.isfinite(rhs)):
        raise ValueError("spline interpolation: the collocation system is singular (points too close?)")
    return Spline(t, rhs.reshape(y.shape), k)


def _banded_solve(ab, kl, ku, b):  # pragma: no cover - compiled
    """Solve a banded system in place (Gaussian elimination without pivoting, as de Boor's
    ``banfac`` / ``banslv``: a B-spline collocation matrix is totally positive). ``ab[i, kl + c - i]``
    holds ``A[i, c]``; ``b`` (n, m) becomes the solution."""
    n = ab.shape[0]
    m = b.shape[1]
    for i in range(n):
        piv = ab[i, kl]
        last = min(n, i + kl + 1)
        for r in range(i + 1, last):
            f = ab[r, kl - (r - i)] / piv
            if f != 0.0:
                for c in range(1, min(ku, n - 1 - i) + 1):
                    ab[r, kl - (r - i) + c] -= f * ab[i, kl + c]
                for q in range(m):
                    b[r, q] -= f * b[i, q]
    for i in range(n - 1, -1, -1):
        for c in range(1, min(ku, n - 1 - i) + 1):
            u = ab[i, kl + c]
            for q in range(m):
                b[i, q] -= u * b[i + c, q]
        piv = ab[i, kl]
        for q in range(m):
            b[i, q] /= piv


def piecewise(spl: Spline) -> tuple[np.ndarray, np.ndarray]:
    """``PPoly.from_spline(spl)``'s breakpoints and coefficients: ``(t, c)``, ``c[k - m, i]`` the
    ``m``-th derivative at ``t[i]`` over ``m!`` (from the right; interval ``i`` of non-zero length)."""
    t, k = spl.t, spl.k
    left = t[:-1]
    ell = np.clip(np.arange(t.size - 1), k, t.size - k - 2)
    out = np.empty((k + 1, t.size - 1) + spl.c.shape[1:])
    s = spl
    for m in range(k + 1):
        b = basis_values(s.t, s.k, left, ell - m)
        cols = (ell - m)[:, None] - s.k + np.arange(s.k + 1)
        out[k - m] = np.einsum("pj,pj...->p...", b, s.c[cols]) / math.factorial(m)
        if m < k:
            s = s.derivative()
    return t, out


@dataclass(frozen=True, eq=False)
class CubicHermite:
    """``CubicHermiteSpline(x, y, dydx)``: the cubic of each interval from the values and slopes at its ends."""

    x: np.ndarray
    y: np.ndarray
    dydx: np.ndarray

    def __call__(self, xq) -> np.ndarray:
        x, y, d = self.x, self.y, self.dydx
        xq = np.asarray(xq, dtype=float)
        i = np.clip(np.searchsorted(x, xq, side="right") - 1, 0, x.size - 2)
        h = x[i + 1] - x[i]
        slope = (y[i + 1] - y[i]) / h
        tt = (d[i] + d[i + 1] - 2.0 * slope) / h
        c0, c1 = tt / h, (slope - d[i]) / h - tt
        u = xq - x[i]
        return ((c0 * u + c1) * u + d[i]) * u + y[i]


def hermite(x, y, dydx) -> CubicHermite:
    """A :class:`CubicHermite` (``x`` strictly increasing, one ``y`` and one slope per point)."""
    x, y, d = (np.asarray(a, dtype=float) for a in (x, y, dydx))
    if x.ndim != 1 or x.size < 2 or y.shape != x.shape or d.shape != x.shape or not np.all(np.diff(x) > 0):
        raise ValueError("cubic Hermite: x strictly increasing (2 or more points), one y and dydx each")
    return CubicHermite(x, y, d)


#: The compiled kernel (:mod:`eddi.kernels`: built ahead of time, else numba's JIT).
_KERNELS = Kernels(globals(), {
    "_banded_solve": ["void(f8[:, ::1], i8, i8, f8[:, ::1])"],
})
