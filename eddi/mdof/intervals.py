"""95 % intervals of least-squares fits on ring-downs: the delete-one-block jackknife.

No I/O: arrays in, arrays out.
"""

from __future__ import annotations

import math

import numpy as np


#: Contiguous blocks per record of the delete-one-block jackknife.
JACKKNIFE_BLOCKS = 5


def block_jackknife_ci95(solve, blocks: np.ndarray) -> np.ndarray:
    """95 % half-widths of a least-squares fit by the delete-one-block jackknife.

    Samples of a ring-down are correlated over many cycles, so the textbook covariance of
    the fit understates its spread; deleting one contiguous block (a fifth of a record) at a
    time and measuring how far the coefficients move does not assume independent samples.
    Half-width ``t_{0.975, g-1} sqrt((g-1)/g sum (c_k - mean c)^2)`` over ``g`` blocks.

    Parameters
    ----------
    solve : callable
        ``solve(rows) -> coefficients`` for a boolean mask of the samples to keep.
    blocks : ndarray of int, shape (n_samples,)
        Block of each sample.
    """
    from scipy import stats

    ids = np.unique(blocks)
    g = ids.size
    if g < 3:
        return np.full(np.asarray(solve(np.ones(blocks.size, bool))).shape, math.inf)
    est = np.array([solve(blocks != k) for k in ids])
    spread = np.sqrt((g - 1) / g * np.sum((est - est.mean(axis=0)) ** 2, axis=0))
    return float(stats.t.ppf(0.975, g - 1)) * spread



def jackknife_lstsq_ci95(a: np.ndarray, y: np.ndarray, blocks: np.ndarray, keep: slice = slice(None)) -> np.ndarray:
    """:func:`block_jackknife_ci95` of the least squares ``a c = y`` (coefficients ``keep``), by one
    QR per block instead of one least squares over the other blocks per block.

    ``||a c - y||^2`` over any set of blocks is the sum of ``||R_k [c; -1]||^2`` over them, with
    ``R_k`` the triangular factor of block ``k``'s ``[a | y]``; each delete-one fit is then a least
    squares on the other blocks' stacked factors (``(g - 1)(m + 1)`` rows). The columns are scaled to
    unit norm over all rows (:func:`eddi.phase_one.scaled_lstsq` scales over each subset: the same
    solution to rounding, the conditioning alike). Cost ``n m^2`` once instead of ``g n m^2`` (3 s of
    a three-mass identification's 29 s at 2 kHz, 8 s records; 28 % of it at 10 kHz).
    """
    from scipy import stats

    a = np.asarray(a, float)
    ids = np.unique(blocks)
    g = ids.size
    if g < 3:
        return np.full(np.arange(a.shape[1])[keep].shape, math.inf)
    norms = np.linalg.norm(a, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    aug = np.hstack([a / norms, np.asarray(y, float)[:, None]])
    factors = [np.linalg.qr(aug[blocks == k], mode="r") for k in ids]
    est = []
    for k in range(g):
        r = np.vstack([f for j, f in enumerate(factors) if j != k])
        est.append((np.linalg.lstsq(r[:, :-1], r[:, -1], rcond=None)[0] / norms)[keep])
    est = np.array(est)
    spread = np.sqrt((g - 1) / g * np.sum((est - est.mean(axis=0)) ** 2, axis=0))
    return float(stats.t.ppf(0.975, g - 1)) * spread
