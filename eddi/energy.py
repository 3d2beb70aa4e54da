"""Energies, zero crossings and accurate quadrature for the EDDI method.

Everything here works on one uniformly or non-uniformly sampled free response
``(t, x, v)`` of a generalized coordinate ``x`` (metres, radians...) and its rate ``v``.

Accuracy notes
--------------
* Zero crossings ``gamma_i`` are located to sub-sample accuracy on the cubic Hermite
  interpolant built from ``x`` and its derivative ``v`` (fourth-order accurate), by
  bisection, so a root is always bracketed.
* Values at crossings (``v(gamma_i)``) come from a quintic interpolating spline of ``v``,
  or from the cubic Hermite interpolant of ``v`` and ``a`` when the acceleration is known.
* Time integrals (dissipated energy) use the antiderivative of a quintic interpolating
  spline of the integrand (sixth-order accurate), so partial intervals between a crossing
  and a sample boundary are integrated exactly on the same interpolant as whole intervals.
"""

from __future__ import annotations

import numpy as np
from eddi.bspline import Spline, hermite, interpolate

from eddi.calculus import abs_third_difference
from eddi.median import median

#: Degree of the interpolating splines used for quadrature and for values at crossings.
#: Quintic: on the paper Duffing (60 samples per period at the start) the energy balance of
#: the first half cycle closes to 6e-9 J instead of 3e-6 J with cubic splines.
SPLINE_DEGREE = 5

from eddi.terms import Term


def kinetic_energy(mass: float, v: np.ndarray) -> np.ndarray:
    """Kinetic energy ``T = m v^2 / 2``.

    Parameters
    ----------
    mass : float
        Mass [kg] (or inertia [kg m^2] for an angle).
    v : ndarray, shape (n,)
        Rate [m/s] (or [rad/s]).

    Returns
    -------
    ndarray, shape (n,), [J]
    """
    v = np.asarray(v, dtype=float)
    return 0.5 * float(mass) * v * v


def noise_level(y: np.ndarray) -> float:
    """Standard deviation of white noise on a smooth, densely sampled signal.

    Robust estimate from third differences (which cancel a smooth signal up to
    ``O(h^3)``): ``median(|diff(y, 3)|) / 0.6745 / sqrt(20)``.

    Parameters
    ----------
    y : ndarray, shape (n,)

    Returns
    -------
    float
        Same unit as ``y`` (0 for fewer than 4 samples).
    """
    y = np.asarray(y, dtype=float)
    if y.size < 4:
        return 0.0
    # numpy.median's value bit for bit, by selection in a bracket (eddi.median: ~4x faster on
    # the 460k samples of a 24 s free response at 19.2 kHz; three per identification)
    return float(median(abs_third_difference(y)) / 0.6745 / np.sqrt(20.0))


