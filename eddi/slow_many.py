"""The conditioner's slow errors in phase two over several segments (potential route).

:func:`eddi.identify.identify` fits, with the stiffness of one record, a slow offset
``delta(t)`` of ``x`` and a slow error ``dv(t)`` of ``v`` in the conditioner's drift-spline
space and discards them (:mod:`eddi.slow_errors`): a coordinate integrated from a measured
acceleration is known only up to the drift its conditioner removed, and on an asymmetric
spring the conditioned ``x`` carries a slow offset that follows the squared amplitude (the
mean shift of an ``x^2`` stiffness, which the anchoring at ``a = 0`` cannot tell from drift).
:mod:`eddi.identify_many` (the per-fold fits of :mod:`eddi.diagnosis`) regressed ``V = E - T``
without them. Measured (session 10, issue 10) on a chain-difference null of the calibration
(seed 4058: 1.68 kg, 47.5 Hz, an ``x^2 + x^3`` spring whose stiffness rises 73 %, 2 kHz, i.e.
42 samples a cycle, 31.6 dB, nine captures): leave-one-out fits of the nine free responses
had ``k[x]`` 1.0-1.2 % low with the pipeline's terms and 1.7-2.3 % low with the default
library, held-out nrmse 0.175 / 0.32 (the pipeline's single-record model: 0.04). The same
segment fitted by ``identify`` (potential route, which has them) was 0.2 % low.

The slow errors belong to a segment (each record was conditioned on its own), not to a fold:
:func:`segment_correction` fits them on the segment alone, as ``identify`` does (phase one
with the given damping library, phase two with the stiffness library and ``x, x^2, x^3``, so
that the estimate does not hang on whether the library holds the even term whose mean shift
it is, jointly with the nuisance columns, :data:`~eddi.slow_errors.PASSES` passes), and
returns the correction of ``V = E - T`` at every sample of the segment:
``V(x) ~ (E - T) + K(x) delta - [rate-error columns] c_v`` (:mod:`eddi.slow_errors`). It is
cached on the segment, so every fold, candidate and mechanism shape that trains on the
segment fits the same corrected rows at no further cost, and no fold's correction depends on
another fold's data (nor on the order in which folds run: forked and in-turn maps agree).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy import sparse
from scipy.linalg import cho_factor, cho_solve

from eddi.identify_many import (
    Basis, PotentialRows, SegmentEnergy, phase_one_many, phase_two_many, potential_rows, row_step, term_basis,
)
from eddi.phase_one import scaled_lstsq
from eddi.slow_errors import MAX_OFFSET, PASSES, drift_basis, nuisance_values, rate_error_columns

#: Stiffness terms always in the library a segment's slow errors are fitted with.
NUISANCE_STIFFNESS = ("x", "x^2", "x^3")
#: Samples of a segment its slow errors are fitted on (every k-th; the errors are slow: knots
#: every two periods, so 8000 samples leave tens of rows per knot interval on 100-cycle records).
FIT_ROWS = 4000


def segment_correction(e: SegmentEnergy, damping: Sequence[Basis], stiffness: Sequence[Basis],
                       step: int = 1) -> np.ndarray | None:
    """The correction of ``V = E - T`` for the segment's slow errors at ``t[i0:i1:step]`` [J], or None.

    Parameters
    ----------
    e : SegmentEnergy
    damping : sequence of Basis
        The damping library (phase one on the segment alone).
    stiffness : sequence of Basis
        The stiffness library; :data:`NUISANCE_STIFFNESS` joins it.
    step : int
        Every how many samples the correction is wanted (the rows of
        :func:`eddi.identify_many.potential_rows`): only those are evaluated.

    Returns
    -------
    ndarray, shape (len(range(i0, i1, step)),) or None
        None when the segment has too few samples for the nuisance columns (ten rows per
        unknown, as :func:`eddi.phase_two._nuisance_basis`), a solve fails, or the fitted
        offset exceeds :data:`~eddi.slow_errors.MAX_OFFSET` of ``x`` (the first-order expansion
        no longer holds; :func:`~eddi.slow_errors.refit_with_offset` keeps its first estimate
        then). The fit is cached on ``e`` by the libraries' names, its values by ``step`` too
        (every sample's values then thinned are the same numbers: each sample's value depends
        only on its own sample, the crossings and the fit).
    """
    texts = [b.text for b in stiffness]
    k = [b for b in stiffness if b.potential is not None] + [term_basis(t) for t in NUISANCE_STIFFNESS
                                                               if t not in texts]
    key = (tuple(b.text for b in damping), tuple(b.text for b in k))
    cache = e.__dict__.setdefault("_slow_correction", {})
    if key not in cache:
        cache[key] = _fit(e, list(damping), k)
    if cache[key] is None:
        return None
    values = e.__dict__.setdefault("_slow_values", {})
    if (key, step) not in values:
        values[(key, step)] = _values(e, k, *cache[key], step)
    return values[(key, step)]


def rows_correction(energies: Sequence[SegmentEnergy], damping: Sequence[Basis], stiffness: Sequence[Basis],
                    max_rows: int = 60000) -> np.ndarray | None:
    """:func:`segment_correction` of every segment at the rows of
    :func:`eddi.identify_many.potential_rows` (same ``max_rows``); 0 on a segment without one,
    None when no segment has one."""
    step = row_step(energies, max_rows)
    got = [segment_correction(e, damping, stiffness, step) for e in energies]
    if all(g is None for g in got):
        return None
    return np.concatenate([np.zeros(len(range(e.i0, e.i1, step))) if g is None else g
                           for e, g in zip(energies, got)])


def corrected(rows: PotentialRows, correction: np.ndarray | None) -> PotentialRows:
    """``rows`` with ``correction`` added to the potential (``rows`` when None)."""
    if correction is None:
        return rows
    return PotentialRows(rows.x, rows.potential + correction, rows.weight)


def _fit(e: SegmentEnergy, damping: list[Basis], stiffness: list[Basis]
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The segment's slow errors fitted jointly with its stiffness (module notes), on at most
    :data:`FIT_ROWS` of its samples (every k-th): (stiffness, offset and rate-error
    coefficients), or None (:func:`segment_correction`)."""
    ts = e.seg.t[e.i0:e.i1]
    vs = e.seg.v[e.i0:e.i1]
    m = len(stiffness)
    span = (float(np.min(ts)), float(np.max(ts)))
    n_basis = drift_basis(ts[[0, -1]], e.gamma, span=span).shape[1]
    if ts.size < 10 * (m + 2 * n_basis) or len(damping) > e.half_cycles:
        return None
    b, _ = phase_one_many([e], damping)
    rows = potential_rows([e], damping, b, max_rows=max(FIT_ROWS, 10 * (m + 2 * n_basis)))
    step = row_step([e], max(FIT_ROWS, 10 * (m + 2 * n_basis)))
    # the nuisance columns at the fitted rows only (each row of them depends only on its own
    # sample and the crossings: the rows of the full matrices, bit for bit)
    sel = slice(None, None, step)
    banded = drift_basis(ts[sel], e.gamma, span=span)
    rs = rate_error_columns(ts, e.gamma, e.t_gamma, vs, e.mass, banded, rows=sel).tocsr()
    bs = banded.tocsr()
    c, _ = phase_two_many(rows, stiffness)
    pot = np.column_stack([s.potential(rows.x) for s in stiffness])
    kmat = np.column_stack([s.force(rows.x, np.zeros_like(rows.x)) for s in stiffness])
    w = rows.weight
    ca, ya = pot * w[:, None], rows.potential * w
    for _ in range(PASSES):
        nmat = sparse.diags(w) @ sparse.hstack([sparse.diags(-(kmat @ c)) @ bs, rs], format="csr")
        solve = _projector(nmat)
        if solve is None:
            return None
        za, zy = solve(ca), solve(ya[:, None])[:, 0]
        c, _cond = scaled_lstsq(ca - nmat @ za, ya - nmat @ zy)
        if not np.all(np.isfinite(c)):
            return None
    z = zy - za @ c  # the nuisance coefficients given the stiffness (Frisch-Waugh-Lovell)
    p = bs.shape[1]
    offset = bs @ z[:p]
    if not np.all(np.isfinite(z)) or np.sqrt(np.mean(offset ** 2)) > MAX_OFFSET * np.sqrt(np.mean(rows.x ** 2)):
        return None
    return c, z[:p], z[p:]


