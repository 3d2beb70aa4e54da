"""Input checks: a uniform time base, finite channels, clipped (flat-topped) runs, dropouts."""

from __future__ import annotations

import math

import numpy as np

from eddi.errors import SignalError
from eddi.kernels import Kernels
from eddi.peaks import peak_abs



def check_time(t: np.ndarray) -> float:
    """Check a time vector and return its sample rate [Hz].

    Raises
    ------
    SignalError
        If ``t`` is not 1-D, has fewer than 16 samples, is not finite, not increasing or
        not uniform (a sample more than 1 % of a step off the uniform grid).
    """
    given = np.asarray(t)
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 16:
        raise SignalError(f"time must be a 1-D array of at least 16 samples, got shape {t.shape}")
    step = (t[-1] - t[0]) / (t.size - 1)
    # times stored in less than double precision (float32 from a DAQ or a MATLAB single: 9 s at
    # 19.2 kHz is rounded by up to 4.8e-7 s, 0.9 % of a step) may sit off the grid by their own
    # rounding, as station's readers allow a file's printed digits (session 19: the library call
    # refused a float32 time base that `station identify` on the same .mat file read)
    coarse = given.dtype.kind == "f" and given.dtype.itemsize < 8 and t.size and np.isfinite(t[[0, -1]]).all()
    tol = 0.01 * step
    if coarse:
        tol = max(tol, 2.0 * float(np.spacing(given.dtype.type(max(abs(t[0]), abs(t[-1]))))))
        if not tol < 0.5 * step:
            raise SignalError(f"time is stored as {given.dtype} whose rounding near t = {max(abs(t[0]), abs(t[-1])):.3g} s "
                              f"cannot resolve steps of {step:.3g} s; expected float64 times")
    elif t.flags.c_contiguous and _KERNELS._time_on_grid(t, float(step)):
        return 1.0 / step  # one compiled pass found every check passed (else the messages below)
    if not np.isfinite(t).all():
        bad = np.nonzero(~np.isfinite(t))[0]
        raise SignalError(f"time is NaN or infinite at sample {int(bad[0])}")
    dt = np.diff(t)
    if np.any(dt <= 0):
        i = int(np.nonzero(dt <= 0)[0][0])
        raise SignalError(f"time must increase; t[{i + 1}] = {t[i + 1]:g} after t[{i}] = {t[i]:g}")
    step = (t[-1] - t[0]) / (t.size - 1)
    # each sample within 1 % of a step of the uniform grid (allows times printed with few digits)
    dev = np.arange(t.size, dtype=float)  # |t - (t[0] + step i)|, in place in one buffer
    dev *= step
    dev += t[0]
    dev -= t
    np.abs(dev, out=dev)
    if np.max(dev) > tol:
        i = int(np.argmax(dev))
        within = f"{tol:.3g} s: the rounding of {given.dtype} times" if tol > 0.01 * step else "1 % of a step"
        raise SignalError(
            f"time must be uniformly sampled; t[{i}] = {t[i]:.9g} s is {dev[i]:.3g} s off the grid "
            f"of step {step:.6g} s (expected within {within})"
        )
    return 1.0 / step



def check_channel(name: str, y: np.ndarray, n: int) -> np.ndarray:
    """A channel as a float array of length ``n``, finite everywhere.

    Raises
    ------
    SignalError
        Wrong length, or a NaN / infinite value (the message names the sample).
    """
    y = np.asarray(y, dtype=float)
    if y.shape != (n,):
        raise SignalError(f"channel {name!r} has shape {y.shape}, expected ({n},) like the time")
    if all_finite(y):
        return y
    bad = np.nonzero(~np.isfinite(y))[0]
    if bad.size:
        raise SignalError(f"channel {name!r} is NaN or infinite at sample {int(bad[0])}")
    return y



def clipped_run(y: np.ndarray, min_run: int = 5) -> int | None:
    """Index where ``y`` sits flat at its global maximum or minimum for ``min_run`` samples.

    A clipped channel is flat-topped at its extreme value; a smooth signal sampled with
    enough resolution does not repeat its extreme value several samples in a row. A coarse
    converter does, at a slow peak (an 8-bit displacement channel at 1 kHz sits 7 samples on its
    last count at a 7 Hz peak; blind unseen9, session 13: refused as clipped): a flat run whose
    flanks trace a parabola that tops out at the flat level (:func:`_quantised_peak`) is the
    converter's resolution, not its limit.

    Returns
    -------
    int or None
        First sample of the first such run, or None when the signal is not clipped.
    """
    y = np.asarray(y, dtype=float)
    if y.size < min_run or np.ptp(y) == 0:
        return None
    for extreme in (np.max(y), np.min(y)):
        if extreme == 0:
            continue
        hit = (y == extreme).astype(np.int8)
        if hit.sum() < min_run:
            continue
        # run lengths of consecutive hits
        edges = np.diff(np.concatenate(([0], hit, [0])))
        starts = np.nonzero(edges == 1)[0]
        stops = np.nonzero(edges == -1)[0]
        for a, b in zip(starts, stops):
            if b - a >= min_run and not _quantised_peak(y, int(a), int(b)):
                return int(a)
    return None


