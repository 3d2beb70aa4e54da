"""Nuisance columns for the slow errors a conditioner leaves in ``x`` and ``v``.

A coordinate integrated from a measured acceleration is known only up to the drift its
conditioner removed: a smooth curve (``eddi.conditioning``'s cubic drift spline, knots every
:data:`DRIFT_KNOT_PERIODS` periods). Whatever part of the true motion lies in that space is
taken out with the drift, and whatever part of the integrated noise lies in it is left in.
Measured on an asymmetric oscillator (``x^2`` stiffness, clean record,
``benchmarks/bench_vs_sindy.py``'s ``heavy_asym``): the conditioned ``x`` is off by a slow
curve that follows the squared amplitude (the mean shift a quadratic stiffness causes, which
the anchoring at ``a = 0`` cannot tell from drift), 0.4 % of the RMS of ``x``, and lies in the
drift spline's space to 5e-6 of it. Fed to phase two as is, that offset moves ``x^2`` by 2-4 %
and ``x^3`` by 1-3 %.

Phase two therefore treats the offset ``delta(t)`` of ``x`` and the slow error ``dv(t)`` of
``v`` as unknowns in the same spline space (errors in variables, to first order):

* potential route, ``E - T = V(x_true)`` with ``x_true = x - delta``, ``T = m (v_true + dv)^2 / 2``
  and ``E`` anchored on ``T(gamma_i)``::

      E - T = V(x) - K(x) delta(t) + [blend of m v(gamma_i) dv(gamma_i)] - m v dv(t)

* Lagrangian route, ``F_c = -K(x_true) = -K(x) + K'(x) delta(t)``.

``K`` is the route's own estimate (a first pass without these columns, then refitted), and
``delta, dv`` are B-spline series; their coefficients are fitted and discarded. The part of
the error faster than the knots (the integrated noise between knots) is not removed; it is
what limits the routes at low SNR.

The basis and the columns built on it are :class:`eddi.bspline.BandedRows` (each row's few
values in one window of columns), whose compiled products give ``scipy.sparse``'s numbers bit
for bit without importing it (~0.09 s of each ``station identify`` process).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from eddi.bspline import BandedRows, design_rows

#: Knot spacing of the nuisance splines, in periods of the response: that of the
#: conditioner's drift spline (``eddi.conditioning.conditioner.KNOT_PERIODS``).
DRIFT_KNOT_PERIODS = 2.0

#: Largest RMS of the fitted offset of ``x``, relative to the RMS of ``x``, for which the
#: correction is used. The expansion ``V(x - delta) = V(x) - K(x) delta`` drops
#: ``K'(x) delta^2 / 2``, about ``delta / (2 x)`` of the correction: 5 % at this bound. The
#: conditioner's own errors measured 0.4-3 % (``benchmarks/bench_vs_sindy.py``, 30-45 dB); a
#: record with dry friction fitted by a smooth library asked for 25-110 % (a mechanism outside
#: the library, not a conditioning error).
MAX_OFFSET = 0.1

#: Refits of the stiffness with the nuisance columns built on the previous estimate of ``K``
#: (one refit: plain EDDI 0.33x / 0.74x STLSQ's median at 45 / 30 dB on bench_vs_sindy's
#: seeds 3-10; two: 0.32x / 0.72x).
PASSES = 2


def drift_basis(t: np.ndarray, gamma: np.ndarray, knot_periods: float = DRIFT_KNOT_PERIODS,
                span: tuple[float, float] | None = None) -> BandedRows:
    """Cubic B-spline basis over ``t`` with knots every ``knot_periods`` periods.

    Parameters
    ----------
    t : ndarray, shape (k,), [s]
        Increasing sample times.
    gamma : ndarray, shape (N+1,), [s]
        Zero crossings of ``x`` (two per period; the period is twice their median spacing).
    knot_periods : float
        Knot spacing in periods.
    span : (float, float), optional
        The knots' first and last time [s] (default: the extremes of ``t``), to evaluate
        another basis's functions at other times.

    Returns
    -------
    BandedRows, shape (k, p)
        Basis functions at ``t`` (``p >= 4``; four values a row; ``.tocsr()`` for scipy.sparse).
    """
    t = np.asarray(t, dtype=float)
    t0, t1 = (float(np.min(t)), float(np.max(t))) if span is None else (float(span[0]), float(span[1]))
    knots = _drift_knots(t0, t1, gamma, knot_periods)
    return design_rows(np.clip(t, t0, t1), knots, 3)


def rate_error_columns(t: np.ndarray, gamma: np.ndarray, kinetic_at_gamma: np.ndarray, v: np.ndarray,
                       mass: float, basis: BandedRows,
                       knot_periods: float = DRIFT_KNOT_PERIODS, rows: slice | None = None) -> BandedRows:
    """Columns of ``E - T`` for a slow rate error ``dv = basis @ c`` (potential route).

    ``T`` at the samples is off by ``m v dv``; the energy anchored on ``T(gamma_i)``
    (:func:`eddi.phase_one._anchored_energy`, a linear blend in time between crossings) by
    the same blend of ``m v(gamma_i) dv(gamma_i)``.

    Parameters
    ----------
    t : ndarray, shape (k,), [s]
    gamma : ndarray, shape (N+1,), [s]
    kinetic_at_gamma : ndarray, shape (N+1,), [J]
    v : ndarray, shape (k,), [m/s]
    mass : float, [kg]
    basis : BandedRows, shape (k, p)
        :func:`drift_basis` at ``t`` (at ``t[rows]`` when ``rows`` is given).
    knot_periods : float
        As for ``basis``.
    rows : slice, optional
        Only these samples' rows (the crossings' terms from all of ``t, v``): the same rows,
        bit for bit, as the full matrix's, without forming it.

    Returns
    -------
    BandedRows, shape (k, p) or (len(t[rows]), p), [J per m/s]
        Each row's window the union of its three terms' (4-8 values).
    """
    v = np.asarray(v, dtype=float)
    # the basis at the crossings, on the knots of ``basis`` (the same t[0], t[-1] and period;
    # each row of a design matrix depends only on its own time)
    t = np.asarray(t, dtype=float)
    gc = np.clip(gamma, t[0], t[-1])
    span = (min(float(np.min(t)), float(np.min(gc))), max(float(np.max(t)), float(np.max(gc))))
    bg = drift_basis(gc, gamma, knot_periods, span=span)
    vg = np.sign(np.interp(gamma, t, v)) * np.sqrt(2.0 * np.maximum(kinetic_at_gamma, 0.0) / mass)
    if rows is not None:
        t, v = t[rows], v[rows]
    i = np.clip(np.searchsorted(gamma, t, side="right") - 1, 0, gamma.size - 2)
    lam = np.clip((t - gamma[i]) / np.maximum(gamma[i + 1] - gamma[i], 1e-300), 0.0, 1.0)
    eg = bg.scale_rows(mass * vg)
    blend = eg.take(i).scale_rows(1.0 - lam) + eg.take(i + 1).scale_rows(lam)
    return blend - basis.scale_rows(mass * v)


def nuisance_values(t: np.ndarray, gamma: np.ndarray, kinetic_at_gamma: np.ndarray, v: np.ndarray,
                    mass: float, offset_coef: np.ndarray, rate_coef: np.ndarray,
                    knot_periods: float = DRIFT_KNOT_PERIODS, span: tuple[float, float] | None = None,
                    v_full: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``drift_basis(t) @ offset_coef`` and ``rate_error_columns(t, ...) @ rate_coef`` at every
    sample, by evaluating the two splines (scipy's ``BSpline``) instead of forming the
    (k x p) matrices: the same values to rounding (~1e-16 of them), at a fraction of the cost on
    long segments (``eddi.slow_many``: fitted on every k-th sample, evaluated on all).

    ``t`` may be a subset of the segment's samples (every k-th): ``span`` is then the segment's
    ``(t_min, t_max)`` (the spline's knots) and ``v_full`` its ``(t, v)`` (the velocity's sign at
    the crossings); each value is the one at that sample of the whole segment, bit for bit.

    Returns
    -------
    offset : ndarray, shape (k,)
        The fitted offset of ``x`` at ``t``.
    rate_terms : ndarray, shape (k,), [J]
        The rate-error columns' contribution to ``E - T`` at ``t``.
    """
    from eddi.bspline import Spline as BSpline  # numpy (scipy.interpolate imports scipy.optimize)

    t = np.asarray(t, dtype=float)
    v = np.asarray(v, dtype=float)
    t0, t1 = span if span is not None else (float(np.min(t)), float(np.max(t)))
    tf, vf = v_full if v_full is not None else (t, v)
    knots = _drift_knots(t0, t1, gamma, knot_periods)
    offset = BSpline(knots, np.asarray(offset_coef, float), 3, extrapolate=False)(np.clip(t, t0, t1))
    dv = BSpline(knots, np.asarray(rate_coef, float), 3, extrapolate=False)
    gc = np.clip(gamma, tf[0], tf[-1])
    vg = np.sign(np.interp(gamma, tf, vf)) * np.sqrt(2.0 * np.maximum(kinetic_at_gamma, 0.0) / mass)
    eg = mass * vg * dv(gc)
    i = np.clip(np.searchsorted(gamma, t, side="right") - 1, 0, gamma.size - 2)
    lam = np.clip((t - gamma[i]) / np.maximum(gamma[i + 1] - gamma[i], 1e-300), 0.0, 1.0)
    rate_terms = (1.0 - lam) * eg[i] + lam * eg[i + 1] - mass * v * dv(np.clip(t, t0, t1))
    return offset, rate_terms


