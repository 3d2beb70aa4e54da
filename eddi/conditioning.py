"""Measurement conditioning: what a bench measures -> ``x, v, a`` and the free-response window.

A hammer test measures force and acceleration (or a laser vibrometer measures velocity).
EDDI needs the coordinate ``x``, its rate ``v`` and (for phase two) ``a``, over the part of
the record where the structure rings down freely and the response is above the noise.

Drift-free integration (``acc`` -> ``v``, ``x``), see ``docs/conditioning.md``
---------------------------------------------------------------------------------
1. Integrate the (bias-corrected) acceleration from rest: the pre-trigger proves
   ``x = v = 0`` there, so nothing is filtered and the impulse response keeps all of its
   low-frequency content (the mean of an impulse response is the impulse times the
   compliance, which a high-pass removes).
2. The integrated ``x`` carries a smooth drift ``d(t)`` (noise random walk, sensor bias,
   IEPE coupling). ``d`` is estimated only where the true ``x`` is known to be zero: at the
   zero crossings of the acceleration in the free response (``a = 0`` means
   ``K(x) = -B(x, v)``, i.e. ``x ~ 0`` for a restoring force with its only zero at 0; the
   small damping offset alternates in sign and averages out), and in the tail where the
   response has sunk into the noise. ``d`` is a cubic spline with knots every two of the
   longest periods, clamped to ``d = d' = 0`` at the start of the motion.
3. ``x = x_int - d`` and ``v = v_int - d'``; ``a`` is the measured acceleration.

Velocity-only input (laser vibrometer) is integrated the same way (``v`` is kept as
measured) and differentiated with a Savitzky-Golay filter (zero phase) for ``a``.

Records that start in motion (no rest before them, e.g. vibrometer ring-downs): the
integration constants are unknown. :func:`integrate_about_equilibrium` makes the integral
average to zero over every cycle of every mode (a cascade of moving averages over the
modes' periods, the lowest mode's period tracked along the record; the drift is a spline
through those means), integrating through a cubic spline (the trapezoid rule loses
``(w h)^2 / 12`` of the amplitude). When ``x`` at the zero crossings of ``a`` behaves as one
restoring force (:func:`anchor_residual` < :data:`ONE_FORCE_RESIDUAL`) the ``a = 0``
anchors above are used on top (they handle damping, chirp and asymmetry); with several
modes ``a = 0`` does not mean ``x = 0`` and the cycle means alone are used.

:func:`integrate_highpass` is the paper's procedure (integrate, then a zero-phase
third-order Butterworth high-pass at 2-3 Hz; paper Sec. 4.1 and 4.2), kept for comparison.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import cumulative_trapezoid
from scipy.interpolate import BSpline

from eddi.calculus import integrate, spline_cumulative_integral
from eddi.errors import SignalError

#: Minimum number of acceleration zero crossings in the free response (3: a short ring-down,
#: e.g. dry friction that sticks after a cycle, is data; fewer hold nothing to anchor the drift).
MIN_CROSSINGS = 3
#: Knot spacing of the drift spline, in (longest) periods of the response.
KNOT_PERIODS = 2.0
#: Half width of the sample groups around each acceleration zero crossing, in periods.
ANCHOR_HALF_WIDTH = 0.02
#: A record that starts in motion is treated as one restoring force (drift anchored where
#: ``a = 0``) when ``x`` there is within this fraction of its RMS of ``c_a a + c_v v`` (plus
#: a line in time); otherwise (several modes) it is integrated about the equilibrium only.
#: Measured: one mode 0.0004-0.05, two modes 0.5-0.9 (docs/conditioning.md).
ONE_FORCE_RESIDUAL = 0.3


@dataclass(frozen=True)
class ConditionedSignal:
    """Signals ready for identification.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
        Uniform time (the exact grid from the first to the last input time).
    x : ndarray, shape (n,), [m] (or [rad])
        Coordinate, from rest (0 before the impact when a pre-trigger was seen).
    v : ndarray, shape (n,), [m/s]
        Rate.
    a : ndarray, shape (n,), [m/s^2]
        Second derivative.
    force : ndarray, shape (n,), [N], or None
        Measured force with its pre-trigger offset removed.
    rate_hz : float
        Sample rate [Hz].
    free_start, free_stop : int
        Free-response window ``[free_start, free_stop)``: after the impact has ended, until
        the response sinks into the noise.
    method : str
        How ``x``, ``v`` and ``a`` were obtained.
    notes : tuple of str
        Facts found on the way (noise floor, knots, impact indices...).
    impact_start : int
        First sample of the motion (rest before it), 0 when no rest was seen.
    impact_end : int
        First sample after the impact force is back within the noise (== ``free_start``
        when there is a force channel).
    noise_rms : float
        Noise RMS of the measured response channel (units of that channel).
    force_noise_rms : float
        Noise RMS of the force channel [N] (0 without force).
    acc_measured : bool
        True when ``a`` is the measured acceleration (not a derivative).
    response : str
        The measured response channel the window and noise floor refer to: ``"acc"``,
        ``"vel"`` or ``"disp"`` (acceleration first when several were given).
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    force: np.ndarray | None
    rate_hz: float
    free_start: int
    free_stop: int
    method: str
    notes: tuple[str, ...] = field(default_factory=tuple)
    impact_start: int = 0
    impact_end: int = 0
    noise_rms: float = 0.0
    force_noise_rms: float = 0.0
    acc_measured: bool = False
    response: str = "acc"

    def __post_init__(self) -> None:
        n = self.t.size
        for name in ("x", "v", "a"):
            if getattr(self, name).shape != (n,):
                raise SignalError(f"conditioned {name} has shape {getattr(self, name).shape}, expected ({n},)")
        if not 0 <= self.free_start < self.free_stop <= n:
            raise SignalError(
                f"free-response window [{self.free_start}, {self.free_stop}) is not inside 0..{n}"
            )

    @property
    def window(self) -> tuple[int, int]:
        """``(free_start, free_stop)``."""
        return (self.free_start, self.free_stop)

    @property
    def impact_force(self) -> np.ndarray | None:
        """The force during the impact ``[impact_start, impact_end)``, zero elsewhere [N].

        Outside the impact a hammer's force sensor shows only its noise; this is the force
        a validation simulation should be driven with.
        """
        if self.force is None:
            return None
        f = np.zeros_like(self.force)
        f[self.impact_start: self.impact_end] = self.force[self.impact_start: self.impact_end]
        return f


