"""The slow band the drift high-pass removed, estimated together with the lumped elements.

Why: the conditioned displacement ``x_c`` (:mod:`eddi.mdof.signals`) lacks the band below
about twice the drift high-pass cut-off ``f_c``. For a linear element, filtering both sides of
the equation alike removes that band from the fit (the prefilter of :mod:`eddi.mdof.lumped`).
For a cubic spring it does not: ``(x_c + s)^3`` is not the filtered ``x^3``. The worst case is
an essentially nonlinear attachment (a nonlinear energy sink: no linear stiffness, no linear
mode of its own): its relative displacement carries slow, broad-band motion, and on the rig's
``nes`` system at 45 dB the conditioned relative displacement misses 6-12 % of the true one
(RMS), so the sink's force balance closed to 16-23 % only and its cubic constant came out
7-23 % low (measured per record, the true relative displacement closes it to 1 %).

How: the missing part is an unknown of the fit. Per record and channel,
``x = x_c + B beta`` and ``v = v_c + B' beta`` over the rows, ``B`` cubic B-splines with knots
every ``1 / (KNOTS_PER_CUTOFF f_c)`` s: they span a sine at ``f_c`` to 1.2 %, at
``1.5 f_c`` to 12 %, and not at ``2 f_c`` (95 % left) nor at the modes (``f_1 >= 4 f_c``), so
the unknowns cannot absorb modal motion. The band between ``f_c`` and ``1.5 f_c`` (where the
twice-applied high-pass still removes 75-7 % of ``x``) is only partly restored; 8 knots per
period (spanning ``2 f_c``) was no better on the energy sink (held-out 0.03 / 0.13 against
0.01 / 0.09 before the polish) and reaches a third of the way into the first mode. The accelerations are measured directly (their slow part is
``(2 pi f)^2`` times smaller) and need nothing. The force balance of every mass over the free
window, ``m_i a_i + sum_e c_e col_e(x, v) = 0`` (``m_d = 1``; scaled by each equation's
inertia RMS), is solved for the masses, the element constants and every ``beta`` together by
Levenberg-Marquardt on the normal equations (the constants enter linearly, ``beta`` through
the element columns; the band is absorbed in the equation's slow part, so what decides the
constants is the band the sensors measure). A linear spring to ground pins its mass's slow
band by the force balance (the quasi-static response); a cubic spring pins the relative one.

The result is the records with the restored ``x`` and ``v`` (over the rows), which
:func:`eddi.mdof.lumped.fit_lumped` then fits without the prefilter (pruning, intervals).

No I/O: arrays in, arrays out.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import sparse
from scipy.interpolate import BSpline
from scipy.linalg import solve_banded

from eddi.mdof.lumped import Element, element_column

#: Knots per period of the cut-off: 4 spans a band to about ``f_c`` (module docstring).
KNOTS_PER_CUTOFF = 4.0


def slow_basis(n_samples: int, rate_hz: float, cutoff_hz: float, knots_per_cutoff: float = KNOTS_PER_CUTOFF
               ) -> tuple[np.ndarray, np.ndarray]:
    """Cubic B-splines over ``n_samples`` (knots every ``1 / (knots_per_cutoff cutoff_hz)`` s) and
    their time derivative [1/s].

    Returns
    -------
    b, bd : ndarray, shape (n_samples, n_basis)
    """
    b, bd = _sparse_basis(n_samples, rate_hz, cutoff_hz, knots_per_cutoff)  # one construction: dense views
    return b.toarray(), bd.toarray()


def _sparse_basis(n_samples: int, rate_hz: float, cutoff_hz: float, knots_per_cutoff: float = KNOTS_PER_CUTOFF
                  ) -> tuple[sparse.csr_matrix, sparse.csr_matrix]:
    """:func:`slow_basis` as sparse matrices (each row has at most 4 non-zeros; the same values to
    rounding). Dense, the joint fit's normal matrix cost ``rows x (n * n_basis)^2`` per step and
    the basis grows with the record: cubic in its length (an 8 s record at 2 kHz: minutes)."""
    span = n_samples / rate_hz
    n_knots = max(2, int(np.ceil(span * knots_per_cutoff * cutoff_hz)) + 1)
    inner = np.linspace(0.0, span, n_knots)
    knots = np.concatenate([[0.0] * 3, inner, [span] * 3])
    t = np.minimum(np.arange(n_samples) / rate_hz, span * (1 - 1e-12))
    b = BSpline.design_matrix(t, knots, 3).tocsr()
    h = 1.0 / rate_hz
    if n_samples < 2:
        return b, sparse.csr_matrix(b.shape)
    # np.gradient along the rows: central inside, one-sided at both ends
    lo = np.full(n_samples - 1, -0.5 / h)
    up = np.full(n_samples - 1, 0.5 / h)
    main = np.zeros(n_samples)
    main[0], up[0] = -1.0 / h, 1.0 / h
    main[-1], lo[-1] = 1.0 / h, -1.0 / h
    grad = sparse.diags([lo, main, up], [-1, 0, 1], format="csr")
    return b, (grad @ b).tocsr()


def _sign(e: Element, i: int) -> float:
    return 1.0 if e.a - 1 == i else -1.0 if e.b - 1 == i else 0.0


def _slope(e: Element, x: np.ndarray, j: int, v: np.ndarray | None = None
           ) -> tuple[np.ndarray | float, np.ndarray | float]:
    """``(d col / d x_j, d col / d v_j)`` of the element's column (``v`` needed for a nonlinear damper)."""
    s = _sign(e, j)
    if s == 0.0:
        return 0.0, 0.0
    if e.power == 1:
        return (0.0, s) if e.on_rate else (s, 0.0)
    y = v if e.on_rate else x
    ya = y[e.a - 1] if e.a else 0.0
    g = s * e.power * (ya - y[e.b - 1]) ** (e.power - 1)
    return (0.0, g) if e.on_rate else (g, 0.0)