def _drift_knots(t0: float, t1: float, gamma: np.ndarray, knot_periods: float) -> np.ndarray:
    """The knots of :func:`drift_basis` over ``[t0, t1]``."""
    period = 2.0 * float(np.median(np.diff(gamma))) if gamma.size > 1 else t1 - t0
    n_int = max(1, int(np.ceil((t1 - t0) / max(knot_periods * period, 1e-300))))
    return np.concatenate(([t0] * 3, np.linspace(t0, t1, n_int + 1), [t1] * 3))


def refit_with_offset(cols: np.ndarray, rhs: np.ndarray, w: np.ndarray, coef: np.ndarray, basis: BandedRows,
                      offset_gain, extra: BandedRows | None, solve, x: np.ndarray) -> np.ndarray:
    """Weighted least squares of ``rhs`` on ``cols`` plus the nuisance columns, :data:`PASSES` times.

    The first-order correction holds while the fitted offset is small against ``x``; when
    its RMS exceeds :data:`MAX_OFFSET` of that of ``x`` the first estimate ``coef`` is
    returned unchanged.

    Parameters
    ----------
    cols : ndarray, shape (k, m)
        The route's columns.
    rhs : ndarray, shape (k,)
    w : ndarray, shape (k,)
        Row weights.
    coef : ndarray, shape (m,)
        First estimate (without nuisance columns).
    basis : BandedRows, shape (k, p)
        :func:`drift_basis`.
    offset_gain : callable
        ``coef -> ndarray (k,)``: how the row responds to a unit offset of ``x`` for the
        stiffness ``coef`` (potential: ``-K(x)``; Lagrangian: ``K'(x)``).
    extra : BandedRows, shape (k, q), or None
        Further nuisance columns that do not depend on ``coef``.
    solve : callable
        ``(a, b) -> (coef, cond)``, e.g. :func:`normal_lstsq` (run by blocks,
        :func:`normal_lstsq_split`; another solver is given the stacked matrix as ``scipy.sparse``).
    x : ndarray, shape (k,)
        The coordinate at the rows.

    Returns
    -------
    ndarray, shape (m,)
        The stiffness coefficients.
    """
    first = coef
    m, p = cols.shape[1], basis.shape[1]
    offset = np.zeros(basis.shape[0])
    dense = cols * w[:, None]
    for _ in range(PASSES):
        nuisance = [basis.scale_rows(offset_gain(coef))] + ([extra] if extra is not None else [])
        if solve is normal_lstsq:
            # the dense route columns and the banded nuisance ones kept apart (normal_lstsq_split)
            sol, _cond = normal_lstsq_split(dense, [b.scale_rows(w) for b in nuisance], rhs * w)
        else:
            from scipy import sparse  # another solver takes the stacked matrix as scipy.sparse

            full = sparse.diags(w) @ sparse.hstack([sparse.csr_matrix(cols), *(b.tocsr() for b in nuisance)],
                                                   format="csr")
            sol, _cond = solve(full, rhs * w)
        coef = sol[:m]
        offset = basis @ sol[m:m + p]
    if not np.all(np.isfinite(coef)) or np.sqrt(np.mean(offset**2)) > MAX_OFFSET * np.sqrt(np.mean(x**2)):
        return first
    return coef