# ----------------------------------------------------------------------------------------
# checks
# ----------------------------------------------------------------------------------------
def check_time(t: np.ndarray) -> float:
    """Check a time vector and return its sample rate [Hz].

    Raises
    ------
    SignalError
        If ``t`` is not 1-D, has fewer than 16 samples, is not finite, not increasing or
        not uniform (a sample more than 1 % of a step off the uniform grid).
    """
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 16:
        raise SignalError(f"time must be a 1-D array of at least 16 samples, got shape {t.shape}")
    bad = np.nonzero(~np.isfinite(t))[0]
    if bad.size:
        raise SignalError(f"time is NaN or infinite at sample {int(bad[0])}")
    dt = np.diff(t)
    if np.any(dt <= 0):
        i = int(np.nonzero(dt <= 0)[0][0])
        raise SignalError(f"time must increase; t[{i + 1}] = {t[i + 1]:g} after t[{i}] = {t[i]:g}")
    step = (t[-1] - t[0]) / (t.size - 1)
    # each sample within 1 % of a step of the uniform grid (allows times printed with few digits)
    dev = np.abs(t - (t[0] + step * np.arange(t.size)))
    if np.max(dev) > 0.01 * step:
        i = int(np.argmax(dev))
        raise SignalError(
            f"time must be uniformly sampled; t[{i}] = {t[i]:.9g} s is {dev[i]:.3g} s off the grid "
            f"of step {step:.6g} s (expected within 1 % of a step)"
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
    bad = np.nonzero(~np.isfinite(y))[0]
    if bad.size:
        raise SignalError(f"channel {name!r} is NaN or infinite at sample {int(bad[0])}")
    return y


def clipped_run(y: np.ndarray, min_run: int = 5) -> int | None:
    """Index where ``y`` sits flat at its global maximum or minimum for ``min_run`` samples.

    A clipped channel is flat-topped at its extreme value; a smooth signal sampled with
    enough resolution does not repeat its extreme value several samples in a row.

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
        long = np.nonzero(stops - starts >= min_run)[0]
        if long.size:
            return int(starts[long[0]])
    return None


# ----------------------------------------------------------------------------------------
# building blocks
# ----------------------------------------------------------------------------------------
def integrate_highpass(t: np.ndarray, acc: np.ndarray, cutoff_hz: float = 2.0,
                       order: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """The paper's integration: integrate, then zero-phase Butterworth high-pass, twice.

    Paper Sec. 4.1: "numerically integrating the accelerations and high-pass filtering the
    output using a third-order Butterworth filter with a cutoff frequency of 2 Hz" (3 Hz in
    Sec. 4.2). Kept as the reference that :func:`condition` is measured against.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    acc : ndarray, shape (n,), [m/s^2]
    cutoff_hz : float
    order : int

    Returns
    -------
    x, v : ndarray, shape (n,)
        Displacement [m] and velocity [m/s].
    """
    from scipy import signal as sps  # local: scipy.signal imports scipy.stats (~0.5 s)

    rate = check_time(t)
    sos = sps.butter(order, cutoff_hz, btype="highpass", fs=rate, output="sos")
    v = sps.sosfiltfilt(sos, cumulative_trapezoid(acc, t, initial=0.0))
    x = sps.sosfiltfilt(sos, cumulative_trapezoid(v, t, initial=0.0))
    return x, v


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


def crossings(y: np.ndarray, hysteresis: float, start: int = 0, stop: int | None = None) -> np.ndarray:
    """Zero crossings of ``y`` with hysteresis, as fractional sample indices.

    A crossing counts only when ``y`` has gone beyond ``+-hysteresis`` on both sides; its
    position is the linear interpolation of the last sign change before reaching the other
    side.

    Returns
    -------
    ndarray, shape (k,)
        Fractional indices (``i + frac``) in ``[start, stop)``.
    """
    stop = y.size if stop is None else stop
    seg = np.asarray(y[start:stop], float)
    if seg.size < 3:
        return np.zeros(0)
    state = np.where(seg > hysteresis, 1, np.where(seg < -hysteresis, -1, 0))
    nz = np.nonzero(state)[0]
    if nz.size < 2:
        return np.zeros(0)
    s = state[nz]
    flips = nz[1:][s[1:] != s[:-1]]  # first sample beyond threshold on the new side
    sign_change = np.nonzero(np.signbit(seg[:-1]) != np.signbit(seg[1:]))[0]
    if flips.size == 0 or sign_change.size == 0:
        return np.zeros(0)
    pos = np.searchsorted(sign_change, flips, side="left") - 1
    ok = pos >= 0
    i = sign_change[pos[ok]]
    y0, y1 = seg[i], seg[i + 1]
    frac = np.where(y1 != y0, y0 / (y0 - y1), 0.5)
    return start + i + np.clip(frac, 0.0, 1.0)


def _onset(r: np.ndarray, head: int) -> tuple[int, float]:
    """Start of the run of ``|r|`` above the noise that leads to its peak, and the peak.

    ``r`` has its rest offset removed; ``head`` samples at the start give a (robust) noise
    scale. The level is the larger of 5 % of the peak and 6 noise RMS.
    """
    peak_i = int(np.argmax(np.abs(r)))
    peak = abs(float(r[peak_i]))
    h = r[: max(8, head)]
    sigma = 1.4826 * float(np.median(np.abs(h - np.median(h))))
    level = max(0.05 * peak, 6.0 * sigma)
    below = np.nonzero(np.abs(r[: peak_i + 1]) <= level)[0]
    return (int(below[-1]) + 1 if below.size else 0), peak


def _sg_derivative(y: np.ndarray, rate_hz: float, period_s: float, deriv: int,
                   split: int = 0) -> np.ndarray:
    """Zero-phase Savitzky-Golay derivative with a window of about a tenth of a period.

    The record is differentiated in two pieces, ``[:split]`` and ``[split:]``, so that the
    jump of the rate at an impact is not smeared into the free response.
    """
    from scipy import signal as sps  # local: scipy.signal imports scipy.stats (~0.5 s)

    out = np.zeros_like(y)
    for lo, hi in ((0, split), (split, y.size)):
        seg = y[lo:hi]
        if seg.size < 5:
            out[lo:hi] = np.gradient(seg, 1.0 / rate_hz) if seg.size > 1 and deriv == 1 else 0.0
            continue
        win = int(round(period_s * rate_hz / 10.0)) | 1
        win = max(5, min(win, 201))
        if win > seg.size:
            win = seg.size if seg.size % 2 else seg.size - 1
        out[lo:hi] = sps.savgol_filter(seg, win, polyorder=min(3, win - 1), deriv=deriv,
                                       delta=1.0 / rate_hz)
    return out


def _at(y: np.ndarray, pos: np.ndarray) -> np.ndarray:
    """``y`` linearly interpolated at fractional sample indices ``pos``."""
    idx = np.floor(pos).astype(int)
    frac = pos - idx
    nxt = np.minimum(idx + 1, y.size - 1)
    return y[idx] * (1 - frac) + y[nxt] * frac


def _drift_spline(
    t: np.ndarray, x_int: np.ndarray, pts: np.ndarray, knot_s: float, start: int, clamped: bool,
    local: np.ndarray, free_slope: bool = False,
) -> BSpline:
    """Least-squares cubic spline ``d`` with ``x_int = d(t) + local @ c`` at samples ``pts``.

    ``local`` holds, per sample, signals to which the true ``x`` is locally proportional
    near its zeros (``-a`` and ``-v``: near ``x = 0``, ``k1 x = -m a - b1 v``); their
    coefficients ``c`` are fitted with the spline. With ``clamped``, ``d`` and (unless
    ``free_slope``) its slope are 0 at ``t[start]`` (rest).
    """
    t0, t1 = float(t[start]), float(t[-1])
    n_int = max(1, int(math.ceil((t1 - t0) / knot_s)))
    inner = np.linspace(t0, t1, n_int + 1)
    knots = np.concatenate(([t0] * 3, inner, [t1] * 3))
    basis = BSpline.design_matrix(t[pts], knots, 3)
    first = (1 if free_slope else 2) if clamped else 0
    # the B-spline block stays sparse (4 non-zeros a row): the normal equations are built
    # block by block, never as a dense (rows x knots) product (a dense one took 2 s of
    # multi-threaded BLAS on a 45 s record; this takes a few ms)
    b = basis.tocsc()[:, first:]
    m = b.shape[1]
    # a light second-difference penalty keeps intervals without samples well posed
    d2 = np.diff(np.eye(m), 2, axis=0)
    btb = (b.T @ b).toarray()
    lam = 1e-3 * float(np.mean(np.diag(btb)))
    scale = np.max(np.abs(local), axis=0)
    scale[scale == 0] = 1.0
    loc = local / scale
    y = x_int[pts]
    k = m + loc.shape[1]
    normal = np.empty((k, k))
    normal[:m, :m] = btb + lam * d2.T @ d2
    normal[:m, m:] = np.asarray(b.T @ loc)
    normal[m:, :m] = normal[:m, m:].T
    normal[m:, m:] = loc.T @ loc
    rhs = np.concatenate((np.asarray(b.T @ y).ravel(), loc.T @ y))
    sol = np.linalg.solve(normal + 1e-12 * np.eye(k), rhs)
    coef = np.zeros(basis.shape[1])
    coef[first:] = sol[:m]
    return BSpline(knots, coef, 3, extrapolate=False)


# ----------------------------------------------------------------------------------------
# records that start in motion: integration about the equilibrium
# ----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class EquilibriumIntegral:
    """Result of :func:`integrate_about_equilibrium`.

    Attributes
    ----------
    x : ndarray, shape (n,), [m]
        Displacement, oscillating about the equilibrium ``x = 0``.
    v : ndarray, shape (n,), [m/s]
        Velocity: the given one, or (from acceleration) integrated about zero the same way.
    modes_hz : tuple of float
        Frequencies of the spectral peaks of the displacement whose periods are averaged
        over (lowest first).
    f1_hz : ndarray, shape (n,), [Hz]
        Frequency of the lowest mode used for the cycle averages at each sample (constant
        unless the crossings show the frequency varying by 1 % or more).
    """

    x: np.ndarray
    v: np.ndarray
    modes_hz: tuple[float, ...]
    f1_hz: np.ndarray


def _spectral_peaks(y: np.ndarray, rate: float, power: int, rel: float,
                    max_peaks: int = 4) -> list[float]:
    """Frequencies [Hz] of the largest local maxima of ``|Y(f)| / f**power`` (Hann window).

    Peaks below ``8 / record length`` (fewer than 8 cycles in the record) are ignored, as
    are those less than 10 times the median of ``|Y|`` (the noise floor of a sensor) and
    those below ``rel`` times the largest. Positions are refined by a parabola through
    the log magnitudes of the three bins around each maximum. Returned lowest first.
    """
    n = y.size
    mag = np.abs(np.fft.rfft((y - np.mean(y)) * np.hanning(n)))
    f = np.fft.rfftfreq(n, 1.0 / rate)
    lo = max(8.0 * rate / n, f[2])
    # a peak must stand 10 times above the median level of the measured channel (its noise
    # floor, white for a sensor), before the weighting raises low-frequency noise
    w = np.where((f >= lo) & (mag > 10.0 * float(np.median(mag))),
                 mag / np.maximum(f, lo) ** power, 0.0)
    if not np.any(w > 0):
        return []
    mid = w[1:-1]
    loc = np.nonzero((mid >= rel * np.max(w)) & (mid >= w[:-2]) & (mid > w[2:]))[0] + 1
    loc = loc[np.argsort(-w[loc])][:max_peaks]
    out = []
    for k in loc:
        la, lb, lc = np.log(w[k - 1: k + 2] + 1e-300)
        den = la - 2.0 * lb + lc
        shift = 0.5 * (la - lc) / den if den != 0 else 0.0
        out.append(float(f[k] + np.clip(shift, -0.5, 0.5) * (f[1] - f[0])))
    return sorted(out)


def _lsq_spline(tp: np.ndarray, y: np.ndarray, t0: float, t1: float, knot_s: float) -> BSpline:
    """Least-squares cubic spline on ``[t0, t1]``, uniform knots ``knot_s`` apart.

    A light second-difference penalty keeps intervals with few samples well posed.
    """
    n_int = max(1, int(math.ceil((t1 - t0) / knot_s)))
    knots = np.concatenate(([t0] * 3, np.linspace(t0, t1, n_int + 1), [t1] * 3))
    b = BSpline.design_matrix(np.clip(tp, t0, t1), knots, 3).tocsc()
    m = b.shape[1]
    btb = (b.T @ b).toarray()
    d2 = np.diff(np.eye(m), 2, axis=0)
    lam = 1e-3 * float(np.mean(np.diag(btb)))
    coef = np.linalg.solve(btb + lam * d2.T @ d2 + 1e-12 * np.eye(m), np.asarray(b.T @ y).ravel())
    return BSpline(knots, coef, 3)


def _cycle_means(t: np.ndarray, y: np.ndarray, width_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean of ``y`` over ``[t - w/2, t + w/2]`` at every ``t`` whose window fits the record.

    ``width_s`` may vary with ``t`` (one local period). The integral is the trapezoid
    cumulative integral interpolated at the window ends (fractional samples).
    """
    cum = cumulative_trapezoid(y, t, initial=0.0)
    ok = (t - width_s / 2 >= t[0]) & (t + width_s / 2 <= t[-1])
    tc, w = t[ok], width_s[ok]
    return tc, (np.interp(tc + w / 2, t, cum) - np.interp(tc - w / 2, t, cum)) / w


