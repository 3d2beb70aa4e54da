"""Mains (line) interference: a persistent narrowband tone at the grid frequency on a channel.

A logger, a cable or a conditioner picks up the grid's 50 or 60 Hz (and its harmonics) as an
additive tone of constant amplitude and phase-continuous over the capture. A structure's mode
near 50 Hz looks alike in the ring-down's tail, but a mode is set ringing by the blow and decays:
it is absent before the blow. A tone is not: it stands in the pre-trigger at the amplitude it
keeps in the late tail (session 19, helper s19hum: a blind two-channel logger export with a
0.005 g, 50 Hz tone on both channels read "the records ring at 49.9 Hz, damping ratio 0.0037"
for a 73.7 Hz mode and was called ``unexplained``).

:func:`line_tones` looks, per channel, at every line frequency ``h f_grid`` (``f_grid`` 50 and
60 Hz, ``h`` 1..:data:`MAX_HARMONIC`, below 0.4 of the sample rate) within :data:`GRID_TOL` of
the nominal value:

* the frequency is refined by least squares of one phase-continuous sinusoid (with an offset per
  segment) over the pre-trigger and the late tail together (the grid's frequency is a common
  one; a few pre-trigger cycles do not resolve it, FFT bins of 50 ms are 20 Hz wide);
* the amplitude is then fitted on each segment alone: on the pre-trigger (samples before the
  blow; 2 cycles at least) by ordinary least squares, on the late tail (the last
  :data:`TAIL_SHARE` of the free response) by least squares weighted with a Hann taper (a mode
  ringing 20 Hz away leaks 3 % of its amplitude into an untapered 0.5 s fit, far more than a
  0.005 g tone; tapered, under 1e-4);
* each segment's amplitude must stand :data:`TONE_SIGMAS` standard errors over the channel's
  noise at rest (the pre-trigger's residual after the tone and a trend are taken out): by chance
  a Rayleigh amplitude exceeds k standard errors with probability ``exp(-k^2 / 2)``, 3.4e-4 per
  segment at k = 4, 1.1e-7 for both; over the ~30 independent frequencies searched on a record
  3e-6 (the same standard as :data:`eddi.diagnosis.chain.BASE_NOISE_BINS`);
* the two amplitudes must agree (a tone is persistent): within 3 combined standard errors plus
  :data:`AMPLITUDE_AGREEMENT` of the larger. A mode at the line frequency is absent before the
  blow and larger in the tail than there: not a tone.

:func:`remove_tones` subtracts the tones fitted (phase-continuous, frequency refined) from the
whole channel: the correction the diagnosis re-runs on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

#: Nominal grid frequencies [Hz].
LINE_HZ = (50.0, 60.0)
#: Relative tolerance on the grid frequency (the grid holds +-0.2 %; loggers' clocks add some).
GRID_TOL = 0.01
#: Harmonics searched (1: the fundamental).
MAX_HARMONIC = 5
#: Standard errors of the amplitude a tone must stand in each segment (module notes).
TONE_SIGMAS = 4.0
#: Relative disagreement of the pre-trigger's and the tail's amplitude a tone may show beyond
#: their standard errors (pick-up changes little over a second).
AMPLITUDE_AGREEMENT = 0.3
#: Share of the free response, at its end, read as the late tail.
TAIL_SHARE = 0.4
#: Cycles the pre-trigger must hold at a line frequency.
MIN_CYCLES = 2.0


@dataclass(frozen=True)
class LineTone:
    """One line tone on one channel.

    Attributes
    ----------
    frequency_hz : float
        Refined frequency [Hz]; ``nominal_hz`` the grid's multiple it belongs to.
    amplitude : float
        Amplitude (peak) of the phase-continuous fit over both segments [channel units, SI].
    cos, sin : float
        Its coefficients: the tone is ``cos * cos(w t) + sin * sin(w t)`` on the record's time.
    pre_amplitude, tail_amplitude : float
        Amplitudes fitted on the pre-trigger and the late tail alone.
    pre_sigmas, tail_sigmas : float
        Each over its standard error.
    noise_rms : float
        The channel's noise at rest with the tone taken out [SI].
    rest_rms : float
        The channel's RMS at rest as measured (tone included) [SI].
    """

    frequency_hz: float
    nominal_hz: float
    amplitude: float
    cos: float
    sin: float
    pre_amplitude: float
    tail_amplitude: float
    pre_sigmas: float
    tail_sigmas: float
    noise_rms: float
    rest_rms: float

    @property
    def power_share(self) -> float:
        """The tone's share of the channel's power at rest (0..1)."""
        return min(1.0, 0.5 * self.amplitude ** 2 / self.rest_rms ** 2) if self.rest_rms > 0 else 0.0

    def signal(self, t: np.ndarray) -> np.ndarray:
        w = 2 * math.pi * self.frequency_hz
        return self.cos * np.cos(w * t) + self.sin * np.sin(w * t)


def _design(t: np.ndarray, f: float, seg: np.ndarray, extra: Sequence[float] = ()) -> np.ndarray:
    """Columns cos, sin, then an offset and a slope per segment label in ``seg`` (0, 1), then per
    frequency of ``extra`` a sinusoid with a linear envelope (a mode ringing down nearby)."""
    w = 2 * math.pi * f
    cols = [np.cos(w * t), np.sin(w * t)]
    tc = t - np.mean(t)
    for fe in extra:
        we = 2 * math.pi * fe
        c, s_ = np.cos(we * t), np.sin(we * t)
        cols += [c, s_, tc * c, tc * s_]
    for k in np.unique(seg):
        m = (seg == k).astype(float)
        tk = (t - np.mean(t[seg == k])) * m
        cols += [m, tk]
    return np.column_stack(cols)


def _lsq(t: np.ndarray, y: np.ndarray, f: float, seg: np.ndarray, w: np.ndarray | None = None,
         extra: Sequence[float] = ()) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Coefficients, residual and the unscaled covariance of (cos, sin) of a (weighted) fit."""
    X = _design(t, f, seg, extra)
    Xw = X if w is None else X * w[:, None]
    # normal equations of a few well-scaled columns (lstsq's SVD was 30x slower)
    g = np.linalg.pinv(Xw.T @ Xw)
    coef = g @ (Xw.T @ (y if w is None else y * w))
    # weighted: the estimate's covariance under white noise of unit variance (sandwich): the
    # estimate is g X'W^2 y, so g X'W^4 X g (session 19 had X'W^3 X: the Hann-tapered tail's
    # variance 14 % high, its standard error 7 %; session 20, tests/eddi/test_diagnose_mains.py)
    cov = g if w is None else g @ (Xw.T @ (Xw * (w * w)[:, None])) @ g
    return coef, y - X @ coef, cov[:2, :2]


