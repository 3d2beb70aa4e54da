"""Peaks and first hits of a record-length array in one pass, without numpy's temporaries.

``float(np.max(np.abs(y)))`` forms ``|y|`` (a new array of the record's length) and reads it
again; on a 45 s record at 19.2 kHz that is 7 MB written and read per call, and the identify
path asks ~30 times. On a machine whose caches do not hold such arrays (session 19's: a numpy
pass at ~29 GB/s from 3.7 MB up, against ~79 GB/s at 0.4 MB) these passes were most of the
ratio of the library call to its floor. Here each is one compiled pass (or chunked numpy
passes that stop where the answer is), with numpy's results bit for bit:

* :func:`peak_abs`, :func:`peak_abs_at`, :func:`block_peaks`: the largest ``|y|`` read as the
  largest bit pattern with the sign cleared (a non-negative double orders as its bits; the
  integer maximum vectorises where a float maximum does not without fast-math);
* :func:`first_abs_above`, :func:`last_nonzero`: first / last hits in chunks of 16k samples;
* :func:`varies`: ``np.ptp(y) > 0`` from the first sample that differs;
* :func:`finite`: ``np.all(np.isfinite(y))`` from :func:`peak_abs`;
* :func:`misfit_sums`: a validation's ``sum (a - b)^2`` and ``sum |c - d|`` in one pass (not bit
  for bit: eight running sums in place of BLAS's dot and numpy's pairwise sum, a change at
  rounding level, ~1e-15 of the sums).
"""

from __future__ import annotations

import math

import numpy as np

from eddi.kernels import Kernels

#: Below this many samples :func:`peak_abs` leaves it to numpy (the compiled call's overhead).
PEAK_ABS_MIN = 4096


def peak_abs(y: np.ndarray) -> float:
    """``float(numpy.max(numpy.abs(y)))``, the same double, in one pass without a temporary.

    The largest ``|y|`` is one of the values whatever the order it is looked for in; the pass
    (:func:`_peak_abs`) reads it as the largest bit pattern with the sign cleared (a non-negative
    double orders as its bits), which vectorises where a float ``max`` does not; NaN when ``y``
    holds one, as numpy. On the 883k samples of a 45 s record at 19.2 kHz: ~0.24 ms against
    ~0.87 ms for numpy's ``abs`` into a new array and ``max`` (session 19, a machine whose
    caches do not hold the 7 MB temporary). Other layouts, dtypes and short arrays: numpy.
    """
    if not (isinstance(y, np.ndarray) and y.ndim == 1 and y.dtype == np.float64 and y.flags.c_contiguous
            and y.size >= PEAK_ABS_MIN):
        return float(np.max(np.abs(y)))
    return float(_KERNELS._peak_abs(y))


def _peak_abs(y):  # pragma: no cover - compiled
    """:func:`peak_abs`: the largest ``|y|`` as the largest sign-cleared bit pattern."""
    b = y.view(np.int64)
    m = np.int64(0)
    for i in range(b.shape[0]):
        m = max(m, b[i] & 0x7FFFFFFFFFFFFFFF)
    if m > 0x7FF0000000000000:  # a NaN's bits: above +inf's
        return np.nan
    buf = np.empty(1, dtype=np.float64)
    buf.view(np.int64)[0] = m
    return buf[0]


def peak_abs_at(y: np.ndarray, offset: float = 0.0) -> tuple[int, float]:
    """``i = argmax(|y - offset|)`` and ``|y[i] - offset|`` (numpy's first index of the largest),
    in compiled passes without the two temporaries (``y - offset`` and its ``abs``).

    The largest ``|y - offset|`` as in :func:`peak_abs` (the differences formed as numpy forms
    them, a block at a time), then the first sample where it occurs; a NaN anywhere (numpy: the
    first NaN), another layout, dtype or a short array: numpy's passes.
    """
    if (isinstance(y, np.ndarray) and y.ndim == 1 and y.dtype == np.float64 and y.flags.c_contiguous
            and y.size >= PEAK_ABS_MIN):
        i = int(_KERNELS._peak_abs_at(y, float(offset)))
        if i >= 0:
            return i, abs(float(y[i] - offset))
    r = np.abs(y - offset)
    i = int(np.argmax(r))
    return i, float(r[i])