def _remove_cycle_mean(t: np.ndarray, y_int: np.ndarray, f1_hz: np.ndarray,
                       others_hz: list[float]) -> np.ndarray:
    """``y_int`` minus the smooth drift that makes its mean over every cycle zero.

    The cycle means are a cascade of moving averages: two over the local period of the
    lowest mode (``1 / f1_hz``, which may vary along the record) and one over the period
    of each other mode, so that each mode (and the harmonics of each) averages to zero.
    The drift is a least-squares cubic spline through the means, knots one shortest
    lowest-mode period apart, extended to the ends of the record.
    """
    tc, m = t, y_int
    widths = [1.0 / f1_hz, 1.0 / f1_hz] + [np.full(t.size, 1.0 / f) for f in others_hz]
    for w in widths:
        wk = np.interp(tc, t, w)
        if tc.size < 8 or tc[-1] - tc[0] <= np.max(wk):
            break
        tc, m = _cycle_means(tc, m, wk)
    if tc.size < 8:
        return y_int - float(np.mean(y_int))
    knot_s = 1.0 / float(np.max(f1_hz))
    step = max(1, int(tc.size / max(1.0, (tc[-1] - tc[0]) / knot_s) / 16))
    drift = _lsq_spline(tc[::step], m[::step], float(t[0]), float(t[-1]), knot_s)
    return y_int - drift(t)


