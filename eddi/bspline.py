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

The design matrix is a :class:`BandedRows` (each row's ``k + 1`` values in one window of
columns), with the products the engine's least squares need (Gram matrix, transposed
products, scaling, sums): the drift splines' and EDDI's nuisance columns
(:mod:`eddi.slow_errors`) without ``scipy.sparse``, whose import alone cost ~0.09 s of each
``station identify`` process on a quiet machine (scipy's array-API layer: numpy.f2py,
numpy.testing, charset_normalizer). The compiled products sum row by row as scipy's sparse
kernels do (``csr_matmat``, ``csr_matvec(s)``): the same numbers bit for bit.
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
    column ``j`` being ``B_{ell - k + j}`` (a compiled pass, :func:`_basis_values`)."""
    x = np.ascontiguousarray(x, dtype=float).ravel()
    b = np.empty((x.size, k + 1))
    _KERNELS._basis_values(np.ascontiguousarray(t, dtype=float), int(k), x,
                           np.ascontiguousarray(ell, dtype=np.int64).ravel(), b)
    return b


def _basis_values(t, k, x, ell, b):  # pragma: no cover - compiled
    """:func:`basis_values` into ``b`` (points, k + 1): per point the recurrence's steps in the
    order numpy's column passes took them (a zero knot span contributes 0), so the same numbers."""
    for p in range(x.shape[0]):
        xp = x[p]
        e = ell[p]
        b[p, 0] = 1.0
        for j in range(1, k + 1):
            saved = 0.0
            for r in range(j):
                lo = t[e + 1 - j + r]
                hi = t[e + 1 + r]
                den = hi - lo
                term = b[p, r] / den if den != 0 else 0.0
                b[p, r] = saved + (hi - xp) * term
                saved = (xp - lo) * term
            b[p, j] = saved


def design_rows(x: np.ndarray, t: np.ndarray, k: int = 3) -> BandedRows:
    """``scipy.interpolate.BSpline.design_matrix(x, t, k)`` as :class:`BandedRows` (the same values bit
    for bit: row ``r`` holds ``B_{ell - k} .. B_ell`` at ``x[r]``, ``ell`` its knot interval).

    numpy checks the bounds (and finiteness): scipy (1.17) checked them with Python's ``min(x)`` and
    ``max(x)``, one interpreted comparison per sample (4.4 of 7.3 ms on the 45 s record, session 12).

    Raises
    ------
    ValueError
        On a point outside the base interval ``[t[k], t[n]]`` or not finite, as scipy does.
    """
    x = np.ascontiguousarray(x, dtype=float)
    t = np.ascontiguousarray(t, dtype=float)
    if x.ndim != 1 or t.ndim != 1 or t.size < 2 * k + 2 or np.any(np.diff(t) < 0):
        raise ValueError(f"B-spline design matrix: points and knots must be 1-D, the knots non-decreasing and "
                         f"at least {2 * k + 2}")
    if x.size and not (float(np.min(x)) >= t[k] and float(np.max(x)) <= t[t.size - k - 1]):
        raise ValueError(f"B-spline design matrix: points outside [{t[k]:g}, {t[t.size - k - 1]:g}]"
                         " or not finite")
    ell = _interval(t, k, x)
    return BandedRows(ell - k, basis_values(t, k, x, ell), t.size - k - 1)


