"""The numerical toolbox: integration, differentiation and resampling of sampled signals.

One module owns these so that conditioning (:mod:`eddi.conditioning`), the modal route
(:mod:`eddi.multimode`) and the station use the same, measured accuracy:

* :func:`cumulative_trapezoid`: the trapezoid rule, cumulative (what ``scipy.integrate``'s
  function of that name computes, the same arithmetic, without importing ``scipy.integrate``
  (~0.3 s of CPU at start-up: it pulls in ``scipy.special``, ``scipy.optimize`` and
  ``scipy.sparse.linalg``));
* :func:`trapezoid`: the trapezoid rule's definite integral (``numpy.trapezoid``, a name
  numpy 1.x, which the project supports, does not have);
* :func:`integrate`: cumulative integral, 4th-order accurate in the interior
  (``dt/24 (-y[n-1] + 13 y[n] + 13 y[n+1] - y[n+2])``; the weights sum to one, so the integral
  of a pulse is kept exactly). The trapezoid rule shrinks a sinusoid's integral by
  ``(w h)^2 / 12`` per pass: 0.2 % at 41 samples a period, i.e. 0.4 % on ``x`` from ``a``
  (two passes), which becomes +0.4 % on k1 and +2 % on a weakly excited k3. This stencil
  leaves ``(w h)^4 * 11/720`` (1e-5 at 41 samples a period);
* :func:`spline_cumulative_integral`: the same through an interpolating cubic spline
  (``O((w h)^4)``, any grid);
* :func:`differentiate`: 6th-order central difference (lower order at the ends);
  :func:`spline_derivative`: the derivative of the quintic interpolating spline (any grid;
  what the Lagrangian route of phase two uses when no acceleration was measured);
* :func:`resample`: band-limited (FFT / polyphase-free) resampling of records whose clocks
  differ slightly onto one grid (:func:`common_rate`);
* :func:`delay`: a signal moved later by a fraction of a sample through the same spline (the
  hammer force aligned with a response that lags it: :mod:`eddi.diagnosis.align`);
* :func:`fill_gaps`: a few missing samples (a laser vibrometer's dropouts) from a cubic fitted
  to the good samples either side;
* :func:`samples_per_cycle_note`: what accuracy to expect from a given sampling;
* :func:`decimation_factor`, :func:`decimate_centred`: a record sampled far faster than it
  moves (19.2 kHz for a 4 Hz oscillator) onto a coarser grid for the regression;
* :func:`bspline_design_matrix`: scipy's B-spline design matrix as a ``scipy.sparse`` array (the
  equilibrium's spline), the same entries, without its per-sample Python check (the drift
  splines of the conditioning and of the slow errors use :func:`eddi.bspline.design_rows`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from eddi.kernels import Kernels

#: Largest relative difference of sample rates :func:`common_rate` accepts (200 ppm).
RATE_TOLERANCE = 200e-6
#: Below this many samples per cycle the pipeline warns (accuracy of EDDI worsens quickly).
MIN_SAMPLES_PER_CYCLE = 20.0


def cumulative_trapezoid(y: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Cumulative trapezoid integral of ``y`` over the times ``t``, 0 at the first sample.

    The arithmetic of ``scipy.integrate.cumulative_trapezoid(y, t, initial=0.0)`` (bit for
    bit, ``tests/eddi/test_calculus.py``) for 1-D arrays.

    Parameters
    ----------
    y : ndarray, shape (n,)
    t : ndarray, shape (n,), [s]
        Increasing times (need not be uniform).

    Returns
    -------
    ndarray, shape (n,)
        ``int_{t0}^{t} y dt`` (units of ``y`` times s).
    """
    y = np.asarray(y, dtype=float)
    t = np.asarray(t, dtype=float)
    if y.shape != t.shape or y.ndim != 1 or y.size == 0:
        raise ValueError(f"y and t must be 1-D of one non-zero length, got {y.shape} and {t.shape}")
    return np.concatenate(([0.0], np.cumsum(np.diff(t) * (y[1:] + y[:-1]) / 2.0)))