def _lowest_mode_frequency(t: np.ndarray, x: np.ndarray, rate: float, f1: float,
                           higher_hz: list[float]) -> np.ndarray:
    """Frequency of the lowest mode along the record [Hz], from the zero crossings of ``x``.

    ``x`` is low-passed (zero phase, 8th-order Butterworth at 1.6 ``f1`` or between ``f1``
    and the next mode) so that its crossings are those of the lowest mode; the frequency of
    each cycle (between alternate crossings, away from the ends and above 5 % of the
    amplitude) is smoothed by a cubic spline. Constant ``f1`` (the median) when it varies by
    less than 1 %, or when there are too few crossings.
    """
    from scipy import signal as sps  # local: scipy.signal imports scipy.stats (~0.5 s)

    n = x.size
    fc = 1.6 * f1
    above = [f for f in higher_hz if f > 1.15 * f1]
    if above:
        fc = min(fc, math.sqrt(f1 * min(above)))
    const = np.full(n, f1)
    edge = int(2.0 * rate / f1)
    if fc >= 0.45 * rate or n < 4 * edge + 16:
        return const
    xl = sps.sosfiltfilt(sps.butter(8, fc, fs=rate, output="sos"), x)
    amp = float(np.max(np.abs(xl[edge: n - edge])))
    c = crossings(xl, 0.02 * amp, start=edge, stop=n - edge)
    if c.size < 6:
        return const
    env = np.array([np.max(np.abs(xl[int(c[i]): int(c[i + 2]) + 1])) for i in range(c.size - 2)])
    tm = t[0] + (c[2:] + c[:-2]) / (2.0 * rate)
    fr = rate / (c[2:] - c[:-2])
    keep = env > 0.05 * amp
    tm, fr = tm[keep], fr[keep]
    if tm.size < 4:
        return const
    span = float(tm[-1] - tm[0])
    knot_s = max(2.0 / f1, min(8.0 / f1, span / 4.0))
    smooth = _lsq_spline(tm, fr, float(tm[0]), float(tm[-1]), knot_s)(tm) if span >= 2 * knot_s \
        else np.full(tm.size, np.median(fr))
    if np.ptp(smooth) < 0.01 * float(np.median(smooth)):
        return np.full(n, float(np.median(fr)))
    return np.interp(t, tm, smooth)


