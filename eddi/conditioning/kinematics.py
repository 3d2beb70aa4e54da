"""Integration and differentiation helpers of the conditioner: the paper's high-pass
integration, Savitzky-Golay derivatives, the drift spline anchored where ``x = 0``."""

from __future__ import annotations

import math

import numpy as np
from eddi.bspline import Spline, design_rows, piecewise
from eddi.calculus import cumulative_trapezoid
from eddi.conditioning.checks import check_time
from eddi.conditioning.equilibrium import _spectral_peaks
from eddi.conditioning.levels import _at, crossings, noise_rms
from eddi.kernels import Kernels
from eddi.peaks import peak_abs



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
    v = sps.sosfiltfilt(sos, cumulative_trapezoid(acc, t))
    x = sps.sosfiltfilt(sos, cumulative_trapezoid(v, t))
    return x, v



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



def _drift_spline(
    t: np.ndarray, y: np.ndarray, t_pts: np.ndarray, knot_s: float, start: int, clamped: bool,
    local: np.ndarray, free_slope: bool = False,
) -> Spline:
    """Least-squares cubic spline ``d`` with ``y = d(t_pts) + local @ c`` (``y``: the integrated ``x`` at the anchors).

    ``t`` is the record's time (the spline spans ``t[start:]``); ``t_pts, y, local`` are the
    anchors (samples, or block means of samples: :func:`eddi.conditioning.conditioner._anchor_means`).

    ``local`` holds, per sample, signals to which the true ``x`` is locally proportional
    near its zeros (``-a`` and ``-v``: near ``x = 0``, ``k1 x = -m a - b1 v``); their
    coefficients ``c`` are fitted with the spline. With ``clamped``, ``d`` and (unless
    ``free_slope``) its slope are 0 at ``t[start]`` (rest).
    """
    t0, t1 = float(t[start]), float(t[-1])
    n_int = max(1, int(math.ceil((t1 - t0) / knot_s)))
    inner = np.linspace(t0, t1, n_int + 1)
    knots = np.concatenate(([t0] * 3, inner, [t1] * 3))
    basis = design_rows(t_pts, knots, 3)
    first = (1 if free_slope else 2) if clamped else 0
    # the B-spline block stays banded (4 values a row): the normal equations are built
    # block by block, never as a dense (rows x knots) product (a dense one took 2 s of
    # multi-threaded BLAS on a 45 s record; this takes a few ms). The first ``first`` columns
    # (held at 0) are left out of the products' results: each entry of a Gram matrix or a
    # transposed product involves its own columns only (scipy.sparse's numbers, bit for bit)
    m = basis.shape[1] - first
    # a light second-difference penalty keeps intervals without samples well posed
    d2 = np.diff(np.eye(m), 2, axis=0)
    btb = basis.gram()[first:, first:]
    lam = 1e-3 * float(np.mean(np.diag(btb)))
    scale = np.max(np.abs(local), axis=0)
    scale[scale == 0] = 1.0
    loc = local / scale
    k = m + loc.shape[1]
    normal = np.empty((k, k))
    normal[:m, :m] = btb + lam * d2.T @ d2
    normal[:m, m:] = basis.tmul(loc)[first:]
    normal[m:, :m] = normal[:m, m:].T
    normal[m:, m:] = loc.T @ loc
    rhs = np.concatenate((basis.tmul(y)[first:], loc.T @ y))
    sol = np.linalg.solve(normal + 1e-12 * np.eye(k), rhs)
    coef = np.zeros(basis.shape[1])
    coef[first:] = sol[:m]
    return Spline(knots, coef, 3, extrapolate=False)