def _masses(theta: np.ndarray, n: int, d: int, driven_free: bool) -> tuple[np.ndarray, list[int]]:
    """Masses from ``theta`` and the equations whose mass is a column (``m_d = 1`` unless free)."""
    free = list(range(n)) if driven_free else [k for k in range(n) if k != d]
    masses = np.ones(n)
    masses[free] = theta[: len(free)]
    return masses, free


def _record_blocks(data: tuple, beta: np.ndarray, theta: np.ndarray, elements: list[Element], n: int, d: int,
                   scales: np.ndarray, driven_free: bool, jacobian: bool = True):
    """Residual and Jacobian blocks (``theta`` columns, this record's ``beta`` columns); the
    residual alone when not ``jacobian`` (the same arithmetic)."""
    x, v, a, f, b, bd = data
    xs, vs = x + (b @ beta.T).T, v + (bd @ beta.T).T
    masses, free = _masses(theta, n, d, driven_free)
    nm = len(free)
    consts = theta[nm:]
    cols = [element_column(e, xs, vs) for e in elements]
    nb = b.shape[1]
    res, jt, jb = [], [], []
    for i in range(n):
        r = masses[i] * a[i] - (f if (i == d and f is not None) else 0.0)
        jt_i = np.zeros((x.shape[1], theta.size)) if jacobian else None
        if jacobian and i in free:
            jt_i[:, free.index(i)] = a[i]
        slopes: list = [None] * n  # this equation's d r / d x_j, d r / d v_j (summed over elements)
        for k, e in enumerate(elements):
            s = _sign(e, i)
            if s == 0.0:
                continue
            r = r + s * consts[k] * cols[k]
            if jacobian:
                jt_i[:, nm + k] = s * cols[k]
                _add_slopes(slopes, e, s * consts[k], xs, vs)
        res.append(r / scales[i])
        if jacobian:
            jt.append(jt_i / scales[i])
            jb.append(sparse.hstack([_beta_block(sl, b, bd) for sl in slopes]) * (1.0 / scales[i]))
    if not jacobian:
        return np.concatenate(res)
    return np.concatenate(res), np.vstack(jt), sparse.vstack(jb).tocsr()


def _add_slopes(slopes: list, e: Element, factor: float, xs: np.ndarray, vs: np.ndarray | None = None) -> None:
    """Add ``factor`` x the element column's derivatives in each channel's ``x`` and ``v`` to ``slopes``."""
    for j in range(len(slopes)):
        gx, gv = _slope(e, xs, j, vs)
        if np.any(gx) or np.any(gv):
            got = (factor * np.asarray(gx, float), factor * np.asarray(gv, float))
            slopes[j] = got if slopes[j] is None else (slopes[j][0] + got[0], slopes[j][1] + got[1])