def zero_crossings(t: np.ndarray, x: np.ndarray, v: np.ndarray, hysteresis: float = 0.0,
                   iterations: int = 60) -> np.ndarray:
    """Times where ``x`` crosses zero, to sub-sample accuracy.

    A candidate is an interval ``[t_k, t_k+1]`` with ``x_k <= 0 < x_k+1`` or
    ``x_k >= 0 > x_k+1`` (both directions). With ``hysteresis = h > 0`` a crossing counts
    only when ``x`` travels from beyond ``-h`` to beyond ``+h`` (or back), and the last
    candidate of that passage is kept, so noise chattering around zero adds no crossing.
    The time is the root of the cubic Hermite interpolant of ``(x_k, v_k, x_k+1, v_k+1)``,
    found by bisection.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Increasing sample times.
    x : ndarray, shape (n,)
        Coordinate.
    v : ndarray, shape (n,)
        Its rate (derivative of ``x``).
    hysteresis : float
        Half-width of the dead band, same unit as ``x`` (0: every sign change).
    iterations : int
        Bisection steps (60 reaches double precision on any interval).

    Returns
    -------
    ndarray, shape (n_crossings,), [s]
        Increasing crossing times.
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    v = np.asarray(v, dtype=float)
    x0, x1 = x[:-1], x[1:]
    up = (x0 <= 0) & (x1 > 0)
    down = (x0 >= 0) & (x1 < 0)
    k = np.flatnonzero(up | down)
    if k.size and hysteresis > 0:
        state = np.where(x > hysteresis, 1, np.where(x < -hysteresis, -1, 0))
        idx = np.flatnonzero(state)
        if idx.size < 2:
            return np.zeros(0)
        st = state[idx]
        change = np.flatnonzero(st[1:] != st[:-1])  # run ends at idx[change], next starts idx[change+1]
        q = idx[change + 1]
        rising = st[change + 1] > 0
        k_up, k_down = np.flatnonzero(up), np.flatnonzero(down)
        # the record may start inside the band: its first exit counts too
        q = np.concatenate(([idx[0]], q))
        rising = np.concatenate(([st[0] > 0], rising))
        pos_up = np.searchsorted(k_up, q[rising], side="left") - 1
        pos_down = np.searchsorted(k_down, q[~rising], side="left") - 1
        chosen = np.concatenate((k_up[pos_up[pos_up >= 0]], k_down[pos_down[pos_down >= 0]]))
        k = np.unique(chosen)
    if k.size == 0:
        return np.zeros(0)
    h = t[k + 1] - t[k]
    ya, yb = x[k], x[k + 1]
    da, db = v[k] * h, v[k + 1] * h

    def hermite(s: np.ndarray) -> np.ndarray:
        s2 = s * s
        s3 = s2 * s
        return ((2 * s3 - 3 * s2 + 1) * ya + (s3 - 2 * s2 + s) * da
                + (-2 * s3 + 3 * s2) * yb + (s3 - s2) * db)

    lo = np.zeros(k.size)
    hi = np.ones(k.size)
    sign_lo = np.sign(ya)
    # an exact zero at the left end is the crossing itself
    exact = ya == 0
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        fm = hermite(mid)
        same = np.sign(fm) == sign_lo
        lo = np.where(same, mid, lo)
        hi = np.where(same, hi, mid)
    s = np.where(exact, 0.0, 0.5 * (lo + hi))
    gamma = t[k] + s * h
    # drop duplicates produced by a sample sitting exactly on zero
    if gamma.size > 1:
        keep = np.concatenate(([True], np.diff(gamma) > 1e-12 * max(1.0, abs(float(t[-1])))))
        gamma = gamma[keep]
    return gamma


def rate_interpolant(t: np.ndarray, v: np.ndarray, a: np.ndarray | None = None):
    """An interpolant of the rate: cubic Hermite with ``a`` when given, else a quintic spline.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    v : ndarray, shape (n,)
    a : ndarray, shape (n,), optional
        Second derivative of the coordinate.

    Returns
    -------
    callable
        ``f(tq) -> v(tq)``.
    """
    if a is not None:
        return hermite(t, v, a)
    return interpolate(t, v, SPLINE_DEGREE)


def term_matrix(terms: tuple[Term, ...], x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Evaluate several terms at once, sharing integer powers between them.

    Same values as :func:`eddi.terms.evaluate` (to the last bit or two: powers are built by
    repeated multiplication, not ``pow``), about 5x faster for polynomial libraries on long
    records (``x^5`` by ``pow`` costs ~20 ns a sample).

    Parameters
    ----------
    terms : tuple of Term
    x, v : ndarray, shape (n,)

    Returns
    -------
    ndarray, shape (n, len(terms))
    """
    x = np.asarray(x, dtype=float)
    v = np.asarray(v, dtype=float)
    out = np.empty((x.size, len(terms)))
    cache: dict[tuple[str, int], np.ndarray] = {}
    base = {"x": x, "v": v}

    def power(name: str, p: int) -> np.ndarray:
        key = (name, p)
        if key not in cache:
            if name not in base:
                base[name] = (np.abs(x) if name == "ax" else np.abs(v) if name == "av"
                              else np.sign(x) if name == "sx" else np.sign(v))
            cache[key] = base[name] if p == 1 else power(name, p - 1) * base[name]
        return cache[key]

    for j, tm in enumerate(terms):
        col: np.ndarray | None = None
        for name, p in zip(("x", "v", "ax", "av", "sx", "sv"), tm.exponents):
            if name in ("sx", "sv"):
                p %= 2
            if p:
                f = power(name, p)
                col = f if col is None else col * f
        out[:, j] = 1.0 if col is None else col
    return out


def integrated_term(term: Term, x: np.ndarray) -> np.ndarray:
    """``integral_0^x K(s) ds`` of a stiffness term that depends on ``x`` only.

    Any term ``x^p |x|^q sign(x)^r`` equals ``|x|^n sign(x)^e`` with ``n = p + q`` and
    ``e = p + r``; its integral from 0 is ``|x|^(n+1) sign(x)^(e+1) / (n+1)``.

    Parameters
    ----------
    term : Term
        A term free of ``v``.
    x : ndarray, shape (n,)

    Returns
    -------
    ndarray, shape (n,)
        Potential-energy shape function (e.g. ``x^4/4`` for ``x^3``).
    """
    px, _pv, pax, _pav, sx, _sv = term.exponents
    n = px + pax
    e = (px + sx + 1) % 2
    x = np.asarray(x, dtype=float)
    out = np.abs(x) ** (n + 1) / (n + 1)
    if e:
        out = out * np.sign(x)
    return out