def _refine(t: np.ndarray, y: np.ndarray, w: np.ndarray, f0: float) -> float:
    """The frequency within ``GRID_TOL`` of ``f0`` of the largest phase-continuous fit: the
    weighted (``w``: 1 on the pre-trigger, the Hann taper on the tail) demodulation of ``y``
    (offsets removed per segment) over a grid of a quarter of the span's resolution, the peak
    refined by a parabola."""
    span = float(t[-1] - t[0]) or 1.0
    lo, hi = f0 * (1 - GRID_TOL), f0 * (1 + GRID_TOL)
    n = max(5, int(math.ceil((hi - lo) * span * 4)) + 1)
    grid = np.linspace(lo, hi, n)
    z = (w * y) * np.exp(-2j * math.pi * lo * t)
    step = np.exp(-2j * math.pi * (grid[1] - grid[0]) * t)
    p = np.empty(n)
    for i in range(n):  # phasors by recursion: a product per point instead of an exponential
        p[i] = abs(complex(np.sum(z))) ** 2
        z = z * step
    k = int(np.argmax(p))
    if 0 < k < n - 1 and p[k - 1] + p[k + 1] - 2 * p[k] < 0:
        d = 0.5 * (p[k - 1] - p[k + 1]) / (p[k - 1] + p[k + 1] - 2 * p[k])
        return float(grid[k] + d * (grid[1] - grid[0]))
    return float(grid[k])