def _values(e: SegmentEnergy, stiffness: list[Basis], c: np.ndarray, offset_coef: np.ndarray,
            rate_coef: np.ndarray, step: int) -> np.ndarray:
    """The fitted correction (:func:`_fit`) at ``t[i0:i1:step]``:
    ``V(x) = (E - T) - [-K(x) delta + rate columns c_v]``, the splines evaluated at those samples
    (forming the two (samples x knots) matrices for it was ~60 % of the fit; the values at the
    rows only, session 11b: ~2/3 of the evaluations of a 3-record fold at step 3)."""
    ts = e.seg.t[e.i0:e.i1]
    sel = slice(None, None, step)
    x = e.seg.x[e.i0:e.i1][sel]
    kc = np.column_stack([s.force(x, np.zeros_like(x)) for s in stiffness]) @ c
    delta, rate_terms = nuisance_values(ts[sel], e.gamma, e.t_gamma, e.seg.v[e.i0:e.i1][sel], e.mass,
                                        offset_coef, rate_coef, span=(float(np.min(ts)), float(np.max(ts))),
                                        v_full=(ts, e.seg.v[e.i0:e.i1]))
    return kc * delta - rate_terms


def _projector(nmat: sparse.csr_matrix):
    """``rhs -> z``, the least-squares coefficients of ``rhs`` (dense columns) on the sparse
    columns ``nmat`` (unit-scaled normal equations with a 1e-12 ridge, as
    :func:`eddi.slow_errors.normal_lstsq`, and one step of refinement); None when singular."""
    norms = np.sqrt(np.asarray(nmat.multiply(nmat).sum(axis=0)).ravel())
    norms = np.where(norms > 0, norms, 1.0)
    ns = nmat @ sparse.diags(1.0 / norms)
    gram = (ns.T @ ns).toarray()
    try:
        factor = cho_factor(gram + 1e-12 * np.eye(gram.shape[0]), lower=True)
    except np.linalg.LinAlgError:
        return None

    def solve(rhs: np.ndarray) -> np.ndarray:
        z = cho_solve(factor, np.asarray(ns.T @ rhs))
        z = z + cho_solve(factor, np.asarray(ns.T @ (rhs - ns @ z)))
        return z / norms[:, None]

    return solve