def trapezoid(y: np.ndarray, x: np.ndarray | None = None, dx: float = 1.0) -> float:
    """Trapezoid integral of ``y`` (over the points ``x``, or uniform spacing ``dx``).

    ``numpy.trapezoid``'s arithmetic on every numpy the project supports (the name is
    numpy >= 2.0 only; numpy 1.x has ``numpy.trapz``).
    """
    y = np.asarray(y, dtype=float)
    if y.size < 2:
        return 0.0
    if x is None:
        return float(dx * np.sum((y[1:] + y[:-1]) / 2.0))
    x = np.asarray(x, dtype=float)
    return float(np.sum(np.diff(x) * (y[1:] + y[:-1]) / 2.0))


def integrate(y: np.ndarray, dt: float, smooth_from: int = 0, out: np.ndarray | None = None) -> np.ndarray:
    """Cumulative integral of a sampled signal from ``y[0]``, 4th-order accurate inside.

    Parameters
    ----------
    y : ndarray, shape (n,)
    dt : float
        Sample interval [s].
    smooth_from : int
        Intervals before this sample use the trapezoid: the 4th-order stencil assumes a
        smooth signal and rings on a kink (a hammer pulse), where the trapezoid is exact for
        the piecewise-linear force a sampled pulse stands for.
    out : ndarray of float, shape (n,), optional
        Where to write the integral (not overlapping ``y``; e.g. the slice of a record's
        array: no temporary of the record's length and no copy into it). Default: a new array.

    Returns
    -------
    ndarray, shape (n,)
        ``int_{t0}^{t} y dt`` (units of ``y`` times s), ``0`` at the first sample; trapezoid
        on the first and last intervals (``out`` when given).
    """
    y = np.asarray(y, dtype=float)
    n = y.size
    if out is None:
        out = np.empty(n)
    elif out.shape != (n,) or out.dtype != np.float64 or np.shares_memory(out, y):
        raise ValueError("integrate: out must be a float array of y's shape, not overlapping y")
    if n < 2:
        out[:] = 0.0
        return out
    out[0] = 0.0
    if n >= 4 and y.flags.c_contiguous and out.flags.c_contiguous:
        # one compiled pass: the same increments and running sum (np.cumsum adds in order), bit
        # for bit (the numpy passes below cost ~4x as much on the 45 s record: 8 passes over it)
        _KERNELS._integrate_sum(y, float(dt), min(max(1, int(smooth_from)), n - 2), out)
        return out
    inc = out[1:]  # the increments, summed in place (no temporaries of the record's length)
    k = max(1, int(smooth_from)) if n >= 4 else n - 1
    k = min(k, n - 2) if n >= 4 else k
    np.add(y[:k], y[1:k + 1], out=inc[:k])
    inc[:k] *= 0.5 * dt
    inc[-1] = 0.5 * dt * (y[-2] + y[-1])
    if n >= 4 and k < n - 2:
        hi = inc[k:-1]  # dt/24 (13 (y[j] + y[j+1]) - y[j-1] - y[j+2]) for j = k .. n-3
        np.add(y[k:-2], y[k + 1:-1], out=hi)
        hi *= 13.0
        hi -= y[k - 1:-3]
        hi -= y[k + 2:]
        hi *= dt / 24.0
    np.cumsum(inc, out=inc)
    return out