def _amp_sigmas(coef: np.ndarray, cov: np.ndarray, sigma: float) -> tuple[float, float]:
    """Amplitude and its size over the standard error of one quadrature under white noise."""
    amp = float(math.hypot(coef[0], coef[1]))
    se = sigma * math.sqrt(max(0.5 * (cov[0, 0] + cov[1, 1]), 1e-300))
    return amp, (amp / se if se > 0 else 0.0)


def line_tones(t: np.ndarray, y: np.ndarray, rest: int, tail: tuple[int, int]) -> list[LineTone]:
    """The line tones standing in channel ``y`` (module notes); ``rest``: samples before the blow,
    ``tail``: ``[start, stop)`` of the late tail. Empty when the pre-trigger is too short.

    Strongest first; a tone taken is subtracted before the next is tested (50 ms of pre-trigger
    do not tell 50 from 60 Hz: a 0.3 m/s^2 tone at 50 Hz read 0.2 m/s^2 at 59.4 Hz beside it)."""
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    if rest < 16 or tail[1] - tail[0] < 64 or t.size < 2:
        return []
    rate = 1.0 / float(t[1] - t[0])
    cands = sorted({round(h * b, 6) for b in LINE_HZ for h in range(1, MAX_HARMONIC + 1)
                    if h * b <= 0.4 * rate and rest >= MIN_CYCLES * rate / (h * b * (1 - GRID_TOL))})
    found: list[LineTone] = []
    rest_rms = float(np.std(y[:rest]))
    while cands:
        best = None
        for f0 in cands:
            tn = _candidate(t, y, rest, tail, f0, rest_rms)
            if tn is not None and (best is None or tn.amplitude > best.amplitude):
                best = tn
        if best is None:
            break
        found.append(best)
        y = y - best.signal(t)
        cands = [c for c in cands if c != round(best.nominal_hz, 6)]
    return found


def _candidate(t: np.ndarray, y: np.ndarray, rest: int, tail: tuple[int, int], f0: float,
               rest_rms: float) -> LineTone | None:
    """The tone at ``f0`` (nominal) when it stands (module notes), else None."""
    rate = 1.0 / float(t[1] - t[0])
    t0, t1 = tail
    pre_t, pre_y = t[:rest], y[:rest]
    tail_t, tail_y = t[t0:t1], y[t0:t1]
    hann = np.hanning(t1 - t0 + 2)[1:-1]
    span = float(tail_t[-1] - tail_t[0]) or 1.0
    pad = 4 * (t1 - t0)
    p_tail = np.abs(np.fft.rfft(hann * (tail_y - np.mean(tail_y)), pad)) ** 2
    f_tail = np.fft.rfftfreq(pad, 1.0 / rate)
    # modes ringing near the line frequency, fitted at the nominal one and taken out of the tail
    near = _nearby(f_tail, p_tail, f0, span)
    one = np.zeros(t1 - t0, int)
    ring = _design(tail_t, f0, one, near)[:, 4:] @ _lsq(tail_t, tail_y, f0, one, hann, near)[0][4:]
    tail_c = tail_y - ring
    tt = np.concatenate([pre_t, tail_t])
    seg = np.concatenate([np.zeros(rest, int), np.ones(t1 - t0, int)])
    wj = np.concatenate([np.ones(rest), hann])
    yd = np.concatenate([pre_y - np.mean(pre_y), tail_c - np.sum(hann * tail_c) / np.sum(hann)])
    f = _refine(tt, yd, wj, f0)
    cp, rp, vp = _lsq(pre_t, pre_y, f, np.zeros(rest, int))
    sigma = float(np.sqrt(np.sum(rp ** 2) / max(1, rest - 4)))
    ct, _rt, vt = _lsq(tail_t, tail_y, f, one, hann, near)
    ap, zp = _amp_sigmas(cp, vp, sigma)
    at, zt = _amp_sigmas(ct, vt, sigma)
    if min(zp, zt) < TONE_SIGMAS:
        return None
    if abs(ap - at) > 3 * math.hypot(ap / zp, at / zt) + AMPLITUDE_AGREEMENT * max(ap, at):
        return None
    cj, _r, _v = _lsq(tt, np.concatenate([pre_y, tail_c]), f, seg, wj)
    return LineTone(f, f0, float(math.hypot(cj[0], cj[1])), float(cj[0]), float(cj[1]), ap, at, zp, zt, sigma,
                    rest_rms)