def block_peaks(y: np.ndarray, block: int) -> np.ndarray:
    """``np.abs(y[:nb * block]).reshape(nb, block).max(axis=1)`` (``nb = y.size // block``), the
    same doubles, in one compiled pass without the ``|y|`` temporary (as :func:`peak_abs`)."""
    nb = y.size // block
    if not (isinstance(y, np.ndarray) and y.ndim == 1 and y.dtype == np.float64 and y.flags.c_contiguous
            and nb * block >= PEAK_ABS_MIN):
        return np.abs(y[: nb * block]).reshape(nb, block).max(axis=1)
    out = np.empty(nb, dtype=np.int64)
    _KERNELS._block_peaks(y, int(block), out)
    return out.view(np.float64)


def _block_peaks(y, block, out):  # pragma: no cover - compiled
    """:func:`block_peaks`: each block's largest sign-cleared bit pattern (a NaN's: NaN)."""
    b = y.view(np.int64)
    for k in range(out.shape[0]):
        m = np.int64(0)
        for i in range(k * block, (k + 1) * block):
            m = max(m, b[i] & 0x7FFFFFFFFFFFFFFF)
        out[k] = m


#: Samples a chunk of :func:`first_abs_above` / :func:`last_nonzero` (its masks: in L2).
SCAN_CHUNK = 16384


def first_abs_above(y: np.ndarray, level: float, strict: bool = True) -> int:
    """The first ``i`` with ``|y[i]| > level`` (``>=`` when not ``strict``), -1 for none.

    ``np.flatnonzero(np.abs(y) > level)[0]`` without the record-length temporaries: numpy's
    same comparisons a chunk at a time, stopping at the first chunk with a hit (a blow, which
    these look for, is near the start of what they scan)."""
    y = np.asarray(y)
    for s in range(0, y.size, SCAN_CHUNK):
        a = np.abs(y[s:s + SCAN_CHUNK])
        hit = np.flatnonzero(a > level if strict else a >= level)
        if hit.size:
            return s + int(hit[0])
    return -1


def last_nonzero(y: np.ndarray) -> int:
    """The last ``i`` with ``y[i] != 0`` (a NaN counts), -1 for none; chunks from the end."""
    y = np.asarray(y)
    for e in range(y.size, 0, -SCAN_CHUNK):
        hit = np.flatnonzero(y[max(0, e - SCAN_CHUNK):e] != 0.0)
        if hit.size:
            return max(0, e - SCAN_CHUNK) + int(hit[-1])
    return -1


#: Samples a block of :func:`_peak_abs_at` (its differences' buffer: in L1).
_PEAK_BLOCK = 2048


def _peak_abs_at(y, c):  # pragma: no cover - compiled
    """:func:`peak_abs_at`: the index of the first largest ``|y - c|``, -1 for a NaN."""
    n = y.shape[0]
    buf = np.empty(_PEAK_BLOCK, dtype=np.float64)
    bb = buf.view(np.int64)
    m = np.int64(0)
    for s in range(0, n, _PEAK_BLOCK):
        e = min(s + _PEAK_BLOCK, n)
        for i in range(s, e):
            buf[i - s] = y[i] - c
        for k in range(e - s):
            m = max(m, bb[k] & 0x7FFFFFFFFFFFFFFF)
    if m > 0x7FF0000000000000:
        return -1
    bb[0] = m
    peak = buf[0]
    for i in range(n):
        if abs(y[i] - c) == peak:
            return i
    return -1