def spline_cumulative_integral(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Cumulative integral of ``y`` from ``t[0]`` through its interpolating cubic spline.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    y : ndarray, shape (n,)

    Returns
    -------
    ndarray, shape (n,)
        ``int_{t0}^{t} y dt`` (units of ``y`` times s).
    """
    from eddi.bspline import interpolate

    s = interpolate(t, y, 3).antiderivative()
    out = s(t)
    return out - out[0]


def differentiate(y: np.ndarray, dt: float) -> np.ndarray:
    """Derivative of a sampled signal, 6th-order central difference (2nd order at the ends).

    Parameters
    ----------
    y : ndarray, shape (n,)
    dt : float
        Sample interval [s].

    Returns
    -------
    ndarray, shape (n,)
    """
    y = np.asarray(y, dtype=float)
    d = np.gradient(y, dt, edge_order=2)
    if y.size >= 7:
        d[3:-3] = (-y[:-6] + 9.0 * y[1:-5] - 45.0 * y[2:-4] + 45.0 * y[4:-2] - 9.0 * y[5:-1] + y[6:]) / (60.0 * dt)
    return d


def spline_derivative(t: np.ndarray, y: np.ndarray, degree: int = 5) -> np.ndarray:
    """Time derivative of a sampled signal, from its interpolating spline (quintic by default).

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Increasing times (need not be uniform).
    y : ndarray, shape (n,)
    degree : int
        Spline degree (odd; 5 is sixth-order accurate inside, see :mod:`eddi.energy`).

    Returns
    -------
    ndarray, shape (n,)
        ``dy/dt`` at ``t`` (units of ``y`` per s).
    """
    from eddi.bspline import interpolate

    return interpolate(t, y, degree).derivative()(t)


def common_rate(rates_hz: list[float] | tuple[float, ...], tolerance: float = RATE_TOLERANCE) -> float | None:
    """The rate to resample records onto, or None when they already agree (1 ppm).

    Parameters
    ----------
    rates_hz : sequence of float
        Sample rates [Hz] of the records.
    tolerance : float
        Largest relative difference accepted.

    Returns
    -------
    float or None
        The first record's rate when some differ by more than 1 ppm, else None.

    Raises
    ------
    ValueError
        When two rates differ by more than ``tolerance`` (a different setting, not a clock
        tolerance: resampling would hide it).
    """
    r0 = float(rates_hz[0])
    worst = max(abs(float(r) - r0) / r0 for r in rates_hz)
    if worst > tolerance:
        raise ValueError(f"sample rates differ by {worst * 1e6:.0f} ppm (more than {tolerance * 1e6:.0f} ppm): "
                         f"{', '.join(f'{r:.6g}' for r in rates_hz)} Hz; resample them to one rate first")
    return r0 if worst > 1e-6 else None


def resample(t: np.ndarray, y: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Resample a uniformly sampled record onto ``rate_hz`` from ``t[0]``.

    Through the record's 5th-order interpolating spline: for clocks that differ by up to
    200 ppm the new samples sit within a fraction of a step of the old ones, and the
    interpolation error is ~``(w h)^6 / 1000`` relative (below 1e-5 at 20 samples per cycle;
    ``tests/eddi/test_calculus.py``).

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Uniform times.
    y : ndarray, shape (n,)
    rate_hz : float
        New sample rate [Hz].

    Returns
    -------
    t_new : ndarray, shape (m,), [s]
        ``t[0] + k / rate_hz`` within ``[t[0], t[-1]]``.
    y_new : ndarray, shape (m,)
    """
    from eddi.bspline import interpolate

    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    m = int(math.floor((t[-1] - t[0]) * rate_hz + 1e-9)) + 1
    t_new = t[0] + np.arange(m) / rate_hz
    t_new = t_new[t_new <= t[-1] + 1e-12]
    return t_new, interpolate(t, y, 5)(t_new)


def delay(y: np.ndarray, samples: float) -> np.ndarray:
    """``y`` moved later by ``samples`` (any real number; negative: earlier) on its own grid.

    Through the record's 5th-order interpolating spline, as :func:`resample`: ``out[n] =
    y(n - samples)``; before the first and after the last sample the signal is continued by
    its end values (the force of a hammer blow at rest: its offset). An integer delay moves
    the samples exactly.

    Parameters
    ----------
    y : ndarray, shape (n,)
    samples : float
        The delay in samples.

    Returns
    -------
    ndarray, shape (n,)
    """
    y = np.asarray(y, dtype=float)
    n = y.size
    idx = np.arange(n) - float(samples)
    inside = (idx >= 0) & (idx <= n - 1)
    out = np.where(idx < 0, y[0], y[-1]) if n else y.copy()
    k = round(float(samples))
    if abs(float(samples) - k) < 1e-9 or n < 6:
        j = np.clip(np.round(idx).astype(int), 0, max(n - 1, 0))
        return np.where(inside, y[j], out)
    from eddi.bspline import interpolate

    out[inside] = interpolate(np.arange(n, dtype=float), y, 5)(idx[inside])
    return out


def fill_gaps(y: np.ndarray, bad: np.ndarray, side: int = 2,
              runs: Sequence[tuple[int, int]] | None = None) -> np.ndarray:
    """``y`` with the samples where ``bad`` is True replaced by the cubic through ``side`` good
    samples on each side of each run of bad samples (least squares when ``side > 2``; a copy).

    For short gaps in an oversampled signal: at 28 samples a cycle a 3-sample gap is filled
    within 0.3 % of the amplitude (1-2 samples: 0.03 %; ``side=4`` gives 1.5 %: the wider cubic
    spans 0.4 cycle). A run with fewer good samples on a side is filled from what it has (a
    line or a constant when only 1-3 samples are there).

    ``runs``: only these runs ``[a, b)`` of ``bad`` are filled (default: every run); each is
    filled as it is when all are (its cubic sees the good samples only).
    """
    y = np.array(y, dtype=float)
    bad = np.asarray(bad, dtype=bool)
    if runs is None:
        edges = np.diff(np.concatenate(([0], bad.astype(np.int8), [0])))
        runs = list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))
    good = np.flatnonzero(~bad)
    for a, b in runs:
        # the nearest ``side`` good samples before the run (nearest first) and after it: a search
        # in the good samples' indices, not a scan of the record per run (a quantized record
        # has hundreds of zero runs: 0.3-0.5 s of CPU a channel, session 16)
        at = int(np.searchsorted(good, a))
        idx = np.concatenate((good[max(at - side, 0):at][::-1], good[at:at + side]))
        if idx.size == 0:
            continue
        deg = min(3, idx.size - 1)
        centre = 0.5 * (a + b - 1)
        c = np.polynomial.polynomial.polyfit(idx - centre, y[idx], deg)
        y[a:b] = np.polynomial.polynomial.polyval(np.arange(a, b) - centre, c)
    return y