def _beta_block(slope, b: sparse.csr_matrix, bd: sparse.csr_matrix) -> sparse.csr_matrix:
    """``d r / d beta_j = diag(d r / d x_j) B + (d r / d v_j) B'`` (sparse: the basis is local)."""
    if slope is None:
        return sparse.csr_matrix(b.shape)
    gx, gv = slope
    return ((sparse.diags(gx) @ b if gx.ndim else float(gx) * b)
            + (sparse.diags(gv) @ bd if gv.ndim else float(gv) * bd))


def _normal(data, betas, theta, elements, n, d, scales, free):
    """Normal matrix, gradient and cost of the joint problem (``theta`` first, then each record's
    beta). The matrix as its blocks: ``theta x theta`` (dense), per record ``theta x beta``
    (dense) and ``beta x beta`` (sparse: the records' betas do not meet, the basis is local)."""
    nt = theta.size
    tt, gt = np.zeros((nt, nt)), np.zeros(nt)
    tb, bb, gb = [], [], []
    cost = 0.0
    for dat, bt in zip(data, betas):
        r, jt, jb = _record_blocks(dat, bt, theta, elements, n, d, scales, free)
        tt += jt.T @ jt
        tb.append(np.asarray(jb.T @ jt).T)
        bb.append((jb.T @ jb).tocsr())
        gt += jt.T @ r
        gb.append(jb.T @ r)
        cost += float(r @ r)
    return (tt, tb, bb), (gt, gb), cost


def _cost(data, betas, theta, elements, n, d, scales, free) -> float:
    return float(sum(np.sum(_record_blocks(dat, bt, theta, elements, n, d, scales, free, jacobian=False) ** 2)
                     for dat, bt in zip(data, betas)))