def clip_on_blow(y: np.ndarray, force: np.ndarray | None, at: int, min_run: int = 5) -> int | None:
    """Length of the flat run of ``y`` from ``at`` (:func:`clipped_run`) when it lies within the
    first hammer pulse of ``force`` (above 5 % of its peak), widened by the pulse's own width on
    each side; None when it reaches outside (or without a force). An accelerometer overloaded by
    the blow alone leaves the free response after it intact: the EDDI fit uses that, the impulse
    check and the force-driven validation must not trust the blow (blind unseen10, session 13: a
    194 kg record at 512 Hz, flat for 7 samples while the force peaked, was refused)."""
    if force is None or not np.size(force):
        return None
    y = np.asarray(y, dtype=float)
    level = y[at]
    stop = at
    while stop < y.size and y[stop] == level:
        stop += 1
    f = np.abs(np.asarray(force, dtype=float))
    peak = float(np.max(f))
    if not peak > 0:
        return None
    k = int(np.argmax(f))
    lo, hi = k, k
    while lo > 0 and f[lo - 1] > 0.05 * peak:
        lo -= 1
    while hi < f.size - 1 and f[hi + 1] > 0.05 * peak:
        hi += 1
    width = hi - lo + 1
    if at >= lo - width and stop <= hi + 1 + width and stop - at >= min_run:
        # and nowhere else: the rest of the channel stays inside the level
        rest = np.concatenate((y[:at], y[stop:]))
        if not np.any(rest == level):
            return stop - at
    return None


def _quantised_peak(y: np.ndarray, start: int, stop: int) -> bool:
    """Whether the flat run ``y[start:stop]`` at an extreme is a smooth peak held by the converter's
    resolution: a parabola through the flanks (as many samples as the run on each side, at least
    3) fits them within one count ``q`` (the smallest step between the channel's values) and its
    vertex is within 2 ``q`` of the flat level. A limit cuts a peak that would have gone on: its
    flanks point beyond the level (a sine clipped at 0.9 of its amplitude: vertex 7000 counts
    beyond at 16 bit; a 6-bit one clipped at 1/1.3: 2.7 counts) or do not trace one smooth peak."""
    levels = np.unique(y)
    q = float(np.min(np.diff(levels)))
    w = min(stop - start, start, y.size - stop)
    if w < 3:
        return False  # a run at the record's edge or at the blow: no flanks to judge by
    idx = np.r_[start - w:start, stop:stop + w]
    x = idx - 0.5 * (start + stop - 1)
    c = np.polyfit(x, y[idx], 2)
    if c[0] == 0 or np.std(y[idx] - np.polyval(c, x)) > q:
        return False
    vertex = c[2] - c[1] ** 2 / (4 * c[0])
    return bool(abs(vertex - y[start]) <= 2 * q)



def dropout_runs(y: np.ndarray, max_run: int = 8) -> list[tuple[int, int]]:
    """Runs ``[a, b)`` of exact zeros amid the motion: a sensor's signal lost for a few samples
    (a laser vibrometer's dropouts read 0 while the surface moves).

    A measured signal reads exactly 0 only where it is within half a converter count of zero:
    at rest or at a zero crossing. A run of zeros is a dropout when the cubic through the
    samples either side (:func:`eddi.calculus.fill_gaps`) puts the signal there beyond 10 noise
    RMS (noise from the median third difference, which a signal sampled 10+ times a cycle
    barely feeds) and 2 counts (the smallest step between the channel's values), and the signal
    moves beyond that on both sides (one of the two samples before, one of the two after: a
    quantized rest before a blow reads 0 up to the blow's foot). Runs at the record's ends are
    left alone; runs longer than ``max_run`` are returned too (the caller
    decides whether they can be filled).
    """
    from eddi.calculus import fill_gaps

    y = np.asarray(y, dtype=float)
    zero = y == 0.0
    if y.size < 16 or not zero.any():
        return []
    from eddi.median import median  # numpy.median's float by selection (and no numpy.ma import)

    noise = median(np.abs(np.diff(y, 3))) / 0.6745 / math.sqrt(20.0)
    count = _smallest_step(y)
    level = max(10.0 * noise, 2.0 * count, 1e-12 * peak_abs(y))
    edges = np.diff(np.concatenate(([0], zero.astype(np.int8), [0])))
    moving = []
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
        if a < 2 or b > y.size - 2:
            continue
        # moving on both sides (a blow's foot after a quantized rest reads 0 before a steep rise:
        # the cubic through the rise puts large values in the rest, a false impulse when filled)
        if float(np.max(np.abs(y[a - 2:a]))) > level and float(np.max(np.abs(y[b:b + 2]))) > level:
            moving.append((int(a), int(b)))
    guess = fill_gaps(y, zero, runs=moving)  # the cubics of those runs only (a quantized rest has hundreds)
    return [(a, b) for a, b in moving if float(np.max(np.abs(guess[a:b]))) > level]