def finite(y: np.ndarray) -> bool:
    """``bool(np.all(np.isfinite(y)))`` of a float array: its largest ``|y|`` (:func:`peak_abs`: one
    pass, no boolean temporary) is finite exactly when every value is (a NaN or inf peaks as one)."""
    y = np.asarray(y)
    if y.dtype != np.float64 or y.ndim != 1:
        return bool(np.all(np.isfinite(y)))
    return y.size == 0 or math.isfinite(peak_abs(y))


def varies(y: np.ndarray) -> bool:
    """``np.ptp(y) > 0`` of a finite 1-D array (two whole passes, max and min) as ``y != y[0]``
    somewhere, in chunks of :data:`SCAN_CHUNK` from the start (a blow's record differs at once)."""
    y = np.asarray(y)
    if y.ndim != 1 or y.size == 0 or y.dtype != np.float64 or not math.isfinite(float(y[0])):
        return bool(np.ptp(y) > 0)
    y0 = y[0]
    for s in range(0, y.size, SCAN_CHUNK):
        seg = y[s:s + SCAN_CHUNK]
        if (seg != y0).any():
            # a NaN differs from y0, and np.ptp(y) is then NaN (not > 0): numpy decides
            return bool(np.ptp(y) > 0) if not math.isfinite(peak_abs(seg)) else True
    return False


def misfit_sums(a: np.ndarray, b: np.ndarray, c: np.ndarray | None = None,
                d: np.ndarray | None = None) -> tuple[float, float] | None:
    """``(sum((a - b)**2), sum(|c - d|))`` (the second 0.0 without ``c, d``) in one pass.

    A validation's ``||x_sim - x||`` and ``mean |v_sim - v|`` over the window without the two
    record-length differences and the ``abs`` (3.7 MB each on a 24 s free response at 19.2 kHz).
    Eight running sums per quantity, added pairwise at the end: the same sums as numpy's to
    rounding (numpy: BLAS's ``dot`` for the norm, a pairwise sum for the mean), not bit for bit.
    None (the caller's numpy then) for arrays that are not contiguous float64 of one length, or
    shorter than :data:`PEAK_ABS_MIN`.
    """
    arrs = (a, b) if c is None else (a, b, c, d)
    n = a.size if isinstance(a, np.ndarray) else -1
    if n < PEAK_ABS_MIN or not all(isinstance(y, np.ndarray) and y.ndim == 1 and y.dtype == np.float64
                                   and y.flags.c_contiguous and y.size == n for y in arrs):
        return None
    out = np.empty(2)
    _KERNELS._misfit_sums(a, b, a if c is None else c, a if d is None else d, int(c is not None), out)
    return float(out[0]), float(out[1])


def _misfit_sums(a, b, c, d, both, out):  # pragma: no cover - compiled
    """:func:`misfit_sums`: eight running sums of ``(a - b)^2`` (and ``|c - d|``), added pairwise."""
    n = a.shape[0]
    s = np.zeros(8)
    r = np.zeros(8)
    m = n - n % 8
    for i in range(0, m, 8):
        for j in range(8):
            e = a[i + j] - b[i + j]
            s[j] += e * e
            if both:
                r[j] += abs(c[i + j] - d[i + j])
    sq = ((s[0] + s[1]) + (s[2] + s[3])) + ((s[4] + s[5]) + (s[6] + s[7]))
    ab = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    for i in range(m, n):
        e = a[i] - b[i]
        sq += e * e
        if both:
            ab += abs(c[i] - d[i])
    out[0] = sq
    out[1] = ab


#: The compiled kernels (:mod:`eddi.kernels`: built ahead of time, else numba's JIT).
_KERNELS = Kernels(globals(), {"_peak_abs": ["f8(f8[::1])"], "_peak_abs_at": ["i8(f8[::1], f8)"],
                               "_block_peaks": ["void(f8[::1], i8, i8[::1])"],
                               "_misfit_sums": ["void(f8[::1], f8[::1], f8[::1], f8[::1], i8, f8[::1])"]})