def _banded_scaled(bb: sparse.csr_matrix, n: int, lam: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """``D^-1 bb D^-1 + lam I`` (``D`` the root of ``bb``'s diagonal) with the channels
    interleaved (``beta[j, q]`` at ``q n + j``: banded, the B-splines overlap their 3
    neighbours): ``D``'s diagonal, the permutation, the matrix in LAPACK band storage and its
    half-bandwidth."""
    db = np.sqrt(np.maximum(bb.diagonal(), 1e-300))
    nb = bb.shape[0] // n
    perm = (np.arange(n)[None, :] * nb + np.arange(nb)[:, None]).ravel()
    where = np.empty_like(perm)
    where[perm] = np.arange(perm.size)
    coo = bb.tocoo()
    vals = coo.data / db[coo.row] / db[coo.col]
    row, col = where[coo.row], where[coo.col]
    half = int(np.max(np.abs(row - col))) if coo.nnz else 0
    ab = np.zeros((2 * half + 1, bb.shape[0]))
    np.add.at(ab, (half + row - col, col), vals)
    ab[half] += lam
    return db, perm, ab, half


def _lm_step(blocks, grads, n: int, lam: float) -> np.ndarray:
    """The Levenberg-Marquardt step ``-D^-1 (D^-1 N D^-1 + lam I)^-1 D^-1 g`` (``N`` the normal
    matrix, ``D`` the root of its diagonal, ``g`` the gradient), ``theta`` first then each
    record's beta. Each record's beta block is banded once its channels are interleaved, so
    the step is solved banded per record and densely only on ``theta`` (Schur complement): the
    dense solve of the whole matrix it replaces cost ``(n_beta)^3`` per try (session 12: a
    two-mass chain's five 10 s records, 4500 unknowns, 15.6 s of a fold's 24 s CPU)."""
    tt, tb, bb = blocks
    gt, gb = grads
    nt = gt.size
    dt = np.sqrt(np.maximum(np.diag(tt), 1e-300))
    schur = tt / dt[:, None] / dt[None, :] + lam * np.eye(nt)
    rhs = gt / dt
    solved = []
    for tb_r, bb_r, g_r in zip(tb, bb, gb):
        db, perm, ab, half = _banded_scaled(bb_r, n, lam)
        tbs = tb_r / dt[:, None] / db[None, :]
        sol = solve_banded((half, half), ab, np.column_stack([tbs.T[perm], (g_r / db)[perm]]))
        y = np.empty_like(sol)
        y[perm] = sol
        schur -= tbs @ y[:, :nt]
        rhs -= tbs @ y[:, nt]
        solved.append((y, db))
    zt = np.linalg.solve(schur, rhs)
    steps = [-zt / dt]
    for y, db in solved:
        steps.append(-(y[:, nt] - y[:, :nt] @ zt) / db)
    return np.concatenate(steps)


def restore_slow_band(records: Sequence[tuple], elements: list[Element], masses: np.ndarray,
                      consts: dict[Element, float], n: int, d: int, *, starts: Sequence[int] | None = None,
                      iterations: int = 12, knots_per_cutoff: float = KNOTS_PER_CUTOFF
                      ) -> tuple[list[tuple], np.ndarray, float, float]:
    """Estimate the slow band of ``x`` and ``v`` with the elements (module docstring).

    Parameters
    ----------
    records : sequence of tuple
        As :func:`eddi.mdof.lumped.fit_lumped`: ``(x, v, a, force, (start, stop), rate_hz, cutoff_hz)``.
    elements : list of Element
        The elements to fit with (e.g. those a prefiltered fit kept).
    masses : ndarray, shape (n,)
        Start masses [kg] (or per unit driven mass).
    consts : dict of Element to float
        Start constants, same scale as ``masses``.
    n, d : int
        Masses and the driving-point mass (0-based).
    starts : sequence of int, optional
        Per record, the first row (the hammer pulse's start): the rows then hold the blow,
        the force enters the driven mass's equation and that mass is an unknown too (the
        quasi-static response the high-pass removed is part of the slow band). Default: the
        window's start, the driven mass fixed at ``masses[d]``.
    iterations : int
        Levenberg-Marquardt steps at most.
    knots_per_cutoff : float
        Knots of the slow basis per period of each record's cut-off (:func:`slow_basis`).

    Returns
    -------
    records : list of tuple
        The records with ``x`` and ``v`` restored over their rows (same layout).
    masses : ndarray, shape (n,)
    cost_before, cost_after : float
        Mean squared scaled force-balance residual at the start and at the end.
    """
    driven_free = starts is not None
    data, spans = [], []
    for k, (x, v, a, f, (s0, s1), rate, fc) in enumerate(records):
        s0 = int(starts[k]) if driven_free else s0
        b, bd = _sparse_basis(s1 - s0, rate, fc, knots_per_cutoff)
        data.append((x[:, s0:s1], v[:, s0:s1], a[:, s0:s1], f[s0:s1] if (driven_free and f is not None) else None,
                     b, bd))
        spans.append((s0, s1))
    scales = np.array([float(np.sqrt(np.mean(np.concatenate([dt[2][i] for dt in data]) ** 2))) or 1.0
                       for i in range(n)])
    unit = 1.0 if driven_free else masses[d]
    free = list(range(n)) if driven_free else [k for k in range(n) if k != d]
    theta = np.concatenate([masses[free] / unit, [consts.get(e, 0.0) / unit for e in elements]])
    betas = [np.zeros((n, dt[4].shape[1])) for dt in data]
    rows = sum(dt[0].shape[1] for dt in data) * n
    lam, first = 1e-3, None
    for _ in range(iterations):
        blocks, grads, cost = _normal(data, betas, theta, elements, n, d, scales, driven_free)
        first = cost if first is None else first
        improved = False
        for _try in range(6):
            step = _lm_step(blocks, grads, n, lam)
            th_new = theta + step[: theta.size]
            off, b_new = theta.size, []
            for bt in betas:
                b_new.append(bt + step[off:off + bt.size].reshape(bt.shape))
                off += bt.size
            new = _cost(data, b_new, th_new, elements, n, d, scales, driven_free)
            if new < cost:
                theta, betas, lam, improved = th_new, b_new, max(lam / 3.0, 1e-9), True
                break
            lam *= 10.0
        if not improved or (cost - new) < 1e-6 * cost:
            break
    final = _cost(data, betas, theta, elements, n, d, scales, driven_free)
    out = []
    for rec, (s0, s1), dt, bt in zip(records, spans, data, betas):
        x, v, a, f, window, rate, fc = rec
        xr, vr = x.copy(), v.copy()
        xr[:, s0:s1] += (dt[4] @ bt.T).T
        vr[:, s0:s1] += (dt[5] @ bt.T).T
        out.append((xr, vr, a, f, window, rate, fc))
    return out, _masses(theta, n, d, driven_free)[0] * unit, first / rows, final / rows