def _smallest_step(y: np.ndarray) -> float:
    """The smallest step between the distinct values of ``y`` (``min(diff(unique(y)))``, 0 for one
    value): from the sorted values' positive steps, the same float (the distinct values are the
    sorted ones without repeats), without ``numpy.unique``'s compaction and its ``numpy.ma``
    import (~9 ms of CPU at load 22, session 19); with a NaN, ``numpy.unique`` as before."""
    s = np.sort(y)
    if s.size and np.isnan(s[-1]):  # NaNs sort last
        levels = np.unique(y)
        return float(np.min(np.diff(levels))) if levels.size > 1 else 0.0
    with np.errstate(invalid="ignore"):  # inf - inf between repeated infinities: NaN, left out as unique does
        d = np.diff(s)
    d = d[d > 0]
    return float(np.min(d)) if d.size else 0.0


def all_finite(y: np.ndarray) -> bool:
    """``np.isfinite(y).all()`` of a 1-D float array (compiled, no temporary, when contiguous)."""
    if y.ndim == 1 and y.dtype == np.float64 and y.flags.c_contiguous:
        return bool(_KERNELS._finite(y))
    return bool(np.isfinite(y).all())


def time_steps(t: np.ndarray) -> tuple[float, float] | None:
    """``(min, max)`` of ``np.diff(t)`` when ``t`` (1-D float, contiguous, >= 2 samples) is finite
    and strictly increasing; None otherwise (or for another layout: the caller's numpy checks
    then answer, with their messages)."""
    if not (t.ndim == 1 and t.size >= 2 and t.dtype == np.float64 and t.flags.c_contiguous):
        return None
    out = np.empty(2)
    return (float(out[0]), float(out[1])) if _KERNELS._steps(t, out) else None


def _finite(y):  # pragma: no cover - compiled
    for i in range(y.shape[0]):
        if not np.isfinite(y[i]):
            return False
    return True


#: Samples a block of the compiled checks below: the per-sample work of a block is a loop
#: without exits (vectorised); the verdict is read once a block. 2048 doubles: in L1.
_BLOCK = 2048
#: A double's exponent bits: all set for an infinity or a NaN.
_EXP = 0x7FF0000000000000


def _steps(t, out):  # pragma: no cover - compiled
    """Whether ``t`` is finite and strictly increasing; ``out``: the smallest and largest step.

    In blocks: the steps of a block into a buffer with the finite / increasing verdict, then
    their extremes as integers (a positive finite double orders as its bits, so the smallest
    and largest steps are the same doubles as ``min`` / ``max`` give; the integer extremes
    vectorise, the float ones do not without fast-math)."""
    n = t.shape[0]
    b = t.view(np.int64)
    if (b[0] & _EXP) == _EXP:
        return False
    buf = np.empty(_BLOCK, dtype=np.float64)
    bb = buf.view(np.int64)
    lo = np.int64(0x7FF0000000000000)  # +inf
    hi = np.int64(-0x0010000000000000)  # -inf's bits as a signed integer: below every positive double
    for s in range(1, n, _BLOCK):
        e = min(s + _BLOCK, n)
        bad = 0
        for i in range(s, e):
            d = t[i] - t[i - 1]
            bad |= ((b[i] & _EXP) == _EXP) | (not d > 0.0)
            buf[i - s] = d
        if bad:
            return False
        for k in range(e - s):
            lo = min(lo, bb[k])
            hi = max(hi, bb[k])
    bb[0] = lo
    out[0] = buf[0]
    bb[0] = hi
    out[1] = buf[0]
    return True


def _time_on_grid(t, step):  # pragma: no cover - compiled
    """:func:`check_time`'s checks in one pass: finite, increasing, and every sample within 1 %
    of a step of ``t[0] + step i`` (its deviation formed as the numpy passes form it).

    In blocks as :func:`_steps`: the deviations of a block into a buffer, the verdict once a
    block, the largest deviation as an integer (``abs`` of a finite or infinite double: a
    non-negative double, ordered as its bits; never a NaN once ``t`` is finite)."""
    n = t.shape[0]
    b = t.view(np.int64)
    t0 = t[0]
    if (b[0] & _EXP) == _EXP:
        return False
    buf = np.empty(_BLOCK, dtype=np.float64)
    bb = buf.view(np.int64)
    worst = np.int64(0)
    for s in range(0, n, _BLOCK):
        e = min(s + _BLOCK, n)
        bad = 0
        for i in range(s, e):
            bad |= (b[i] & _EXP) == _EXP
            buf[i - s] = abs((float(i) * step + t0) - t[i])
        for i in range(max(s, 1), e):
            bad |= not (t[i] - t[i - 1]) > 0.0
        if bad:
            return False
        for k in range(e - s):
            worst = max(worst, bb[k])
    bb[0] = worst
    return not buf[0] > 0.01 * step


#: The compiled kernels (:mod:`eddi.kernels`: built ahead of time, else numba's JIT).
_KERNELS = Kernels(globals(), {"_finite": ["b1(f8[::1])"], "_steps": ["b1(f8[::1], f8[::1])"],
                               "_time_on_grid": ["b1(f8[::1], f8)"]})