#: Half-width [resolutions of the tail, 1 / its duration] around a line frequency in which the
#: tail's strongest peaks (:data:`NEARBY_PEAKS`) are fitted out beside the tone, and the least
#: distance of such a peak from it.
NEARBY_SPAN, NEARBY_GAP = 12.0, 2.5
#: Peaks fitted out near a line frequency.
NEARBY_PEAKS = 2
#: ... when their power is this many times the tail's at the line frequency.
NEARBY_OVER = 10.0


def _nearby(f_tail: np.ndarray, p_tail: np.ndarray, f: float, span: float) -> list[float]:
    """The tail's strongest local spectral maxima within :data:`NEARBY_SPAN` resolutions of
    ``f`` but :data:`NEARBY_GAP` away from it: modes ringing down near the line frequency. A
    50 Hz mode 0.5 s after the blow, 10 Hz from a 60 Hz tone, leaked through the taper as much as
    a 0.03 m/s^2 tone and was read as one at 60.6 Hz; fitted out with a linear envelope, it
    leaves the tone alone."""
    d = np.abs(f_tail - f) * span
    k = np.flatnonzero((d <= NEARBY_SPAN) & (d >= NEARBY_GAP))
    k = k[(k > 0) & (k < p_tail.size - 1)]
    k = k[(p_tail[k] > p_tail[k - 1]) & (p_tail[k] >= p_tail[k + 1])]
    # only what outshines the line frequency's own bin leaks into it: the tone's own sidelobes
    # (-31 dB under it, 2.5 resolutions out) fitted beside it took a third of a strong tone's
    # amplitude from it (0.3 m/s^2 read 0.45 in the tail)
    k = k[p_tail[k] > NEARBY_OVER * p_tail[int(np.argmin(np.abs(f_tail - f)))]]
    top = k[np.argsort(p_tail[k])[::-1][:NEARBY_PEAKS]]
    return [float(f_tail[i]) for i in top]


def tail_of(start: int, stop: int) -> tuple[int, int]:
    """The late tail of a free response ``[start, stop)``: its last :data:`TAIL_SHARE`."""
    return stop - int(TAIL_SHARE * (stop - start)), stop


def remove_tones(t: np.ndarray, y: np.ndarray, tones: Sequence[LineTone]) -> np.ndarray:
    """``y`` with the fitted tones subtracted over the whole record."""
    out = np.asarray(y, float).copy()
    for tn in tones:
        out -= tn.signal(np.asarray(t, float))
    return out


def tone_text(where: str, tones: Sequence[LineTone], captures: int = 1, of: int = 1) -> str:
    """One sentence on the tones of a channel (amplitudes in SI and g)."""
    parts = [f"{tn.frequency_hz:.4g} Hz, {tn.amplitude:.3g} m/s^2 ({tn.amplitude / 9.80665:.2g} g; "
             f"{tn.pre_sigmas:.0f} and {tn.tail_sigmas:.0f} standard errors before the blow and in the tail, "
             f"{100 * tn.power_share:.0f} % of the power at rest)" for tn in tones]
    seen = f" in {captures} of {of} captures" if of > 1 else ""
    return (f"{where}: a persistent line tone{seen} at " + "; ".join(parts)
            + ": mains interference (present before the blow at the amplitude it keeps in the tail, "
              "unlike a mode)")