def integrate_about_equilibrium(
    t: np.ndarray, *, vel: np.ndarray | None = None, acc: np.ndarray | None = None,
) -> EquilibriumIntegral:
    """Displacement (and velocity) of a free response recorded already in motion.

    Without a rest before the record the integration constants are unknown and the
    integral drifts (sensor offset, noise random walk). A free response oscillates about
    its equilibrium, so over every cycle of every mode its mean is (nearly) zero: the
    constant and the drift are fitted so that the integral has zero cycle means (see
    :func:`_remove_cycle_mean`; two passes, the second with the lowest mode's frequency
    tracked along the record for nonlinear systems whose frequency changes as they decay).
    This holds for several modes at once, where ``a = 0`` no longer implies ``x = 0``.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Uniform time.
    vel : ndarray, shape (n,), [m/s], optional
        Measured velocity (used as it is).
    acc : ndarray, shape (n,), [m/s^2], optional
        Measured acceleration, used when ``vel`` is not given.

    Returns
    -------
    EquilibriumIntegral

    Raises
    ------
    SignalError
        Neither channel given, or no spectral peak with 8 cycles in the record.
    """
    rate = check_time(t)
    t = np.asarray(t, dtype=float)
    if vel is None and acc is None:
        raise SignalError("need vel or acc to integrate; got neither")
    order = 1 if vel is not None else 2
    y = np.asarray(vel if vel is not None else acc, dtype=float)
    peaks = _spectral_peaks(y, rate, power=order, rel=0.1)
    if not peaks:
        raise SignalError(f"no spectral peak with at least 8 cycles in the {t[-1] - t[0]:.3g} s record")
    f1, others = peaks[0], peaks[1:]

    def once(f1_hz: np.ndarray, rest_hz: list[float]) -> tuple[np.ndarray, np.ndarray]:
        if vel is not None:
            v = np.asarray(vel, dtype=float)
        else:
            v = _remove_cycle_mean(t, spline_cumulative_integral(t, y), f1_hz, rest_hz)
        return _remove_cycle_mean(t, spline_cumulative_integral(t, v), f1_hz, rest_hz), v

    x, _ = once(np.full(t.size, f1), others)
    f1_t = _lowest_mode_frequency(t, x, rate, f1, others)
    lo, hi = float(np.min(f1_t)), float(np.max(f1_t))
    rest = [f for f in others if not 0.9 * lo <= f <= 1.1 * hi]
    x, v = once(f1_t, rest)
    return EquilibriumIntegral(x=x, v=v, modes_hz=tuple(peaks), f1_hz=f1_t)


def anchor_residual(x: np.ndarray, v: np.ndarray, a: np.ndarray) -> float:
    """How far ``x`` is from one restoring force at the zero crossings of ``a``.

    With one restoring force ``K(x)`` with its only zero at 0, ``a = 0`` gives
    ``K(x) = -B(x, v)``: near there ``x = c_a a + c_v v``. ``x`` at the crossings of ``a``
    (hysteresis: 3 noise RMS, at least 0.1 % of the peak) is regressed on ``1, t, a, v``;
    with several modes ``a = 0`` says nothing about ``x`` and the residual is large.

    Parameters
    ----------
    x, v, a : ndarray, shape (n,)
        Displacement, velocity, acceleration of a free response.

    Returns
    -------
    float
        RMS of the regression residual over the RMS of ``x`` (inf with fewer than 8 crossings).
    """
    hyst = max(3.0 * noise_rms(a, 0), 1e-3 * float(np.max(np.abs(a))))
    anc = crossings(a, hyst)
    if anc.size < 8:
        return math.inf
    tau = anc / x.size
    design = np.column_stack((np.ones(anc.size), tau, _at(a, anc), _at(v, anc)))
    design /= np.maximum(np.max(np.abs(design), axis=0), 1e-300)
    xa = _at(x, anc)
    coef, *_ = np.linalg.lstsq(design, xa, rcond=None)
    return float(np.sqrt(np.mean((xa - design @ coef) ** 2)) / max(np.sqrt(np.mean(x ** 2)), 1e-300))


def _sg_derivative_modes(y: np.ndarray, rate_hz: float, period_s: float) -> np.ndarray:
    """Zero-phase Savitzky-Golay first derivative (5th order, a quarter of the shortest period).

    The shortest period is that of the highest peak of ``|Y(f)|`` above 5 % of the largest
    (``period_s`` when there is none). Against the tenth-of-a-period cubic window this
    quarters the noise on the derivative at the same bias on the modes (measured in
    ``docs/conditioning.md``).
    """
    from scipy import signal as sps  # local: scipy.signal imports scipy.stats (~0.5 s)

    peaks = _spectral_peaks(y, rate_hz, power=0, rel=0.05)
    shortest = 1.0 / peaks[-1] if peaks else period_s
    win = max(7, int(round(0.25 * shortest * rate_hz)) | 1)
    if win > y.size:
        win = y.size if y.size % 2 else y.size - 1
    return sps.savgol_filter(y, win, polyorder=min(5, win - 1), deriv=1, delta=1.0 / rate_hz)


