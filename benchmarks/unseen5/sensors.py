"""The measurement chain of the fifth blind scorecard: a true signal on a fine grid -> DAQ samples.

Per channel, in order: optional first-order AC coupling (IEPE / charge amplifier, corner ``hp_hz``),
optional sensor nonlinearity ``y + nl2 * y^2 / ref`` (``ref``: a fixed physical acceleration, so
the law is the same in every capture), a causal 6th-order Butterworth anti-alias filter at
0.40 x the true rate (bilinear at the fine rate, 10x the DAQ rate), then the converter: ``point``
(a SAR snapshot at each sample instant) or ``avg`` (the mean over the sample period, a
sigma-delta's first-order kernel), then gain error, DC offset, white noise ``snr_db`` below the
channel's free-response peak, quantisation to ``bits`` over ``range_x`` x the record's peak. The
DAQ's clock runs ``ppm`` off the rate it stamps.

    python sensors.py     # the chain's gain at a few frequencies vs the transfer functions
"""

from __future__ import annotations

import numpy as np
from scipy import signal

R = 10  # fine points per sample period


def fine_grid(n_samples, fs_stamped, ppm):
    """Fine grid [s] on the true clock (sample k at index R*(k+1)) and the true sample period."""
    ts = 1.0 / (fs_stamped * (1 + ppm * 1e-6))
    tf = -ts + np.arange((n_samples + 1) * R + 1) * ts / R
    return tf, ts


def analog(y, ts, *, hp_hz=None, nl2=0.0, ref=1.0):
    """The sensor and anti-alias filter on the fine grid (causal, zero initial state)."""
    y = np.asarray(y, float)
    ffs = R / ts
    if hp_hz:
        b, a = signal.bilinear([1.0, 0.0], [1.0, 2 * np.pi * hp_hz], fs=ffs)
        y = signal.lfilter(b, a, y)
    if nl2:
        y = y + nl2 * y * y / ref
    sos = signal.butter(6, 0.40 / ts, fs=ffs, output="sos")
    return signal.sosfilt(sos, y)


def convert(y_fine, n, adc):
    """The converter: samples k = 0..n-1 from the filtered fine signal."""
    idx = R * (np.arange(n) + 1)
    if adc == "point":
        return y_fine[idx]
    c = np.cumsum(np.concatenate([[0.0], 0.5 * (y_fine[1:] + y_fine[:-1])]))
    return (c[idx] - c[idx - R]) / R  # trapezoid mean over the period ending at the sample


def digitise(s, rng, *, peak, snr_db, bits, range_x, gain=1.0, offset_frac=0.0):
    """Gain, offset, noise and quantisation of sampled values (full scale over the record's peak)."""
    s = gain * np.asarray(s, float) + offset_frac * peak
    full = range_x * np.max(np.abs(s))
    s = s + rng.normal(0.0, peak * 10 ** (-snr_db / 20), len(s))
    q = 2 * full / 2 ** bits
    return np.clip(np.round(s / q) * q, -full, full - q)


def _check():
    fs, n = 4000.0, 16000
    worst = 0.0
    for kw, adc, f in (({}, "point", 50.0), ({"hp_hz": 2.0}, "avg", 2.0), ({}, "avg", 900.0)):
        tf, ts = fine_grid(n, fs, 0.0)
        y = analog(np.sin(2 * np.pi * f * tf), ts, **kw)
        s = convert(y, n, adc)[n // 2:]
        t = (np.arange(n) / fs)[n // 2:]
        X = np.column_stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t)])
        amp = np.hypot(*np.linalg.lstsq(X, s, rcond=None)[0])
        b, a = signal.butter(6, 0.40 * fs, fs=R * fs)
        g = abs(signal.freqz(b, a, [f], fs=R * fs)[1][0])
        if kw:
            bh, ah = signal.bilinear([1.0, 0.0], [1.0, 2 * np.pi * kw["hp_hz"]], fs=R * fs)
            g *= abs(signal.freqz(bh, ah, [f], fs=R * fs)[1][0])
        if adc == "avg":
            g *= abs(np.sinc(f / fs))
        err = abs(amp / g - 1)
        worst = max(worst, err)
        print(f"{kw or 'plain'} {adc} at {f} Hz: gain {amp:.5f}, expected {g:.5f} ({err:.1e})")
    return worst


if __name__ == "__main__":
    _check()
