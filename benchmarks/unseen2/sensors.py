"""The measurement chain of the second blind scorecard: what another lab's DAQ writes.

A record is described by a JSON-able dict (``chain``) and turned into CSV columns by
:func:`record`:

* sample clock: the DAQ samples at ``fs (1 + ppm 1e-6)`` but stamps ``t = k / fs`` (its
  nominal rate; or ``k / (fs (1 + stamp_ppm 1e-6))``: a second DAQ's calibrated rate), starting at 0 with ``pre`` seconds of pre-trigger before the first blow;
* force: the hammer pulse averaged over each sample period (an integrate-and-dump ADC),
  times the force sensor's sensitivity error ``force_gain``, plus offset and white noise;
* acceleration: what the sensing element sees (``physics.simulate``: mounting resonance and
  IEPE high-pass are in the mechanics), times ``acc_gain (1 + drift t / T)`` (a sensitivity
  that drifts over the record), an offset, mains hum, white noise at ``snr_db`` below the
  free response's peak, a low-frequency cable noise (integrated white noise, high-passed at
  0.3 Hz), an analog saturation (``clip_analog``, before the noise) or an ADC overload
  (``clip_adc``: values flat at full scale), and the ADC's quantisation (``bits`` over
  +-``range`` times the record's largest value);
* an optional laser vibrometer instead (``quantity: "vel"``) measuring the velocity.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

import physics


def sample_times(chain):
    """True sample times [s] (physics clock) and stamped times [s] (the file's column: the
    nominal rate, or the rate the DAQ believes after its own calibration, ``stamp_ppm``)."""
    fs = chain["fs"]
    n = int(round(chain["duration"] * fs))
    k = np.arange(n, dtype=float)
    return k / (fs * (1.0 + chain.get("ppm", 0.0) * 1e-6)), k / (fs * (1.0 + chain.get("stamp_ppm", 0.0) * 1e-6))


def _adc(u, full_scale, bits):
    q = 2.0 * full_scale / 2 ** bits
    return np.clip(np.round(u / q) * q, -full_scale, full_scale - q)


def _force_channel(hits, t_true, fs, chain, rng):
    sub = 8
    off = (np.arange(sub) + 0.5) / sub - 0.5
    fine = (t_true[:, None] + off[None, :] / fs).ravel()
    f = physics.hammer_force(fine, hits).reshape(t_true.size, sub).mean(axis=1)
    f = f * chain.get("force_gain", 1.0)
    peak = float(np.max(np.abs(f)))
    f = f + chain.get("force_offset", 0.0) * peak + rng.normal(0.0, peak * chain.get("force_noise", 2e-4), f.size)
    return _adc(f, 1.5 * peak, chain.get("bits", 24))


def record(sys, hits, chain, rng):
    """Columns of one record: ``{"t": ..., "force": ..., "acc" or "vel": ...}`` and the truth
    (``x``, ``v``, ``a`` of the struck mass at the true sample times, the noise RMS).

    ``chain`` keys: ``fs`` [Hz], ``duration`` [s], ``ppm``, ``bits``, ``snr_db``,
    ``acc_gain``, ``drift`` (relative change over the record), ``offset`` (fraction of the
    peak), ``hum`` (fraction of the peak, at ``hum_hz``), ``cable`` (fraction of the peak),
    ``clip_analog`` / ``clip_adc`` (fraction of the peak), ``force`` (bool), ``force_gain``,
    ``quantity`` (``acc`` or ``vel``), ``cut_after_hit`` (free decay: drop the samples up to
    this many seconds after the blow's end and the force column).
    """
    t_true, t_stamp = sample_times(chain)
    fs = chain["fs"]
    x, v, a, sensed = physics.simulate(sys, hits, t_true)
    quantity = chain.get("quantity", "acc")
    y = sensed if quantity == "acc" else v
    end_hit = max(h["t0"] + h["dur"] for h in hits)
    free = t_true > end_hit + 2.0 / fs
    peak = float(np.max(np.abs(y[free])))
    gain = chain.get("acc_gain", 1.0) * (1.0 + chain.get("drift", 0.0) * t_true / t_true[-1])
    u = y * gain
    if chain.get("clip_analog"):
        level = chain["clip_analog"] * peak
        u = level * np.tanh(u / level) if chain.get("soft_clip") else np.clip(u, -level, level)
    sigma = peak * 10.0 ** (-chain.get("snr_db", 50.0) / 20.0)
    u = u + chain.get("offset", 0.0) * peak + rng.normal(0.0, sigma, u.size)
    if chain.get("hum"):
        u = u + chain["hum"] * peak * np.sin(2 * math.pi * chain.get("hum_hz", 50.0) * t_true + rng.uniform(0, 6.3))
    if chain.get("cable"):
        walk = np.cumsum(rng.normal(0.0, 1.0, u.size))
        b, a_ = signal.butter(1, 0.3 / (fs / 2), "highpass")
        walk = signal.lfilter(b, a_, walk)
        u = u + chain["cable"] * peak * walk / (np.std(walk) or 1.0)
    full = chain.get("range", 2.0) * float(np.max(np.abs(u)))  # the range covers the blow
    if chain.get("clip_adc"):
        full = chain["clip_adc"] * peak
    u = _adc(u, full, chain.get("bits", 24))
    cols = {"t": t_stamp}
    if chain.get("force", True):
        cols["force"] = _force_channel(hits, t_true, fs, chain, rng)
    cols[quantity] = u
    truth = {"x": x, "v": v, "a": a, "noise_rms": sigma, "peak": peak}
    if chain.get("cut_after_hit") is not None:
        keep = t_true > end_hit + chain["cut_after_hit"]
        cols = {k: c[keep] for k, c in cols.items() if k != "force"}
        cols["t"] = cols["t"] - cols["t"][0]
        truth = {k: (c[keep] if isinstance(c, np.ndarray) else c) for k, c in truth.items()}
    return cols, truth


def write_csv(path, cols):
    """Write the columns with a header, times with 10 significant digits, values with 9."""
    names = list(cols)
    data = np.column_stack([cols[n] for n in names])
    fmt = ["%.10g"] + ["%.9g"] * (len(names) - 1)
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt=fmt)
