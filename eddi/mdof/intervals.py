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