# ----------------------------------------------------------------------------------------
# the conditioner
# ----------------------------------------------------------------------------------------
def condition(
    t: np.ndarray,
    *,
    acc: np.ndarray | None = None,
    vel: np.ndarray | None = None,
    disp: np.ndarray | None = None,
    force: np.ndarray | None = None,
    pretrigger_samples: int | None = None,
    ac_coupling_s: float | None = None,
    noise_factor: float = 10.0,
    free_drift_slope: bool = False,
) -> ConditionedSignal:
    """Turn measured channels into ``x, v, a`` and find the free-response window.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Uniform, increasing time.
    acc, vel, disp : ndarray, shape (n,), optional
        Measured acceleration [m/s^2], velocity [m/s], displacement [m]; at least one. Given
        ``disp`` and ``vel`` are used as they are.
    force : ndarray, shape (n,), [N], optional
        Measured hammer force; used to find the impact and its end.
    pretrigger_samples : int, optional
        Samples of rest before the trigger (default: detected).
    ac_coupling_s : float, optional
        Time constant [s] of a first-order AC coupling (IEPE) on ``acc``; when given, the
        coupling is inverted before integration.
    noise_factor : float
        The free response stops where the envelope of the measured response falls below
        ``noise_factor`` times its noise RMS.
    free_drift_slope : bool
        With a rest before the impact, the integration drift is 0 at the motion's start;
        False (default) also holds its slope at 0 there, True leaves the slope free: the
        integral over the impact pulse leaves a small velocity step that a clamped slope
        spreads over the first knot intervals (on a clean 50 Hz record at 41 samples a
        period the displacement error fell from 1.7e-3 to 3.9e-4 of its RMS, 4.4e-4 in the
        first tenth of the window instead of 1.8e-3).
    Returns
    -------
    ConditionedSignal

    Raises
    ------
    SignalError
        Bad time base, NaN, no response channel, no motion, too few zero crossings.
    """
    w = _inputs(t, acc, vel, disp, force)
    w.free_slope = bool(free_drift_slope)
    _onset_and_rest(w, pretrigger_samples)
    _remove_rest_offsets(w, ac_coupling_s)
    _impact_end_from_force(w)
    _period(w)
    if w.disp is not None:
        _kinematics_from_disp(w)
    elif w.vel is not None or w.acc is not None:
        _kinematics_by_integration(w, noise_factor)
    return _free_window(w, noise_factor)


@dataclass
class _Work:
    """State passed between the steps of :func:`condition` (internal, mutable)."""

    t: np.ndarray
    rate: float
    acc: np.ndarray | None
    vel: np.ndarray | None
    disp: np.ndarray | None
    force: np.ndarray | None
    resp_name: str
    resp: np.ndarray
    notes: list[str]
    margin: int = 2
    start: int = 0
    rest: bool = False
    noise_stop: int = 0
    sigma: float = 0.0
    f_sigma: float = 0.0
    impact_end: int = -1
    period_s: float = 0.0
    x: np.ndarray | None = None
    v: np.ndarray | None = None
    a: np.ndarray | None = None
    method: str = ""
    free_slope: bool = False

    @property
    def n(self) -> int:
        return self.t.size


def _inputs(t: np.ndarray, acc: np.ndarray | None, vel: np.ndarray | None, disp: np.ndarray | None,
            force: np.ndarray | None) -> _Work:
    """Check the channels; the exact uniform grid; the response channel that shows the motion."""
    rate = check_time(t)
    t = np.asarray(t, dtype=float)
    n = t.size
    # the exact uniform grid (times in files are often printed with few digits)
    t = t[0] + np.arange(n) * ((t[-1] - t[0]) / (n - 1))
    if acc is None and vel is None and disp is None:
        raise SignalError("need at least one of acc, vel, disp; got none")
    acc = None if acc is None else check_channel("acc", acc, n)
    vel = None if vel is None else check_channel("vel", vel, n)
    disp = None if disp is None else check_channel("disp", disp, n)
    force = None if force is None else check_channel("force", force, n)
    if acc is not None:
        name, resp = "acc", acc
    elif vel is not None:
        name, resp = "vel", vel
    else:
        name, resp = "disp", disp
    return _Work(t, rate, acc, vel, disp, force, name, resp, [],  # type: ignore[arg-type]
                 margin=max(2, int(round(2e-4 * rate))))