def normal_lstsq(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
    """Least squares by the column-scaled normal equations with two steps of refinement.

    For the tall systems of :func:`refit_with_offset` (up to ~1e5 rows, a few stiffness columns
    and up to a few hundred sparse nuisance columns, four non-zeros a row each) an SVD solver
    (``numpy.linalg.lstsq``) on the dense matrix took 0.2-0.5 s of CPU a call with ~40 columns
    and seconds with hundreds; the sparse normal equations take a few ms. Each refinement
    step solves them again for the residual's correction (the corrected semi-normal
    equations), which brings the error back to that of a QR solution for condition numbers
    up to ~1e7 of the scaled matrix (measured: 1.3e-13 relative against an SVD on a test
    system of condition ~800).

    Parameters
    ----------
    a : ndarray or scipy.sparse matrix, shape (n, m)
        (a sparse matrix: scipy.sparse is imported; :func:`normal_lstsq_split` needs none)
    b : ndarray, shape (n,)

    Returns
    -------
    coef : ndarray, shape (m,)
    cond : float
        A cheap lower bound of the condition number of the scaled matrix (ratio of the
        extreme diagonal entries of the Cholesky factor).
    """
    if not isinstance(a, np.ndarray):
        from scipy import sparse

        norms = np.sqrt(np.asarray(a.multiply(a).sum(axis=0)).ravel())
        norms = np.where(norms > 0, norms, 1.0)
        a_s = a @ sparse.diags(1.0 / norms)
        gram = (a_s.T @ a_s).toarray()
    else:
        norms = np.linalg.norm(a, axis=0)
        norms = np.where(norms > 0, norms, 1.0)
        a_s = a / norms
        gram = a_s.T @ a_s
    # the scaled columns have unit norm: the Gram matrix has a unit diagonal
    low = _cholesky(gram)
    diag = np.abs(np.diag(low))
    cond = float(np.max(diag) / max(float(np.min(diag)), 1e-300))

    def normal_solve(rhs: np.ndarray) -> np.ndarray:
        return _cholesky_solve(low, np.asarray(a_s.T @ rhs).ravel())

    sol = normal_solve(b)
    for _ in range(2):
        sol = sol + normal_solve(b - a_s @ sol)
    return sol / norms, cond


def normal_lstsq_split(dense: np.ndarray, nuisance: BandedRows | Sequence[BandedRows],
                       b: np.ndarray) -> tuple[np.ndarray, float]:
    """:func:`normal_lstsq` of ``[dense | nuisance]``, its Gram matrix formed by blocks.

    The matrix of :func:`refit_with_offset` is a few dense route columns beside hundreds of
    banded nuisance columns (four to eight non-zeros a row). Stacked into one sparse matrix,
    every row's dense entries joined the sparse Gram product (``rows x (m + 8)^2`` products
    through scipy's sparse kernels: 45 of the 77 ms the two routes' refits took on the 45 s
    record, session 9). By blocks, ``D^T D`` is a BLAS product, ``S^T D`` a sparse-dense
    product and only ``S^T S`` a sparse one; the same normal equations, the same scaling (unit
    column norms), Cholesky factor and two refinement steps, so the solution differs from
    :func:`normal_lstsq`'s by rounding (sums in another order). Session 10, 8 rig records (4
    systems, 30-60 dB, refined and not): coefficients within 5e-6 of their 95 % half widths
    of the stacked solve's, refits 97 -> 59 ms on the 45 s record (same run, load 12.8).

    Parameters
    ----------
    dense : ndarray, shape (n, m)
    nuisance : BandedRows or sequence of BandedRows, shape (n, q) together
        Blocks of columns, side by side.
    b : ndarray, shape (n,)

    Returns
    -------
    coef : ndarray, shape (m + q,)
    cond : float
        As :func:`normal_lstsq`.
    """
    m = dense.shape[1]
    blocks = [nuisance] if isinstance(nuisance, BandedRows) else list(nuisance)
    edges = np.cumsum([m] + [blk.shape[1] for blk in blocks])
    nd = np.linalg.norm(dense, axis=0)
    # column sums of squares in row order, as scipy's sparse column sum formed them
    ns = [np.sqrt(blk.column_sumsq()) for blk in blocks]
    norms = np.concatenate([nd, *ns])
    norms = np.where(norms > 0, norms, 1.0)
    d_s = dense / norms[:m]
    s_s = [blk.scale_cols(1.0 / norms[lo:hi]) for blk, lo, hi in zip(blocks, edges[:-1], edges[1:])]
    # the Gram matrix by blocks, each entry summed over the rows in row order (as scipy's
    # product of the stacked sparse matrix's transpose and itself: the same numbers)
    sd = np.vstack([blk.tmul(d_s) for blk in s_s])
    ss = np.block([[a.gram(b) for b in s_s] for a in s_s])
    gram = np.block([[d_s.T @ d_s, sd.T], [sd, ss]])
    low = _cholesky(gram)
    diag = np.abs(np.diag(low))
    cond = float(np.max(diag) / max(float(np.min(diag)), 1e-300))

    def normal_solve(rhs: np.ndarray) -> np.ndarray:
        return _cholesky_solve(low, np.concatenate([d_s.T @ rhs, *(blk.tmul(rhs) for blk in s_s)]))

    def times(sol: np.ndarray) -> np.ndarray:
        # each row's sum over the blocks' columns in order, continued from block to block
        acc = np.zeros(dense.shape[0])
        for blk, lo, hi in zip(s_s, edges[:-1], edges[1:]):
            blk.add_product(sol[lo:hi], acc)
        return d_s @ sol[:m] + acc

    sol = normal_solve(b)
    for _ in range(2):
        sol = sol + normal_solve(b - times(sol))
    return sol / norms, cond



def _cholesky(gram: np.ndarray) -> np.ndarray:
    """Lower Cholesky factor of ``gram + 1e-14 I`` (numpy's; ``numpy.linalg.LinAlgError`` when not
    positive definite). Not scipy.linalg's ``cho_factor``: importing ``scipy.linalg`` cost ~0.03-0.05 s
    of every ``station identify`` process for these two small systems (54 x 54 on the 45 s record)."""
    return np.linalg.cholesky(gram + 1e-14 * np.eye(gram.shape[0]))


def _cholesky_solve(low: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """``(L L^T)^-1 rhs`` for the factor of :func:`_cholesky` (two solves; the refinement steps of
    :func:`normal_lstsq` correct their rounding as they did ``cho_solve``'s)."""
    return np.linalg.solve(low.T, np.linalg.solve(low, rhs))