def cumulative_energy(t: np.ndarray, power: np.ndarray) -> Spline:
    """Antiderivative of a power signal, exact on its quintic spline interpolant.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    power : ndarray, shape (n,) or (n, m), [W]

    Returns
    -------
    Spline
        ``A(tq)``: integral of the spline of ``power`` from ``t[0]`` to ``tq`` [J].
    """
    return interpolate(t, power, SPLINE_DEGREE).antiderivative()


def check_series(t: np.ndarray, named: dict[str, np.ndarray | None], min_samples: int = 4,
                 finite: tuple[str, ...] = ()) -> tuple[np.ndarray, dict[str, np.ndarray | None]]:
    """Check a time base and the signals sampled on it.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Must be finite, strictly increasing and uniform (relative spread of steps <= 1e-6).
    named : dict of str to ndarray or None
        Signals by name, each of shape (n,) and finite; ``None`` entries are passed through.
    min_samples : int
        Fewest samples accepted.
    finite : tuple of str
        Names of float64 arrays the caller has already found finite (e.g. by a finite
        :func:`eddi.peaks.peak_abs`, which is NaN or inf otherwise): their finite pass is skipped.

    Returns
    -------
    t : ndarray, shape (n,)
    named : dict of str to ndarray or None
        The same signals as float arrays.

    Raises
    ------
    SignalError
        On NaN or infinite values, length mismatch, or a non-uniform or non-increasing time.
    """
    from eddi.errors import SignalError

    t = np.asarray(t, dtype=float)
    if t.ndim != 1:
        raise SignalError(f"t must be 1-D, got shape {t.shape}")
    if t.size < min_samples:
        raise SignalError(f"need at least {min_samples} samples, got {t.size}")
    from eddi.conditioning.checks import all_finite, time_steps  # compiled passes (local: no cycle)

    steps = time_steps(t)
    if steps is not None and steps[1] - steps[0] <= 1e-6 * steps[0]:
        pass  # finite, increasing, uniform: the checks below would pass (their messages when not)
    elif not np.all(np.isfinite(t)):
        raise SignalError(f"t contains {int(np.sum(~np.isfinite(t)))} NaN or infinite values")
    else:
        _check_steps(t)
    out: dict[str, np.ndarray | None] = {}
    for name, arr in named.items():
        if arr is None:
            out[name] = None
            continue
        arr = np.asarray(arr, dtype=float)
        if arr.shape != t.shape:
            raise SignalError(f"{name} has shape {arr.shape}; expected {t.shape} like t")
        if not (name in finite and arr is named[name]) and not all_finite(arr):
            bad = int(np.sum(~np.isfinite(arr)))
            raise SignalError(f"{name} contains {bad} NaN or infinite values (first at index {int(np.flatnonzero(~np.isfinite(arr))[0])})")
        out[name] = arr
    return t, out


def _check_steps(t: np.ndarray) -> None:
    """:func:`check_series`' checks of a finite time base: increasing, uniform (1e-6)."""
    from eddi.errors import SignalError

    dt = np.diff(t)
    if np.any(dt <= 0):
        k = int(np.flatnonzero(dt <= 0)[0])
        raise SignalError(f"t must be strictly increasing; t[{k + 1}] = {t[k + 1]!r} follows t[{k}] = {t[k]!r}")
    lo, hi = float(dt.min()), float(dt.max())
    # every step within 1e-6 of the smallest: within 1e-6 of the median too (no sort needed)
    spread = 0.0 if hi - lo <= 1e-6 * lo else float(np.max(np.abs(dt - np.median(dt)))) / float(np.median(dt))
    if spread > 1e-6:
        step = float(np.median(dt))
        raise SignalError(f"t must be uniform; steps vary by {spread:.3g} of the median step {step:.6g} s (expected <= 1e-6)")


def sample_window(window: tuple[int, int] | None, n: int, min_samples: int) -> tuple[int, int]:
    """``[start, stop)`` sample indices from a caller's window (negative indices count back).

    Parameters
    ----------
    window : tuple of int or None
        ``(start, stop)``; None means all ``n`` samples.
    n : int
        Number of samples.
    min_samples : int
        Fewest samples the window must hold.

    Returns
    -------
    tuple of int

    Raises
    ------
    SignalError
        If the window is not two integers, or not inside ``0..n`` with ``min_samples``.
    """
    from eddi.errors import SignalError

    if window is None:
        return 0, n
    try:
        start, stop = int(window[0]), int(window[1])
    except (TypeError, ValueError, IndexError):
        raise SignalError(f"window must be (start, stop) sample indices, got {window!r}") from None
    if start < 0:
        start += n
    if stop < 0:
        stop += n
    if not 0 <= start < stop <= n or stop - start < min_samples:
        raise SignalError(f"window must satisfy 0 <= start < stop <= {n} with >= {min_samples} samples, "
                          f"got {tuple(window)}")
    return start, stop