def samples_per_cycle_note(rate_hz: float, freq_hz: float) -> str | None:
    """A warning when ``rate_hz / freq_hz`` is below :data:`MIN_SAMPLES_PER_CYCLE` (else None).

    The expected accuracy is the size of the neglected terms of the 4th-order integration
    and of EDDI's spline interpolation at that sampling, measured on clean Duffing records
    (``docs/eddi-method.md``): stiffness ~ ``(w h)^2 / 12`` from the crossings' interpolation.
    """
    if not (freq_hz > 0 and rate_hz > 0):
        return None
    spc = rate_hz / freq_hz
    if spc >= MIN_SAMPLES_PER_CYCLE:
        return None
    wh = 2.0 * math.pi / spc
    err = 100.0 * wh * wh / 12.0
    return (f"only {spc:.3g} samples per cycle at {freq_hz:.4g} Hz (fewer than {MIN_SAMPLES_PER_CYCLE:g}): expect "
            f"stiffness and damping errors of ~{err:.2g} % or more from sampling alone; record faster if you can")


#: Largest ``omega * q * dt`` of the grid :func:`decimate_centred` makes (rad): ~63 samples per
#: cycle of the fastest local oscillation, where EDDI's quintic quadrature and Hermite
#: crossings are exact to ~1e-7.
DECIMATE_H_OMEGA = 0.1
#: Smallest factor worth decimating by.
MIN_DECIMATION = 5


def signal_angular_frequency(x: np.ndarray, v: np.ndarray, a: np.ndarray) -> float:
    """A bound on the fastest local angular frequency of a response [rad/s], from the data.

    ``1.5 max|a| / max|v|`` (a sinusoid gives 1.5 omega; the sharp acceleration peaks of a
    hardening spring raise ``max|a|`` as its tangent frequency rises: on the 45 s duffing-smooth
    record 117 rad/s against a tangent maximum of 110); 0 when ``v`` is all zero.
    """
    from eddi.peaks import peak_abs  # np.max(np.abs(.)) bit for bit, one pass without the temporary

    vmax = peak_abs(v) if v.size else 0.0
    return 1.5 * peak_abs(a) / vmax if vmax > 0 else 0.0


def decimation_factor(rate_hz: float, omega: float, h_omega: float | None = None) -> int:
    """Odd factor ``q`` with ``omega q / rate_hz <= h_omega`` (default :data:`DECIMATE_H_OMEGA`, read
    at the call); 1 below :data:`MIN_DECIMATION`."""
    h_omega = DECIMATE_H_OMEGA if h_omega is None else h_omega
    if not (omega > 0 and math.isfinite(omega) and rate_hz > 0):
        return 1
    q = int(h_omega * rate_hz / omega)
    q -= q % 2 == 0
    return q if q >= MIN_DECIMATION else 1