def _drift_spline_eval(spl: Spline, t: np.ndarray, start: int,
                       minus: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``d`` and ``d'`` of the drift spline on ``t[start:]`` (0 before ``start``).

    ``minus = (x, v)``: ``x - d`` and ``v - d'`` instead, in place in ``x, v`` (returned; the
    same values bit for bit as subtracting the returned ``d, d'``, without two arrays of the
    record's length and two passes over it).

    Evaluated as its piecewise polynomial (:func:`eddi.bspline.piecewise`, scipy's ``PPoly.from_spline``: the
    cubic of each knot interval, by Horner on the interval's samples): equal to the B-spline's
    own evaluation within rounding (~1e-15 of the drift), at a fraction of the cost on a long
    record (the samples are sorted, so each interval's samples are one slice).
    """
    d, dd = (np.zeros(t.size), np.zeros(t.size)) if minus is None else minus
    sub = minus is not None
    ts = t[start:]
    brk, c = piecewise(spl)
    keep = np.nonzero(brk[1:] > brk[:-1])[0]  # the knot intervals of non-zero length
    lo, hi = brk[keep], brk[keep + 1]
    # samples in [lo, hi) per interval; the last interval is closed (t[-1] is its end)
    first = np.searchsorted(ts, lo, side="left")
    last = np.searchsorted(ts, hi, side="left")
    last[-1] = np.searchsorted(ts, hi[-1], side="right")
    dv, ddv = d[start:], dd[start:]
    if ts.flags.c_contiguous and dv.flags.c_contiguous and ddv.flags.c_contiguous and c.shape[0] == 4:
        # one compiled pass (the same Horner steps per sample, in the same order: bit for bit)
        _KERNELS._horner_fill(ts, first.astype(np.int64), last.astype(np.int64), np.ascontiguousarray(lo),
                              np.ascontiguousarray(c[:, keep].T), int(sub), dv, ddv)
        return d, dd
    for i0, i1, x0, (c3, c2, c1, c0) in zip(first.tolist(), last.tolist(), lo.tolist(), c[:, keep].T.tolist()):
        if i1 <= i0:
            continue
        u = ts[i0:i1] - x0
        y = c3 * u
        y += c2
        y *= u
        y += c1
        y *= u
        y += c0
        if sub:
            dv[i0:i1] -= y
        else:
            dv[i0:i1] = y
        y = (3.0 * c3) * u
        y += 2.0 * c2
        y *= u
        y += c1
        if sub:
            ddv[i0:i1] -= y
        else:
            ddv[i0:i1] = y
    return d, dd



def _horner_fill(ts, first, last, lo, coef, sub, d, dd):  # pragma: no cover - compiled
    """:func:`_drift_spline_eval`'s loop: on ``ts[first[k]:last[k]]`` the cubic ``coef[k]``
    (``c3, c2, c1, c0``) about ``lo[k]`` and its slope, by the numpy passes' Horner steps,
    written to (``sub`` = 1: subtracted from) ``d, dd``."""
    for k in range(first.shape[0]):
        c3 = coef[k, 0]
        c2 = coef[k, 1]
        c1 = coef[k, 2]
        c0 = coef[k, 3]
        x0 = lo[k]
        a3 = 3.0 * c3
        a2 = 2.0 * c2
        for j in range(first[k], last[k]):
            u = ts[j] - x0
            y = ((c3 * u + c2) * u + c1) * u + c0
            g = (a3 * u + a2) * u + c1
            if sub:
                d[j] -= y
                dd[j] -= g
            else:
                d[j] = y
                dd[j] = g


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
    hyst = max(3.0 * noise_rms(a, 0), 1e-3 * peak_abs(a))
    anc = crossings(a, hyst)
    if anc.size < 8:
        return math.inf
    tau = anc / x.size
    design = np.column_stack((np.ones(anc.size), tau, _at(a, anc), _at(v, anc)))
    design /= np.maximum(np.max(np.abs(design), axis=0), 1e-300)
    xa = _at(x, anc)
    coef, *_ = np.linalg.lstsq(design, xa, rcond=None)
    return float(np.sqrt(np.mean((xa - design @ coef) ** 2)) / max(np.sqrt(np.mean(x ** 2)), 1e-300))


#: The compiled kernel (:mod:`eddi.kernels`: built ahead of time, else numba's JIT).
_KERNELS = Kernels(globals(), {"_horner_fill": ["void(f8[::1], i8[::1], i8[::1], f8[::1], f8[:, ::1], i8, "
                                                "f8[::1], f8[::1])"]})
