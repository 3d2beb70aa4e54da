"""Sensor chain and DAQ of the third blind scorecard (no project code).

A record is produced from the mechanics on a fine grid (``oversample`` points per DAQ sample, the
grid laid on the DAQ's *true* clock, which runs ``clock_ppm`` off the rate it stamps):

1. optional first-order IEPE/AC coupling ``s / (s + w_c)`` (bilinear, on the fine grid);
2. anti-alias: 4th-order Butterworth low-pass at 0.42 of the sample rate (causal, as an analog
   front end) on the fine grid, then the average over each sample period (the ADC's integration);
3. gain error, DC offset, white noise ``snr_db`` below the channel's peak, slow cable drift;
4. quantisation to ``bits`` over a range ``range_factor`` times the channel's peak;
5. time stamps ``i / rate_stamped`` rounded to ``time_digits`` decimals.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal


@dataclass(frozen=True)
class Chain:
    """One channel's sensor and converter."""

    snr_db: float = 45.0
    bits: int = 24
    range_factor: float = 2.0
    highpass_hz: float = 0.0          # IEPE corner [Hz], 0 = DC coupled
    gain_error: float = 0.0           # relative
    offset_frac: float = 0.0          # DC offset as a fraction of the peak
    drift_frac: float = 0.0           # slow cable drift (0.3 Hz sine) as a fraction of the peak


def highpass(fine, dt_fine, corner_hz):
    """First-order analog high-pass ``s / (s + 2 pi f_c)`` by the bilinear transform."""
    if corner_hz <= 0:
        return fine
    b, a = signal.bilinear([1.0, 0.0], [1.0, 2 * np.pi * corner_hz], fs=1.0 / dt_fine)
    return signal.lfilter(b, a, fine)


def to_samples(fine, oversample, fs):
    """Anti-alias filter (causal 4th-order Butterworth at 0.42 fs) and per-period averaging."""
    sos = signal.butter(4, 0.42 * fs, fs=fs * oversample, output="sos")
    y = signal.sosfilt(sos, fine)
    n = y.size // oversample
    return y[: n * oversample].reshape(n, oversample).mean(axis=1)


def measure(fine, oversample, fs, chain, rng, peak_ref=None, range_ref=None):
    """One channel: fine-grid truth -> sampled, noisy, quantised values (SI).

    Noise, offset and drift are relative to ``peak_ref`` (the free response's peak), the
    converter's range to ``range_ref`` (the whole record's peak, the blow included)."""
    dt_fine = 1.0 / (fs * oversample)
    y = to_samples(highpass(fine, dt_fine, chain.highpass_hz), oversample, fs)
    peak = float(peak_ref if peak_ref is not None else np.max(np.abs(y)))
    rng_peak = max(float(range_ref if range_ref is not None else np.max(np.abs(y))), peak)
    y = y * (1 + chain.gain_error) + chain.offset_frac * peak
    t = np.arange(y.size) / fs
    y = y + chain.drift_frac * peak * np.sin(2 * np.pi * 0.3 * t + rng.uniform(0, 6.28))
    y = y + rng.normal(0.0, peak * 10 ** (-chain.snr_db / 20), y.size)
    full = chain.range_factor * rng_peak
    lsb = 2 * full / 2 ** chain.bits
    return np.clip(np.round(y / lsb) * lsb, -full, full - lsb)


def write_csv(path, rate_stamped, columns, time_digits=7, order=None, t0=0.0):
    """Write ``columns`` (name -> samples) with a time column ``t`` (rounded) in ``order``."""
    n = min(len(v) for v in columns.values())
    t = np.round(t0 + np.arange(n) / rate_stamped, time_digits)
    cols = {"t": t, **{k: np.asarray(v)[:n] for k, v in columns.items()}}
    names = list(order) if order else list(cols)
    data = np.column_stack([cols[k] for k in names])
    fmt = [f"%.{time_digits}f" if k == "t" else "%.9g" for k in names]
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt=fmt)
    return path