@dataclass(frozen=True, eq=False)
class BandedRows:
    """A matrix of ``n`` rows whose non-zeros lie in one window of columns a row: row ``r`` holds
    ``values[r, j]`` at column ``start[r] + j`` (``j < w = values.shape[1]``), zero elsewhere;
    ``0 <= start[r] <= ncols - w``.

    A B-spline design matrix (:func:`design_rows`: ``w = k + 1``) and what the engine's least squares
    make of it (scaled rows and columns, rows taken, sums and differences, whose windows are the
    union of the operands'). The products (:meth:`__matmul__`, :meth:`tmul`, :meth:`gram`) are
    compiled passes that sum in the order of scipy's CSR kernels (a matrix-vector product: each
    row's terms in column order; the transposed products and the Gram matrix: over rows in row
    order), so they give scipy.sparse's numbers bit for bit (a stored zero of a window adds
    nothing).
    """

    start: np.ndarray
    values: np.ndarray
    ncols: int

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", np.ascontiguousarray(self.start, dtype=np.int64))
        object.__setattr__(self, "values", np.ascontiguousarray(self.values, dtype=float))
        if (self.values.ndim != 2 or self.start.shape != self.values.shape[:1]
                or (self.start.size and not (int(self.start.min()) >= 0
                                             and int(self.start.max()) + self.values.shape[1] <= self.ncols))):
            raise ValueError(f"banded rows: {self.values.shape} values, {self.start.shape} starts and "
                             f"{self.ncols} columns do not fit")

    @property
    def shape(self) -> tuple[int, int]:
        return self.values.shape[0], int(self.ncols)

    def _columns(self) -> np.ndarray:
        return self.start[:, None] + np.arange(self.values.shape[1])

    def scale_rows(self, s) -> BandedRows:
        """``diag(s) @ self`` (each stored value times its row's ``s``)."""
        return BandedRows(self.start, self.values * np.asarray(s, dtype=float)[:, None], self.ncols)

    def scale_cols(self, s) -> BandedRows:
        """``self @ diag(s)`` (each stored value times its column's ``s``)."""
        return BandedRows(self.start, self.values * np.asarray(s, dtype=float)[self._columns()], self.ncols)

    def take(self, rows) -> BandedRows:
        """The rows ``rows`` (an index array or a slice), in that order."""
        return BandedRows(self.start[rows], self.values[rows], self.ncols)

    def __add__(self, other: BandedRows) -> BandedRows:
        return self._combine(other, 1.0)

    def __sub__(self, other: BandedRows) -> BandedRows:
        return self._combine(other, -1.0)

    def _combine(self, other: BandedRows, sign: float) -> BandedRows:
        """``self + sign * other`` entry by entry (``a + b``, ``a - b``; ``a`` or ``+-b`` alone), on the
        union of the two windows of each row, widened to the widest row's."""
        if self.shape != other.shape:
            raise ValueError(f"banded rows: shapes {self.shape} and {other.shape} differ")
        wa, wb = self.values.shape[1], other.values.shape[1]
        lo = np.minimum(self.start, other.start)
        width = int(np.max(np.maximum(self.start + wa, other.start + wb) - lo, initial=max(wa, wb)))
        lo = np.minimum(lo, self.ncols - width)
        out = np.zeros((lo.size, width))
        rows = np.arange(lo.size)[:, None]
        out[rows, (self.start - lo)[:, None] + np.arange(wa)] = self.values
        if sign > 0:
            out[rows, (other.start - lo)[:, None] + np.arange(wb)] += other.values
        else:
            out[rows, (other.start - lo)[:, None] + np.arange(wb)] -= other.values
        return BandedRows(lo, out, self.ncols)

    def __matmul__(self, x) -> np.ndarray:
        """``self @ x`` for a vector ``x`` (ncols,): (n,)."""
        x = np.ascontiguousarray(x, dtype=float)
        if x.shape != (self.ncols,):
            raise ValueError(f"banded rows: {self.shape} @ {x.shape}")
        out = np.zeros(self.values.shape[0])
        _KERNELS._banded_matvec(self.start, self.values, x, out)
        return out

    def add_product(self, x, out: np.ndarray) -> np.ndarray:
        """``out += self @ x`` row by row, each row's sum continuing from ``out``'s value: the product of
        columns stacked after another block's (scipy's product of the stacked matrix)."""
        x = np.ascontiguousarray(x, dtype=float)
        if x.shape != (self.ncols,) or out.shape != (self.values.shape[0],) or not out.flags.c_contiguous:
            raise ValueError(f"banded rows: {self.shape} @ {x.shape} into {out.shape}")
        _KERNELS._banded_matvec(self.start, self.values, x, out)
        return out

    def tmul(self, y) -> np.ndarray:
        """``self.T @ y`` for ``y`` (n,) or (n, m): (ncols,) or (ncols, m), summed over rows in row order."""
        y = np.asarray(y, dtype=float)
        if y.ndim not in (1, 2) or y.shape[0] != self.values.shape[0]:
            raise ValueError(f"banded rows: {self.shape}.T @ {y.shape}")
        y2 = np.ascontiguousarray(y.reshape(y.shape[0], -1))
        out = np.zeros((self.ncols, y2.shape[1]))
        _KERNELS._banded_tmul(self.start, self.values, y2, out)
        return out.ravel() if y.ndim == 1 else out

    def gram(self, other: BandedRows | None = None) -> np.ndarray:
        """``self.T @ other`` (dense, ncols x other.ncols; ``other`` default ``self``), summed over rows in row order."""
        other = self if other is None else other
        if other.values.shape[0] != self.values.shape[0]:
            raise ValueError(f"banded rows: {self.shape}.T @ {other.shape}")
        out = np.zeros((self.ncols, other.ncols))
        _KERNELS._banded_gram(self.start, self.values, other.start, other.values, out)
        return out

    def column_sumsq(self) -> np.ndarray:
        """Each column's sum of squares (over rows in row order)."""
        return np.bincount(self._columns().ravel(), weights=(self.values * self.values).ravel(),
                           minlength=self.ncols)

    def toarray(self) -> np.ndarray:
        out = np.zeros(self.shape)
        out[np.arange(self.values.shape[0])[:, None], self._columns()] = self.values
        return out

    def csr_parts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(data, indices, indptr) of the CSR form (every stored value: ``w`` a row)."""
        n, w = self.values.shape
        return (self.values.ravel(), self._columns().ravel().astype(np.int32),
                np.arange(0, w * n + 1, w, dtype=np.int32))

    def tocsr(self):
        """A ``scipy.sparse.csr_matrix`` of the same entries (imports scipy.sparse: not for ``station identify``)."""
        from scipy import sparse

        return sparse.csr_matrix(self.csr_parts(), shape=self.shape)


def _banded_matvec(start, values, x, out):  # pragma: no cover - compiled
    """``out[r] += sum_j values[r, j] x[start[r] + j]``, each row's sum from ``out[r]`` in column order
    (scipy's ``csr_matvec``)."""
    w = values.shape[1]
    for r in range(values.shape[0]):
        s = out[r]
        c = start[r]
        for j in range(w):
            s += values[r, j] * x[c + j]
        out[r] = s


def _banded_tmul(start, values, y, out):  # pragma: no cover - compiled
    """``out[start[r] + j, :] += values[r, j] y[r, :]`` over rows in order (scipy's ``csr_matvecs`` of the
    transpose)."""
    w = values.shape[1]
    m = y.shape[1]
    for r in range(values.shape[0]):
        c = start[r]
        for j in range(w):
            a = values[r, j]
            for q in range(m):
                out[c + j, q] += a * y[r, q]


def _banded_gram(sa, va, sb, vb, out):  # pragma: no cover - compiled
    """``out[sa[r] + i, sb[r] + j] += va[r, i] vb[r, j]`` over rows in order (scipy's ``csr_matmat`` of
    the transpose and the matrix)."""
    wa = va.shape[1]
    wb = vb.shape[1]
    for r in range(va.shape[0]):
        ca = sa[r]
        cb = sb[r]
        for i in range(wa):
            a = va[r, i]
            for j in range(wb):
                out[ca + i, cb + j] += a * vb[r, j]


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
    "_basis_values": ["void(f8[::1], i8, f8[::1], i8[::1], f8[:, ::1])"],
    "_banded_matvec": ["void(i8[::1], f8[:, ::1], f8[::1], f8[::1])"],
    "_banded_tmul": ["void(i8[::1], f8[:, ::1], f8[:, ::1], f8[:, ::1])"],
    "_banded_gram": ["void(i8[::1], f8[:, ::1], i8[::1], f8[:, ::1], f8[:, ::1])"],
})
