"""The measurement chain: a true signal on a fine grid -> what a DAQ writes.

Per channel, in order: optional first-order IEPE high-pass (analog, corner fc) and optional
mounting resonance (second order, base-excited: the sensor's own acceleration), a causal analog
4th-order Butterworth anti-alias filter at 0.42 x the true rate (``scipy.signal.lsim``, exact for a
piecewise-linear input), the average over each sample period (trapezoid over the R fine points),
gain error, DC offset, white noise ``snr_db`` below the channel's free-response peak, quantisation to
``bits`` over a full scale of ``range_x`` x the whole record's peak (the impact included). The DAQ's clock runs ``ppm`` off the rate it stamps.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

R = 8  # fine points per sample period


def fine_grid(n_samples, fs_stamped, ppm, t_start):
    """Fine time grid [s] on the DAQ's true clock, and the true sample times.

    Sample k (k = 0..n-1) is taken at t_start + k * Ts_true and averages [t_k - Ts, t_k].
    """
    ts = 1.0 / (fs_stamped * (1 + ppm * 1e-6))
    tf = t_start - ts + np.arange((n_samples) * R + 1) * ts / R
    return tf, ts


def _lsim(num, den, u, t):
    return signal.lsim((num, den), u, t - t[0])[1]  # time-invariant: start the clock at 0


def chain(t_fine, y_true, ts, rng, *, snr_db, bits, range_x=2.0, gain=1.0, offset_frac=0.0,
          iepe_hz=None, mount_hz=None, mount_zeta=0.03, peak=None):
    """Sampled record (len = (len(t_fine) - 1) / R) of y_true seen through the chain."""
    y = np.asarray(y_true, float)
    if iepe_hz:
        wc = 2 * np.pi * iepe_hz
        y = _lsim([1.0, 0.0], [1.0, wc], y, t_fine)
    if mount_hz:
        wm = 2 * np.pi * mount_hz
        y = _lsim([2 * mount_zeta * wm, wm * wm], [1.0, 2 * mount_zeta * wm, wm * wm], y, t_fine)
    fc = 2 * np.pi * 0.42 / ts
    b, a = signal.butter(4, fc, analog=True)
    y = _lsim(b, a, y, t_fine)
    n = (len(t_fine) - 1) // R
    blocks = y[1:].reshape(n, R)
    prev = y[:-1].reshape(n, R)
    s = 0.5 * (blocks + prev).mean(axis=1)  # trapezoid mean over [t_k - Ts, t_k]
    pk = peak if peak is not None else np.max(np.abs(s))
    s = gain * s + offset_frac * pk
    full = range_x * np.max(np.abs(s))  # over the whole record's peak (the impact included)
    s = s + rng.normal(0.0, pk * 10 ** (-snr_db / 20), n)
    q = 2 * full / 2 ** bits
    s = np.clip(np.round(s / q) * q, -full, full - q)
    return s


def _check():
    """Gains of the chain's analog parts at a few frequencies vs their transfer functions."""
    fs, n = 2000.0, 8000
    rng = np.random.default_rng(0)
    worst = 0.0
    for kw, f, expect in (({}, 20.0, 1.0), ({"iepe_hz": 3.0}, 3.0, 2 ** -0.5),
                          ({"mount_hz": 150.0, "mount_zeta": 0.05}, 150.0, abs((1 + 0.1j) / 0.1j))):
        tf, ts = fine_grid(n, fs, 0.0, 0.0)
        s = chain(tf, np.sin(2 * np.pi * f * tf), ts, rng, snr_db=300, bits=52, range_x=10,
                  peak=1.0, **kw)
        tail = s[n // 2:]
        t = np.arange(n)[n // 2:] / fs
        X = np.column_stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t)])
        amp = np.hypot(*np.linalg.lstsq(X, tail, rcond=None)[0])
        # the anti-alias filter and the sample-period average, exactly
        b, a = signal.butter(4, 2 * np.pi * 0.42 * fs, analog=True)
        aa = abs(signal.freqs(b, a, [2 * np.pi * f])[1][0]) * abs(np.sinc(f / fs))
        err = abs(amp / (expect * aa) - 1)
        worst = max(worst, err)
        print(f"{kw or 'plain'} at {f} Hz: gain {amp:.5f}, expected {expect * aa:.5f} ({err:.1e})")
    return worst


if __name__ == "__main__":
    _check()
