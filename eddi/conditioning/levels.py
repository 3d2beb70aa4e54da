"""Noise levels, zero crossings, the onset of motion and where a response sinks into the noise."""

from __future__ import annotations

import math

import numpy as np

from eddi.kernels import Kernels
from eddi.peaks import block_peaks, peak_abs, peak_abs_at



def noise_rms(y: np.ndarray, rest_stop: int) -> float:
    """Noise RMS of a channel: from its rest part ``y[:rest_stop]`` or, without one, its tail.

    The tail estimate uses first differences (``std(diff) / sqrt 2``), which ignores a slow
    residual response.
    """
    y = np.asarray(y, float)
    if rest_stop >= 32:
        seg = y[:rest_stop]
        return float(np.std(seg - np.mean(seg)))
    tail = y[-max(32, y.size // 10):]
    return float(np.std(np.diff(tail)) / math.sqrt(2.0))



#: A rest whose RMS is this many times the record's quiet end is not a rest: the structure was
#: still moving when it was struck (a blow before the last ring-down died, a knock on the bench).
#: Both RMS are read the same way (mean removed), so the sensor's own noise, white or coloured by
#: its anti-alias filter, and a tone that runs through the whole record cancel in the ratio.
PRE_MOTION_FACTOR = 4.0


def pre_motion(y: np.ndarray, rest_stop: int) -> tuple[float, float] | None:
    """``(rest RMS, end RMS)`` of ``y`` when its rest part ``y[:rest_stop]`` moves more than
    :data:`PRE_MOTION_FACTOR` times its quiet end (the last ``max(32, min(rest_stop, n // 10))``
    samples), else None. A record whose end still rings has a larger end RMS: no claim; nor one
    whose end does not move at all (a logger's zero padding or held last value: no noise measured
    there, and the ratio divided by zero, session 20)."""
    y = np.asarray(y, float)
    if rest_stop < 32 or y.size < 4 * rest_stop:
        return None
    rest = y[:rest_stop]
    end = y[-max(32, min(rest_stop, y.size // 10)):]
    r, e = float(np.std(rest - np.mean(rest))), float(np.std(end - np.mean(end)))
    return (r, e) if e > 0 and r > PRE_MOTION_FACTOR * e else None


#: Samples per block when :func:`crossings` maps its flips back to sample indices.
CROSSING_BLOCK = 1 << 16


def crossings(y: np.ndarray, hysteresis: float, start: int = 0, stop: int | None = None) -> np.ndarray:
    """Zero crossings of ``y`` with hysteresis, as fractional sample indices.

    A crossing counts only when ``y`` has gone beyond ``+-hysteresis`` on both sides; its
    position is the linear interpolation of the last sign change before reaching the other
    side.

    The samples beyond the threshold (most of a ring-down's) are never listed by index: their
    sides are compressed from a mask and only the few flips are mapped back, block by block
    (:data:`CROSSING_BLOCK`). Listing them (an 8-byte index and a gathered value each, two 4 MB
    arrays alive at once on a 45 s record) cost ~2.5 ms a call in page faults alone (session 12);
    the crossings are the same.

    Returns
    -------
    ndarray, shape (k,)
        Fractional indices (``i + frac``) in ``[start, stop)``.
    """
    stop = y.size if stop is None else stop
    seg = np.asarray(y[start:stop], float)
    if seg.size < 3:
        return np.zeros(0)
    if seg.flags.c_contiguous and math.isfinite(hysteresis):
        # one compiled pass over the samples (the numpy passes below: ~4x the CPU on the 45 s
        # record); the same crossings bit for bit
        out = np.empty(seg.size)
        k = _KERNELS._crossing_scan(seg, float(hysteresis), float(start), out)
        return out[:k].copy()
    above = seg > hysteresis  # on the positive side
    beyond = seg < -hysteresis
    beyond |= above  # beyond the threshold
    sides = above[beyond]  # the side of each sample beyond it, in order
    if sides.size < 2:
        return np.zeros(0)
    k = np.flatnonzero(sides[1:] != sides[:-1]) + 1  # first sample beyond threshold on the new side
    neg = np.signbit(seg)
    sign_change = np.flatnonzero(neg[:-1] != neg[1:])
    if k.size == 0 or sign_change.size == 0:
        return np.zeros(0)
    flips = _nth_true(beyond, k)
    pos = np.searchsorted(sign_change, flips, side="left") - 1
    ok = pos >= 0
    i = sign_change[pos[ok]]
    y0, y1 = seg[i], seg[i + 1]
    # where y0 == y1 (two equal samples either side of a sign-bit change: +0.0 and -0.0, or a
    # flat run), the crossing is taken halfway; no 0/0 is formed (its RuntimeWarning reached the
    # user's stderr on clean records)
    frac = np.divide(y0, y0 - y1, out=np.full(y0.shape, 0.5), where=y1 != y0)
    return start + i + np.clip(frac, 0.0, 1.0)


def _nth_true(mask: np.ndarray, k: np.ndarray) -> np.ndarray:
    """``np.flatnonzero(mask)[k]`` (``k`` increasing), without listing every true index."""
    edges = np.arange(0, mask.size, CROSSING_BLOCK)
    cum = np.concatenate(([0], np.cumsum([np.count_nonzero(mask[e:e + CROSSING_BLOCK]) for e in edges])))
    blk = np.searchsorted(cum, k, side="right") - 1
    out = np.empty(k.size, dtype=np.intp)
    for b in np.unique(blk):
        sel = blk == b
        e = int(edges[b])
        out[sel] = np.flatnonzero(mask[e:e + CROSSING_BLOCK])[k[sel] - cum[b]] + e
    return out



def _onset(y: np.ndarray, head: int, offset: float = 0.0) -> tuple[int, float]:
    """Start of the run of ``|r|`` above the noise that leads to its peak, and the peak.

    ``r = y - offset`` is ``y`` with its rest offset removed (formed only where read: the
    peak's search is one compiled pass, :func:`eddi.peaks.peak_abs_at`); ``head`` samples
    at the start give a (robust) noise scale. The level is the larger of 5 % of the peak and 6
    noise RMS.
    """
    peak_i, peak = peak_abs_at(y, offset)
    h = y[: max(8, head)] - offset
    sigma = 1.4826 * float(np.median(np.abs(h - np.median(h))))
    level = max(0.05 * peak, 6.0 * sigma)
    below = np.nonzero(np.abs(y[: peak_i + 1] - offset) <= level)[0]
    return (int(below[-1]) + 1 if below.size else 0), peak



def _at(y: np.ndarray, pos: np.ndarray) -> np.ndarray:
    """``y`` linearly interpolated at fractional sample indices ``pos``."""
    idx = np.floor(pos).astype(int)
    frac = pos - idx
    nxt = np.minimum(idx + 1, y.size - 1)
    return y[idx] * (1 - frac) + y[nxt] * frac



def _envelope_stop(y: np.ndarray, first: int, sigma: float, factor: float, period_s: float,
                   rate: float) -> int:
    """End of the last block (one period long) whose peak exceeds ``factor * sigma``.

    Without noise (``sigma == 0``) the floor is 1e-4 of the peak after ``first``.
    """
    n = y.size
    seg = y[first:]
    if seg.size == 0:
        return n
    floor = max(factor * sigma, 1e-4 * peak_abs(seg))
    block = max(4, int(round(period_s * rate)))
    nb = seg.size // block
    if nb == 0:
        return n
    peaks = block_peaks(seg, block)  # |seg|'s block maxima without the |seg| temporary
    above = np.nonzero(peaks > floor)[0]
    if above.size == 0:
        return min(n, first + block)
    last = int(above[-1])
    return n if last == nb - 1 else first + (last + 1) * block



def _pulse_end(y: np.ndarray, start: int, impact_end: int) -> int:
    """Last sample of the impact (plus 3, the stencil's reach) for the integration.

    From the force when it was measured (``impact_end >= 0``); otherwise symmetric about the
    first peak of ``|y|`` after ``start`` (a hammer pulse is near a half-sine).
    """
    if impact_end >= 0:
        return impact_end + 3
    seg = np.abs(y[start:])
    if seg.size == 0:
        return start
    first_peak = int(np.argmax(seg[: max(4, seg.size // 20)]))
    return start + 2 * first_peak + 3


def _crossing_scan(seg, h, start, out):  # pragma: no cover - compiled
    """:func:`crossings` in one pass: ``out[:k]`` the crossings, ``k`` returned.

    At each sample beyond ``+-h`` on the other side from the last one beyond it (a flip), the
    last sign-bit change before that sample (between ``i`` and ``i + 1``) gives the crossing
    ``start + i + clip(y_i / (y_i - y_{i+1}), 0, 1)`` (0.5 where ``y_i == y_{i+1}``); a flip
    with no sign change before it gives none, as the searchsorted of the numpy passes."""
    k = 0
    last = -1  # the last sign change (i, i + 1) before the current sample
    side = -1  # side of the last sample beyond the threshold (-1: none yet; 1: above; 0: below)
    prev_neg = np.signbit(seg[0])
    for j in range(seg.shape[0]):
        yj = seg[j]
        neg = np.signbit(yj)
        if j > 0 and neg != prev_neg:
            last = j - 1
        prev_neg = neg
        above = yj > h
        if above or yj < -h:
            s = 1 if above else 0
            if side >= 0 and s != side and last >= 0:
                y0 = seg[last]
                y1 = seg[last + 1]
                frac = y0 / (y0 - y1) if y1 != y0 else 0.5
                if frac < 0.0:
                    frac = 0.0
                elif frac > 1.0:
                    frac = 1.0
                out[k] = (start + last) + frac
                k += 1
            side = s
    return k


#: The compiled kernel (:mod:`eddi.kernels`: built ahead of time, else numba's JIT).
_KERNELS = Kernels(globals(), {"_crossing_scan": ["i8(f8[::1], f8, f8, f8[::1])"]})
