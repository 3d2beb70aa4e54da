"""The working sample rate of a multi-DOF diagnosis: captures sampled far above their modes are
reduced by block means before anything else runs.

Why: every stage of :mod:`eddi.mdof` costs per sample (EDDI's sample-by-sample force balance
and its jackknife, the lumped fit, every simulation and its drift high-pass, the polish's
residuals), while what it resolves is set by the modes. The methods were built and measured at
25-90 samples per period of the highest mode (2048 Hz on 20-80 Hz systems); a 20 kHz capture of
the same structure carries 300 and made ``station diagnose`` ten times slower for nothing.

How: the highest mode is the highest peak of the responses' velocity spectrum (Welch, after the
pre-trigger) standing :data:`PEAK_REL` of the largest peak and ten times above the spectrum's
noise floor (median of its upper half); the factor is ``D = floor(rate / (SAMPLES_PER_PERIOD *
f_top))`` (no reduction when ``D < 2``), and every channel, the force among them, is replaced by
the means of ``D`` consecutive samples, stamped at the blocks' centres. A block mean is the
integrating anti-alias filter of a DAQ (and of the rig's hammer, :func:`simulated_rig.hammer.half_sine`):
no ringing around the hammer pulse (the impact is found by a threshold) and the impulse kept
exactly; force and responses go through the same linear filter, so a linear structure's
response to the reduced force is the reduced response. Its gain at the highest mode is
``sinc(1 / SAMPLES_PER_PERIOD)`` (0.07 % at 48 samples per period), on both sides; white
noise's density is kept (the mean of ``D`` samples has ``1/D`` of the variance at ``1/D`` of
the band).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

#: Samples per period of the highest mode kept by the reduction: the middle of the range the
#: MDOF methods were measured at (25-90, :mod:`eddi.mdof` cases at 1-4 kHz), so the repo's own
#: cases are not reduced.
SAMPLES_PER_PERIOD = 48.0
#: Samples per capture past which the rate is reduced further (a stated bound on the cost, which
#: is about linear in the samples: the repo's three-mass chain holds 6100 per capture, 3 s at
#: 2048 Hz) ...
MAX_SAMPLES = 16384
#: ... but never below this many samples per period of the highest mode (the rig's internal-1-3
#: system was measured at 27, :mod:`eddi.mdof` at 25-90).
MIN_SAMPLES_PER_PERIOD = 32.0
#: A spectral peak counts as a mode when its velocity power is at least this share of the largest.
PEAK_REL = 1e-3


def highest_mode_hz(y: np.ndarray, rate_hz: float, quantity: str = "acc") -> float:
    """Highest spectral peak of the velocity of any channel [Hz] (module docstring), 0 when none.

    Parameters
    ----------
    y : ndarray, shape (n_channels, n)
        Response after the trigger (acceleration, velocity or displacement).
    rate_hz : float
    quantity : {"acc", "vel", "disp"}
    """
    y = np.atleast_2d(np.asarray(y, float))
    if y.shape[1] < 64:
        return 0.0
    nper = int(min(y.shape[1], max(256, 2 ** int(np.log2(max(rate_hz, 256))))))
    f, p = signal.welch(y, fs=rate_hz, nperseg=nper, axis=1)
    f, p = f[1:], p[:, 1:]
    w = 2 * np.pi * f
    p = p / w**2 if quantity == "acc" else (p * w**2 if quantity == "disp" else p)
    top = 0.0
    for row in p:
        floor = float(np.median(row[row.size // 2:]))
        peaks, _ = signal.find_peaks(row, height=max(PEAK_REL * float(row.max()), 10.0 * floor))
        if peaks.size:
            top = max(top, float(f[peaks[-1]]))
    return top


def reduction_factor(rate_hz: float, top_hz: float, samples_per_period: float = SAMPLES_PER_PERIOD,
                     n_samples: int | None = None, max_samples: int = MAX_SAMPLES) -> int:
    """Block length ``D`` (1: keep the rate) for a highest mode at ``top_hz``.

    ``samples_per_period`` of the highest mode are kept; a capture of ``n_samples`` that would
    still hold more than ``max_samples`` is reduced further, down to :data:`MIN_SAMPLES_PER_PERIOD`.
    """
    if not (top_hz > 0 and math.isfinite(top_hz) and rate_hz > 0):
        return 1
    d = int(rate_hz // (samples_per_period * top_hz))
    if n_samples is not None and n_samples > max(d, 1) * max_samples:
        d_floor = int(rate_hz // (MIN_SAMPLES_PER_PERIOD * top_hz))
        d = max(d, min(-(-n_samples // max_samples), d_floor))
    return d if d >= 2 else 1


def block_mean(y: np.ndarray, d: int) -> np.ndarray:
    """Means of ``d`` consecutive samples along the last axis (a trailing partial block dropped)."""
    y = np.asarray(y, float)
    n = (y.shape[-1] // d) * d
    return y[..., :n].reshape(y.shape[:-1] + (n // d, d)).mean(axis=-1)