def _onset_and_rest(w: _Work, pretrigger_samples: int | None) -> None:
    """Onset of the motion, whether a rest was seen before it, and the response's noise RMS."""
    n, resp = w.n, w.resp
    head = max(8, min(pretrigger_samples or n // 20, n // 5))
    if w.force is not None and np.ptp(w.force) > 0:
        onset, _ = _onset(w.force - np.median(w.force[:head]), head)
    else:
        onset, _ = _onset(resp - np.median(resp[:head]), head)
    if pretrigger_samples is not None:
        if not 0 <= pretrigger_samples < n:
            raise SignalError(f"pretrigger_samples must be in 0..{n - 1}, got {pretrigger_samples}")
        onset = min(onset, int(pretrigger_samples)) if pretrigger_samples > 0 else onset
    start = max(0, onset - w.margin)
    rest = start >= 32 if pretrigger_samples is None else (pretrigger_samples > 0 and start > 0)
    if rest and pretrigger_samples is None:
        # rest means quiet: the head must be small compared with the response
        quiet = resp[:start]
        if np.std(quiet) > 0.02 * np.max(np.abs(resp - np.mean(quiet))):
            rest = False
    w.start = start if rest else 0
    w.rest = rest
    w.noise_stop = max(0, w.start - w.margin) if rest else 0
    w.sigma = noise_rms(resp, w.noise_stop)
    w.notes.append(f"motion starts at sample {w.start} ({'rest before' if rest else 'no rest seen'})")


def _remove_rest_offsets(w: _Work, ac_coupling_s: float | None) -> None:
    """Offsets seen at rest removed from the force and the acceleration; AC coupling inverted."""
    n, ns = w.n, w.noise_stop
    if w.force is not None:
        f_off = float(np.mean(w.force[:ns])) if ns >= 8 else float(np.median(w.force[: max(8, n // 50)]))
        w.force = w.force - f_off
    if w.acc is not None and w.rest and ns >= 8:
        w.acc = w.acc - float(np.mean(w.acc[:ns]))
    if w.acc is not None and ac_coupling_s is not None:
        if not ac_coupling_s > 0:
            raise SignalError(f"ac_coupling_s must be > 0, got {ac_coupling_s}")
        w.acc = w.acc + cumulative_trapezoid(w.acc, w.t, initial=0.0) / ac_coupling_s
        w.notes.append(f"AC coupling ({ac_coupling_s:g} s) inverted")


def _impact_end_from_force(w: _Work) -> None:
    """End of the impact where the force returns within its noise of zero (force measured)."""
    f = w.force
    if f is None or not np.ptp(f) > 0:
        return  # decided after integration (first extremum of x)
    w.f_sigma = noise_rms(f, w.noise_stop)
    f_peak_i = int(np.argmax(np.abs(f)))
    thr = max(5.0 * w.f_sigma, 0.01 * abs(float(f[f_peak_i])))
    look = f[f_peak_i: min(w.n, f_peak_i + int(0.1 * w.rate))]
    above = np.nonzero(np.abs(look) > thr)[0]
    w.impact_end = min(w.n - 1, f_peak_i + int(above[-1]) + 1 + w.margin)
    w.notes.append(f"impact ends at sample {w.impact_end} (force within {thr:.3g} N of zero)")


def _period(w: _Work) -> None:
    """Longest period of the response, from its zero crossings."""
    resp = w.resp
    hyst = max(3.0 * w.sigma, 1e-9 * float(np.max(np.abs(resp))))
    base = resp if w.resp_name == "acc" else resp - np.median(resp[w.start:])
    crs = crossings(base, hyst, start=max(w.start, w.impact_end))
    if crs.size < MIN_CROSSINGS:
        raise SignalError(
            f"too few zero crossings of {w.resp_name} in the response: {crs.size}, expected >= {MIN_CROSSINGS}"
        )
    half = np.diff(crs)
    w.period_s = 2.0 * float(np.percentile(half[: max(4, half.size // 2)], 90)) / w.rate
    w.notes.append(f"longest period {w.period_s:.4g} s; drift knots every {KNOT_PERIODS * w.period_s:.4g} s")


def _kinematics_from_disp(w: _Work) -> None:
    """A measured displacement: ``v`` and ``a`` as measured or by Savitzky-Golay derivatives."""
    split = w.impact_end if w.impact_end >= 0 else w.start
    x = w.disp
    assert x is not None
    if w.vel is not None:
        w.x, w.v = x, w.vel
        w.a = w.acc if w.acc is not None else _sg_derivative(w.vel, w.rate, w.period_s, 1, split)
        w.method = "disp and vel as measured" + (", acc as measured" if w.acc is not None
                                                 else ", acc by Savitzky-Golay derivative of vel")
        return
    w.x = x
    w.v = _sg_derivative(x, w.rate, w.period_s, 1, split)
    w.a = w.acc if w.acc is not None else _sg_derivative(x, w.rate, w.period_s, 2, split)
    w.method = "disp as measured; vel and acc by Savitzky-Golay derivatives"


def _anchored_drift(w: _Work, x_int: np.ndarray, v_int: np.ndarray, a_for_anchor: np.ndarray,
                    noise_factor: float) -> tuple[np.ndarray, np.ndarray]:
    """The drift ``d, d'`` of an integrated ``x``, anchored where ``a = 0`` and in the noise tail."""
    first = max(w.start, w.impact_end)
    a_sigma = noise_rms(a_for_anchor, w.noise_stop)
    h = max(3.0 * a_sigma, 1e-9 * float(np.max(np.abs(a_for_anchor))))
    anc = crossings(a_for_anchor, h, start=first)
    if w.impact_end < 0 and anc.size:
        anc = anc[1:]  # no force: the first crossing is at the end of the impact
    stop = _envelope_stop(a_for_anchor, first, a_sigma, noise_factor, w.period_s, w.rate)
    anc = anc[anc < stop]
    if anc.size < MIN_CROSSINGS:
        raise SignalError(
            f"too few zero crossings of the acceleration above the noise: {anc.size}, expected >= {MIN_CROSSINGS}"
        )
    # samples within +-2 % of a period of each crossing (|x| below ~12 % of its amplitude)
    half_w = max(1, int(round(ANCHOR_HALF_WIDTH * w.period_s * w.rate)))
    centre = np.rint(anc).astype(int)
    near = (centre[:, None] + np.arange(-half_w, half_w + 1)[None, :]).ravel()
    near = near[(near > max(first, w.start)) & (near < stop)]
    step = max(1, int(round(w.period_s * w.rate / (2 * half_w + 1) / 2.0)))
    tail = np.arange(stop, w.n, step)
    pts = np.unique(np.concatenate((near, tail)))
    local = -np.column_stack((a_for_anchor[pts], v_int[pts]))
    spl = _drift_spline(w.t, x_int, pts, KNOT_PERIODS * w.period_s, w.start, clamped=w.rest, local=local,
                        free_slope=w.free_slope)
    return _drift_spline_eval(spl, w.t, w.start)


def _kinematics_by_integration(w: _Work, noise_factor: float) -> None:
    """Velocity and/or acceleration: integrate (from rest, or about the equilibrium), remove the drift."""
    eq: EquilibriumIntegral | None = None
    one_force = True
    if not w.rest:
        # recorded already in motion: integration constants unknown; first integrate about the
        # equilibrium (valid for any number of modes), then check whether the record behaves as
        # one restoring force (x ~ 0 where a = 0)
        eq = integrate_about_equilibrium(w.t, vel=w.vel) if w.vel is not None else \
            integrate_about_equilibrium(w.t, acc=w.acc)
        w.a = w.acc if w.acc is not None else _sg_derivative_modes(w.vel, w.rate, w.period_s)  # type: ignore[arg-type]
        v_eq = w.vel if w.vel is not None else eq.v
        resid = anchor_residual(eq.x, v_eq, w.a)
        one_force = resid < ONE_FORCE_RESIDUAL
        w.notes.append(_equilibrium_note(eq) + f"; x at the acc zero crossings off a single "
                       f"restoring force by {resid:.3g} of its RMS")
    if not one_force:
        assert eq is not None
        w.x, w.v = eq.x, (w.vel if w.vel is not None else eq.v)
        w.method = ("vel as measured" if w.vel is not None else "acc") + \
            "; integrated about the equilibrium (zero mean over every cycle of every mode)" + \
            ("; acc as measured" if w.acc is not None else "; acc by Savitzky-Golay derivative of vel")
    elif w.vel is not None:
        _integrate_velocity(w, noise_factor)
    else:
        _integrate_acceleration(w, eq, noise_factor)


def _integrate_velocity(w: _Work, noise_factor: float) -> None:
    """A measured velocity (one restoring force): ``x`` by integration, drift anchored."""
    vel, start, dt = w.vel, w.start, 1.0 / w.rate
    assert vel is not None
    split = w.impact_end if w.impact_end >= 0 else start
    if w.rest:
        w.a = w.acc if w.acc is not None else _sg_derivative(vel, w.rate, w.period_s, 1, split)
    v0 = vel - (float(np.mean(vel[:w.noise_stop])) if w.rest and w.noise_stop >= 8 else 0.0)
    x_int = np.zeros(w.n)
    x_int[start:] = (integrate(v0[start:], dt, smooth_from=_pulse_end(v0, start, w.impact_end) - start)
                     if w.rest else spline_cumulative_integral(w.t, v0))
    assert w.a is not None
    d, _ = _anchored_drift(w, x_int, v0, w.a, noise_factor)
    w.x, w.v = x_int - d, vel
    w.method = ("vel as measured; disp by integration " + ("from rest" if w.rest else "from the start")
                + " with drift anchored at acc zero crossings")


def _integrate_acceleration(w: _Work, eq: EquilibriumIntegral | None, noise_factor: float) -> None:
    """A measured acceleration alone: ``v, x`` by integration, drift anchored."""
    a, start, t = w.acc, w.start, w.t
    assert a is not None
    w.a = a
    if eq is None:
        v_int = np.zeros(w.n)
        x_int = np.zeros(w.n)
        # 4th-order integration (the trapezoid loses (w h)^2 / 12 a pass: eddi.calculus),
        # trapezoid over the impact (a pulse is not smooth)
        smooth = _pulse_end(a, start, w.impact_end) - start
        v_int[start:] = integrate(a[start:], 1.0 / w.rate, smooth_from=smooth)
        x_int[start:] = integrate(v_int[start:], 1.0 / w.rate, smooth_from=smooth)
    else:
        # unknown v0 and x0: a line in x, removed by least squares before the anchored fit (it
        # dwarfs x; the cycle-mean v is biased where a damped response chirps)
        v_int = spline_cumulative_integral(t, a)
        x_int = spline_cumulative_integral(t, v_int)
        line = np.polynomial.polynomial.polyfit(t - t[0], x_int, 1)
        x_int = x_int - line[0] - line[1] * (t - t[0])
        v_int = v_int - line[1]
    d, dd = _anchored_drift(w, x_int, v_int, a, noise_factor)
    w.x, w.v = x_int - d, v_int - dd
    w.method = ("acc integrated from rest" if w.rest else "acc integrated about the equilibrium") + \
        "; drift anchored at acc zero crossings (x = 0) and the noise tail"


def _free_window(w: _Work, noise_factor: float) -> ConditionedSignal:
    """The free-response window: after the impact, until the response sinks into the noise."""
    x, v, a, n, start = w.x, w.v, w.a, w.n, w.start
    assert x is not None and v is not None and a is not None
    impact_end = w.impact_end
    if impact_end < 0:
        # without force: from the first extremum of x after the motion starts (the first
        # crossing of v after v has left its rest: at the onset v is still ~0)
        moving = np.nonzero(np.abs(v[start:]) >= 0.3 * float(np.max(np.abs(v[start:]))))[0]
        first_move = start + (int(moving[0]) if moving.size else 0)
        vx = crossings(v, max(3.0 * noise_rms(v, w.noise_stop), 1e-12), start=first_move)
        impact_end = int(math.ceil(vx[0])) if (w.rest and vx.size) else start
    free_start = min(impact_end, n - 2)
    free_stop = _envelope_stop(w.resp if w.resp_name != "disp" else x, free_start, w.sigma, noise_factor,
                               w.period_s, w.rate)
    free_stop = max(free_stop, min(n, free_start + 2))
    w.notes.append(f"noise RMS of {w.resp_name}: {w.sigma:.3g}; free response [{free_start}, {free_stop})")
    return ConditionedSignal(
        t=w.t, x=np.ascontiguousarray(x), v=np.ascontiguousarray(v), a=np.ascontiguousarray(a),
        force=w.force, rate_hz=w.rate, free_start=int(free_start), free_stop=int(free_stop),
        method=w.method, notes=tuple(w.notes), impact_start=int(start), impact_end=int(impact_end),
        noise_rms=w.sigma, force_noise_rms=w.f_sigma, acc_measured=w.acc is not None,
        response=w.resp_name,
    )


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


def _equilibrium_note(eq: EquilibriumIntegral) -> str:
    modes = ", ".join(f"{f:.4g}" for f in eq.modes_hz)
    lo, hi = float(np.min(eq.f1_hz)), float(np.max(eq.f1_hz))
    track = f"{lo:.4g} Hz" if hi - lo < 1e-9 * hi else f"{lo:.4g}-{hi:.4g} Hz along the record"
    return f"no rest: cycle means over the modes at {modes} Hz (lowest mode {track})"


def _drift_spline_eval(spl: BSpline, t: np.ndarray, start: int) -> tuple[np.ndarray, np.ndarray]:
    d = np.zeros(t.size)
    dd = np.zeros(t.size)
    d[start:] = spl(t[start:])
    dd[start:] = spl.derivative()(t[start:])
    return np.nan_to_num(d), np.nan_to_num(dd)


def _envelope_stop(y: np.ndarray, first: int, sigma: float, factor: float, period_s: float,
                   rate: float) -> int:
    """End of the last block (one period long) whose peak exceeds ``factor * sigma``.

    Without noise (``sigma == 0``) the floor is 1e-4 of the peak after ``first``.
    """
    n = y.size
    seg = np.abs(y[first:])
    if seg.size == 0:
        return n
    floor = max(factor * sigma, 1e-4 * float(np.max(seg)))
    block = max(4, int(round(period_s * rate)))
    nb = seg.size // block
    if nb == 0:
        return n
    peaks = seg[: nb * block].reshape(nb, block).max(axis=1)
    above = np.nonzero(peaks > floor)[0]
    if above.size == 0:
        return min(n, first + block)
    last = int(above[-1])
    return n if last == nb - 1 else first + (last + 1) * block