def decimate_centred(t: np.ndarray, x: np.ndarray, v: np.ndarray, a: np.ndarray | None,
                     q: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
    """Every ``q``-th sample of a smooth ``x, v``; the acceleration from its block means.

    ``x`` and ``v`` (integrals: their noise lies at low frequency) are taken at the centre
    sample of each block of ``q`` samples; the measured acceleration (white sensor noise) is
    the block mean, less its curvature, ``m_k - (q^2 - 1) / (24 q^2) (m_{k+1} - 2 m_k +
    m_{k-1})``: the centre value to ``O((omega q dt)^4)`` with ``1/q`` of the noise variance.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    x, v : ndarray, shape (n,)
    a : ndarray, shape (n,) or None
    q : int
        Odd factor (>= 1).

    Returns
    -------
    t, x, v, a : ndarray, shape (n // q,)
        On the blocks' centre samples (``a`` None when not given).
    index : ndarray of int, shape (n // q,)
        The centre samples' indices in the input arrays.
    """
    if q <= 1:
        return t, x, v, a, np.arange(t.size)
    nb = t.size // q
    idx = (q - 1) // 2 + q * np.arange(nb)
    ad = None
    if a is not None:
        from eddi.refine_grid import block_means  # local: it imports the model (pydantic)

        m = block_means(np.asarray(a[: nb * q], dtype=float), q)  # numpy's row means, compiled (bit for bit)
        d2 = np.empty_like(m)
        d2[1:-1] = m[2:] - 2.0 * m[1:-1] + m[:-2]
        d2[0], d2[-1] = d2[1], d2[-2]
        ad = m - (q * q - 1) / (24.0 * q * q) * d2
    return t[idx], x[idx], v[idx], ad, idx


def bspline_design_matrix(x: np.ndarray, knots: np.ndarray, k: int = 3):
    """``scipy.interpolate.BSpline.design_matrix(x, knots, k)``: the same CSR array, bit for bit.

    :func:`eddi.bspline.design_rows` (numpy and a compiled pass; ``scipy.interpolate`` imports
    ``scipy.optimize``, ~0.13 s a process) as a ``scipy.sparse.csr_array``. The engine's own least
    squares use :func:`eddi.bspline.design_rows` directly (no ``scipy.sparse``).

    Raises
    ------
    ValueError
        On a point outside the base interval or not finite, as scipy does.
    """
    from scipy import sparse  # local: keeps `import eddi` light

    from eddi.bspline import design_rows

    rows = design_rows(x, knots, k)
    return sparse.csr_array(rows.csr_parts(), shape=rows.shape)


def _integrate_sum(y, dt, k, out):  # pragma: no cover - compiled
    """:func:`integrate`'s increments and their running sum in one pass (``n >= 4``, ``1 <= k <= n - 2``):
    the trapezoid before interval ``k``, the 4th-order stencil to interval ``n - 3``, the
    trapezoid on the last; each increment as the numpy passes form it, summed in order."""
    n = y.shape[0]
    h = 0.5 * dt
    c = dt / 24.0
    s = 0.0
    out[0] = 0.0
    for j in range(k):
        s += (y[j] + y[j + 1]) * h
        out[j + 1] = s
    for j in range(k, n - 2):
        s += ((((y[j] + y[j + 1]) * 13.0) - y[j - 1]) - y[j + 2]) * c
        out[j + 1] = s
    s += h * (y[n - 2] + y[n - 1])
    out[n - 1] = s


def abs_third_difference(y: np.ndarray) -> np.ndarray:
    """``numpy.abs(numpy.diff(y, 3))`` bit for bit, in one pass over ``y``.

    Parameters
    ----------
    y : ndarray, shape (n,)

    Returns
    -------
    ndarray, shape (max(n - 3, 0),)
    """
    y = np.asarray(y, dtype=float)
    if y.ndim != 1 or y.size < 4 or not y.flags.c_contiguous:
        return np.abs(np.diff(y, 3))
    out = np.empty(y.size - 3)
    _KERNELS._abs_diff3(y, out)
    return out


def _abs_diff3(y, out):  # pragma: no cover - compiled
    """:func:`abs_third_difference`: ``numpy.diff``'s three passes per element, in their order."""
    for i in range(out.shape[0]):
        d0 = y[i + 1] - y[i]
        d1 = y[i + 2] - y[i + 1]
        d2 = y[i + 3] - y[i + 2]
        out[i] = abs((d2 - d1) - (d1 - d0))


#: The compiled kernels (:mod:`eddi.kernels`: built ahead of time, else numba's JIT).
_KERNELS = Kernels(globals(), {"_integrate_sum": ["void(f8[::1], f8, i8, f8[::1])"],
                               "_abs_diff3": ["void(f8[::1], f8[::1])"]})
