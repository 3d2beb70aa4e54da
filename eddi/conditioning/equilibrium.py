"""Records that start in motion: integration about the equilibrium (zero mean over every
cycle of every mode)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eddi.bspline import Spline
from eddi.calculus import bspline_design_matrix, cumulative_trapezoid, spline_cumulative_integral
from eddi.conditioning.checks import check_time
from eddi.conditioning.levels import crossings
from eddi.errors import SignalError



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



def _lsq_spline(tp: np.ndarray, y: np.ndarray, t0: float, t1: float, knot_s: float) -> Spline:
    """Least-squares cubic spline on ``[t0, t1]``, uniform knots ``knot_s`` apart.

    A light second-difference penalty keeps intervals with few samples well posed. The
    normal equations are banded (a cubic B-spline overlaps its three neighbours; the
    penalty its two): solved by a banded Cholesky in O(knots) (a dense solve of the same
    system took 0.2 s per call for 379 knots on a 3 s record under load).
    """
    from scipy.linalg import solveh_banded  # local: the identify path does not fit this spline

    n_int = max(1, int(math.ceil((t1 - t0) / knot_s)))
    knots = np.concatenate(([t0] * 3, np.linspace(t0, t1, n_int + 1), [t1] * 3))
    b = bspline_design_matrix(np.clip(tp, t0, t1), knots, 3).tocsc()
    m = b.shape[1]
    btb = (b.T @ b).todia()
    lam = 1e-3 * float(np.mean(btb.diagonal()))
    # upper banded storage (scipy.linalg.solveh_banded): row 3 - k holds diagonal k
    ab = np.zeros((4, m))
    for k in range(4):
        if k < m:
            ab[3 - k, k:] = btb.diagonal(k)
    ab[3] += lam * _second_difference_gram(m, 0) + 1e-12
    ab[2, 1:] += lam * _second_difference_gram(m, 1)
    ab[1, 2:] += lam * _second_difference_gram(m, 2)
    rhs = np.asarray(b.T @ y).ravel()
    try:
        coef = solveh_banded(ab, rhs, check_finite=False)
    except np.linalg.LinAlgError:  # not positive definite (rounding): the general solver
        dense = np.diag(ab[3]) + sum(np.diag(ab[3 - k, k:], k) + np.diag(ab[3 - k, k:], -k)
                                     for k in range(1, min(4, m)))
        coef = np.linalg.solve(dense, rhs)
    return Spline(knots, coef, 3)


def _second_difference_gram(m: int, k: int) -> np.ndarray:
    """Diagonal ``k`` (0, 1 or 2) of ``D.T @ D`` for the (m-2, m) second-difference ``D``."""
    if m < 3:
        return np.zeros(m - k)
    d = np.zeros(m - k)
    for r, row in enumerate((1.0, -2.0, 1.0)):  # row i of D: 1, -2, 1 at columns i, i+1, i+2
        if r + k <= 2:
            # (D.T D)[j, j+k] = sum_i D[i, j] D[i, j+k] over the m-2 rows
            d[np.arange(m - 2) + r] += row * (1.0, -2.0, 1.0)[r + k]
    return d



def _cycle_means(t: np.ndarray, y: np.ndarray, width_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean of ``y`` over ``[t - w/2, t + w/2]`` at every ``t`` whose window fits the record.

    ``width_s`` may vary with ``t`` (one local period). The integral is the trapezoid
    cumulative integral interpolated at the window ends (fractional samples).
    """
    cum = cumulative_trapezoid(y, t)
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
    # peak |xl| over [c_i, c_(i+2)] (samples, inclusive): the larger of the two half-cycles' peaks
    ci = c.astype(np.int64)
    half = np.maximum(np.maximum.reduceat(np.abs(xl), ci)[:-1], np.abs(xl[ci[1:]]))
    env = np.maximum(half[:-1], half[1:])
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



def _equilibrium_note(eq: EquilibriumIntegral) -> str:
    modes = ", ".join(f"{f:.4g}" for f in eq.modes_hz)
    lo, hi = float(np.min(eq.f1_hz)), float(np.max(eq.f1_hz))
    track = f"{lo:.4g} Hz" if hi - lo < 1e-9 * hi else f"{lo:.4g}-{hi:.4g} Hz along the record"
    return f"no rest: cycle means over the modes at {modes} Hz (lowest mode {track})"

