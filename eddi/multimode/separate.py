"""Separating the modes of one measured coordinate: zero-phase band-passes with AR-extended ends, band suggestions."""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import signal

from eddi.calculus import differentiate, integrate
from eddi.errors import SignalError

# -- calculus and separation ------------------------------------------------------------------


def check_signal(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    t = np.asarray(t, dtype=float)
    v = np.asarray(v, dtype=float)
    if t.ndim != 1 or v.shape != t.shape:
        raise SignalError(f"t and v must be 1-D of the same length, got {t.shape} and {v.shape}")
    if t.size < 64:
        raise SignalError(f"record too short: expected at least 64 samples, got {t.size}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
        raise SignalError("t or v contains NaN or infinite values")
    dt = float((t[-1] - t[0]) / (t.size - 1))
    # times printed with few decimals jitter step by step; what must hold is that every
    # sample sits on the uniform grid (within 1 % of a step)
    grid = t[0] + dt * np.arange(t.size)
    if not dt > 0 or np.any(np.diff(t) <= 0) or np.max(np.abs(t - grid)) > 0.01 * dt:
        raise SignalError(
            f"time must be uniform and increasing: expected samples on a {dt:g} s grid within 1 % of a step"
        )
    return grid, v, dt


def _ar_predict(seed: np.ndarray, n: int, order: int, fit: np.ndarray) -> np.ndarray:
    """Continue ``seed`` forward by ``n`` samples with an AR model fitted on ``fit``."""
    p = int(min(order, max(1, fit.size // 4)))
    rows = np.lib.stride_tricks.sliding_window_view(fit, p + 1)
    coef, *_ = np.linalg.lstsq(rows[:, :p], rows[:, p], rcond=None)
    # keep the extension from growing: reflect unstable poles inside the unit circle
    roots = np.roots(np.concatenate(([1.0], -coef[::-1])))
    big = np.abs(roots) > 1.0
    if np.any(big):
        roots[big] = 1.0 / np.conj(roots[big])
        coef = -np.real(np.poly(roots))[1:][::-1]
    out = np.empty(n + p)
    out[:p] = seed[-p:]
    for i in range(n):
        out[p + i] = out[i : p + i] @ coef
    return out[p:]


def _ar_extend(v: np.ndarray, n_pad: int, order: int) -> np.ndarray:
    """``v`` with ``n_pad`` samples of linear prediction before and after, shape (n + 2 n_pad,)."""
    if n_pad <= 0:
        return v.copy()
    m = int(min(v.size, max(8 * order, v.size // 30)))
    head = _ar_predict(v[:m][::-1], n_pad, order, v[:m][::-1])[::-1]
    tail = _ar_predict(v[-m:], n_pad, order, v[-m:])
    return np.concatenate((head, v, tail))


def band_filter(band_hz: Sequence[float], fs: float, order: int) -> np.ndarray:
    """Second-order sections of the Butterworth band-pass (low-pass when ``low == 0``).

    Cached: diagnosis designs the same few filters hundreds of times (2.2 s of a 19 s run).
    The array is shared: callers must not change it (SciPy's filters only read it, but
    need it writeable)."""
    return _butter_sos(float(band_hz[0]), float(band_hz[1]), float(fs), int(order))


@functools.lru_cache(maxsize=256)
def _butter_sos(lo: float, hi: float, fs: float, order: int) -> np.ndarray:
    if lo > 0:
        sos = signal.butter(order, [lo, hi], btype="bandpass", fs=fs, output="sos")
    else:
        sos = signal.butter(order, hi, btype="lowpass", fs=fs, output="sos")
    return sos


def zero_phase(sos: np.ndarray, y: np.ndarray, pad: int = 256, ar_order: int = 30) -> np.ndarray:
    """Forward-backward filtering with linear-prediction padding at both ends."""
    n_pad = min(pad, y.size)
    return signal.sosfiltfilt(sos, _ar_extend(y, n_pad, ar_order))[n_pad : n_pad + y.size]


@dataclass(frozen=True)
class ModalComponents:
    """Separated modal states of one record.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
    x, v, a : ndarray, shape (n_modes, n)
        Modal displacement [m], velocity [m/s] and acceleration [m/s^2] (units of the input).
    bands_hz : tuple of (float, float)
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    bands_hz: tuple[tuple[float, float], ...]


def separate_modes(
    t: np.ndarray,
    v: np.ndarray,
    bands_hz: Sequence[tuple[float, float]],
    *,
    filter_order: int = 8,
    pad_s: float = 0.5,
    ar_order: int = 30,
) -> ModalComponents:
    """Split a velocity record into modal components with zero-phase band-passes.

    A band-pass run over a record that starts at full amplitude rings at the ends (its
    transient biases the energy at the first crossings by several times the energy lost per
    cycle of a lightly damped mode). The record is therefore extended at both ends by
    ``pad_s`` of linear prediction (an autoregressive model of order ``ar_order`` fitted by
    least squares to the first / last 0.1 s; a sum of damped sinusoids is exactly
    autoregressive) before filtering, and the extension is cut off afterwards.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Uniform time base.
    v : ndarray, shape (n,), [m/s]
        Measured velocity.
    bands_hz : sequence of (low, high)
        Pass band of each mode [Hz]; ``low = 0`` means a low-pass.
    filter_order : int
        Butterworth order (doubled by the forward-backward pass).
    pad_s : float
        Linear-prediction extension at each end [s].
    ar_order : int
        Order of the autoregressive model used for the extension.

    Returns
    -------
    ModalComponents
    """
    return separate_components(t, v, bands_hz, filter_order, pad_s, ar_order, None)


def separate_components(t: np.ndarray, v: np.ndarray, bands_hz: Sequence[tuple[float, float]], filter_order: int,
              pad_s: float, ar_order: int, cache: dict | None) -> ModalComponents:
    """:func:`separate_modes`; with ``cache`` (a dict the caller keeps while ``v`` lives), the
    padded record and each band's components are made once per record (diagnosis separates
    the same records in every fold)."""
    key = (id(v), v.size, float(pad_s), int(ar_order))
    prep = cache.get(key) if cache is not None else None
    if prep is None:
        t, v, dt = check_signal(t, v)
        fs = 1.0 / dt
        n = v.size
        n_pad = min(n, int(round(pad_s * fs)))
        vp = _ar_extend(v, n_pad, ar_order)
        x_raw = signal.detrend(integrate(vp, dt), type="linear")
        a_raw = differentiate(vp, dt)
        prep = (t, fs, vp, x_raw, a_raw, slice(n_pad, n_pad + n))
        if cache is not None:
            cache[key] = prep
    t, fs, vp, x_raw, a_raw, keep = prep
    xs, vs, as_ = [], [], []
    for lo, hi in bands_hz:
        if not (0 <= lo < hi < fs / 2):
            raise SignalError(f"band ({lo}, {hi}) Hz must satisfy 0 <= low < high < {fs / 2:.1f}")
        bkey = key + (float(lo), float(hi), int(filter_order))
        got = cache.get(bkey) if cache is not None else None
        if got is None:
            sos = band_filter((lo, hi), fs, filter_order)
            got = (signal.sosfiltfilt(sos, x_raw)[keep], signal.sosfiltfilt(sos, vp)[keep],
                   signal.sosfiltfilt(sos, a_raw)[keep])
            if cache is not None:
                cache[bkey] = got
        xs.append(got[0])
        vs.append(got[1])
        as_.append(got[2])
    return ModalComponents(
        t=t, x=np.array(xs), v=np.array(vs), a=np.array(as_),
        bands_hz=tuple((float(lo), float(hi)) for lo, hi in bands_hz),
    )


def suggest_bands(
    t: np.ndarray, v: np.ndarray, n_modes: int, *, min_ratio: float = 1.2,
    min_power_ratio: float = 1e-4,
) -> tuple[tuple[float, float], ...]:
    """Separation bands around the ``n_modes`` strongest spectral peaks of a record.

    Peaks of the Welch spectrum closer than a frequency ratio ``min_ratio`` count as one;
    peaks below ``min_power_ratio`` times the largest are ignored.
    Neighbouring bands meet at the geometric mean of their peaks; the outer edges sit at a
    third below the lowest peak and 60 % above the highest (below 0.45 of the sample rate).

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    v : ndarray, shape (n,)
    n_modes : int
    min_ratio : float
    min_power_ratio : float

    Returns
    -------
    tuple of (low, high), [Hz], sorted by frequency

    Raises
    ------
    SignalError
        If fewer than ``n_modes`` separate peaks are found.
    """
    t, v, dt = check_signal(t, v)
    return suggest_bands_many([(t, v)], n_modes, min_ratio=min_ratio,
                              min_power_ratio=min_power_ratio)


def welch_sum(records: Sequence[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """Sum over records of each record's Welch spectrum normalised to unit total power.

    Parameters
    ----------
    records : sequence of (t, v)
        Uniform records of the same sample rate (lengths may differ).

    Returns
    -------
    freqs_hz : ndarray, shape (m,)
    power : ndarray, shape (m,)
        Dimensionless (each record weighs the same).
    """
    if not records:
        raise SignalError("expected at least one record, got none")
    nper = min(4096, min(np.asarray(v).size for _t, v in records))
    freqs = None
    total = None
    for t, v in records:
        t, v, dt = check_signal(t, v)
        f, p = signal.welch(v, fs=1.0 / dt, nperseg=nper)
        s = float(np.sum(p))
        p = p / s if s > 0 else p
        if total is None:
            freqs, total = f, p
        elif p.shape != total.shape:
            raise SignalError("records have different sample rates; resample them first")
        else:
            total = total + p
    assert freqs is not None and total is not None
    return freqs, total


def suggest_bands_many(
    records: Sequence[tuple[np.ndarray, np.ndarray]], n_modes: int, *, min_ratio: float = 1.2,
    min_power_ratio: float = 1e-4,
) -> tuple[tuple[float, float], ...]:
    """:func:`suggest_bands` on the summed spectra of several records (:func:`welch_sum`).

    Raises
    ------
    SignalError
        If fewer than ``n_modes`` separate peaks are found.
    """
    freqs, power = welch_sum(records)
    fs = 2.0 * float(freqs[-1])
    peaks, _ = signal.find_peaks(power, height=min_power_ratio * float(np.max(power)))
    peaks = peaks[freqs[peaks] > 0]
    chosen: list[float] = []
    for i in peaks[np.argsort(power[peaks])[::-1]]:
        f = float(freqs[i])
        if all(max(f, c) / min(f, c) >= min_ratio for c in chosen):
            chosen.append(f)
        if len(chosen) == n_modes:
            break
    if len(chosen) < n_modes:
        raise SignalError(
            f"expected {n_modes} separate spectral peaks (ratio >= {min_ratio}), found {len(chosen)}"
        )
    chosen.sort()
    edges = [chosen[0] / 1.5]
    edges += [math.sqrt(a * b) for a, b in zip(chosen[:-1], chosen[1:])]
    edges.append(min(chosen[-1] * 1.6, 0.45 * fs))
    return tuple((float(lo), float(hi)) for lo, hi in zip(edges[:-1], edges[1:]))


# -- per-mode EDDI, stacked over records ------------------------------------------------------
