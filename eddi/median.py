"""The median of a long 1-D array, equal to ``numpy.median``'s bit for bit, in a fraction of its time.

``numpy.median`` partitions a copy of the whole array (introselect: ~4 ms on the 460k samples
of a 24 s free response at 19.2 kHz); the noise estimates of one identification take three
such medians (``eddi.energy.noise_level``). Here a strided sample of the array brackets the
middle ranks (its order statistics a few binomial deviations either side of the middle), one
compiled pass (:func:`_bracket_split`; numpy's passes for a strided array) counts the values
below and above the bracket and keeps those inside it, and only those
(a few per cent of the array) are partitioned. The result is the same element(s) of the same
array, averaged as ``numpy.median`` does, so the same float; when the bracket misses (the
counts say so) or the array holds a NaN, ``numpy.median`` itself answers.
"""

from __future__ import annotations

import numpy as np

from eddi.kernels import Kernels

#: Below this many values ``numpy.median`` is as fast.
MIN_SIZE = 20_000
#: Values in the strided sample that brackets the middle ranks.
SAMPLE = 16_000
#: Half width of the bracket in binomial standard deviations of the sample's middle rank
#: (a miss, which falls back to ``numpy.median``, is then a ~1e-9 event for a shuffled array;
#: a sorted or periodic one may miss more often and only costs the fallback).
SIGMAS = 6.0


def median(a: np.ndarray) -> float:
    """``float(numpy.median(a))`` of a 1-D float array, by selection inside a bracket.

    Parameters
    ----------
    a : ndarray, shape (n,)

    Returns
    -------
    float
        Bit for bit ``numpy.median(a)`` (NaN when ``a`` holds a NaN, as numpy).
    """
    a = np.asarray(a, dtype=float)
    n = a.size
    if a.ndim != 1 or n < MIN_SIZE:
        return _small_median(a)
    ranks = [n // 2 - 1, n // 2] if n % 2 == 0 else [n // 2]
    sample = np.sort(a[:: max(1, n // SAMPLE)])
    m = sample.size
    half = SIGMAS * 0.5 * np.sqrt(m)
    lo_i, hi_i = int(np.floor(0.5 * m - half)), int(np.ceil(0.5 * m + half))
    if lo_i < 0 or hi_i >= m:
        return float(np.median(a))
    lo, hi = sample[lo_i], sample[hi_i]
    if a.flags.c_contiguous:
        # one compiled pass: the same counts, and the values inside in their order (the numpy
        # passes below: ~4x the CPU on 460k values)
        buf, counts = np.empty(n), np.zeros(3, dtype=np.int64)
        _KERNELS._bracket_split(a, float(lo), float(hi), buf, counts)
        below, inside, above = int(counts[0]), buf[: int(counts[1])], int(counts[2])
    else:
        below = int(np.count_nonzero(a < lo))
        inside = a[(a >= lo) & (a <= hi)]
        above = int(np.count_nonzero(a > hi))
    # every value is below, inside or above (a NaN is none of them): the bracket holds the
    # middle ranks when as many as the ranks below it are below lo and the rest fit inside
    if below + inside.size + above != n or below > ranks[0] or below + inside.size <= ranks[-1]:
        return float(np.median(a))
    k = [r - below for r in ranks]
    part = np.partition(inside, k)
    return float(np.mean(part[k[0]:k[-1] + 1]))


def _small_median(a: np.ndarray) -> float:
    """``float(numpy.median(a))`` of a short array: its middle element(s) partitioned (a copy)
    and averaged by ``numpy.mean``, as ``numpy.median`` does. ``numpy.median`` itself answers for
    an empty array, one with a NaN, or one of several dimensions; its NaN check otherwise imports
    ``numpy.ma`` (~9 ms of CPU at load 22, session 19) to find out the array is not masked."""
    n = a.size
    if a.ndim != 1 or n == 0 or np.isnan(a).any():
        return float(np.median(a))
    k = [n // 2 - 1, n // 2] if n % 2 == 0 else [n // 2]
    part = np.partition(a, k)
    return float(np.mean(part[k[0]:k[-1] + 1]))


def _bracket_split(a, lo, hi, inside, counts):  # pragma: no cover - compiled
    """Values of ``a`` below ``lo`` and above ``hi`` counted (``counts[0]``, ``counts[2]``), those
    in ``[lo, hi]`` copied in order to ``inside`` (``counts[1]`` of them); a NaN is none of them.

    Without branches (every value is stored, the count advances only for one inside): the side
    of a value is a coin toss here, and a branch per value cost ~7x the time (2.0 against 0.3 ms
    on 460k values)."""
    below = 0
    k = 0
    above = 0
    for i in range(a.shape[0]):
        x = a[i]
        below += x < lo
        above += x > hi
        inside[k] = x
        k += (x >= lo) & (x <= hi)
    counts[0] = below
    counts[1] = k
    counts[2] = above


#: The compiled kernel (:mod:`eddi.kernels`: built ahead of time, else numba's JIT).
_KERNELS = Kernels(globals(), {"_bracket_split": ["void(f8[::1], f8, f8, f8[::1], i8[::1])"]})
