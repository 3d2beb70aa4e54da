"""Displacement, velocity and acceleration of several channels that carry several modes.

The single-channel conditioning (:func:`eddi.conditioning.condition`) anchors the integral on
one oscillation (cycle means of the lowest mode); on a channel that carries two modes of
different decay it leaves 10-20 % error in the displacement (measured on the two-mass rig).
Here, as in :mod:`eddi.multimode`: 4th-order cumulative integration
(:func:`eddi.calculus.integrate`) from rest, then a zero-phase Butterworth
high-pass (``sosfiltfilt``) at ``highpass_hz`` (default a quarter of the lowest mode) that
removes the integration drift; a zero-phase linear filter commutes with differentiation, so
``x, v, a`` stay consistent. A velocity channel is integrated once and differentiated
(:func:`eddi.calculus.differentiate`); a displacement channel differentiated twice.

The impact is where the force exceeds ``force_sigmas`` times its noise before the trigger;
the free window runs from the end of the impact to where the largest channel's envelope
(one-cycle running maximum) falls below ``noise_factor`` times its noise, and at the latest
:data:`EDGE_PERIODS` periods of the high-pass's cut-off before the record's end (session 8: the
backward pass of the zero-phase filter starts there; a lightly damped record whose envelope never
fell below the noise kept that transient in its window: the modal damping of a 0.4 % mode came out
negative, and a three-mass chain's true model predicted its own conditioned record to 7 % nrmse
instead of 0.2 %).
"""

from __future__ import annotations

import functools

from dataclasses import dataclass

import numpy as np
from scipy import ndimage, signal

from eddi.calculus import differentiate, integrate
from eddi.errors import SignalError

#: Drift-removal cut-off [Hz] of a record made without :func:`kinematics` (a :class:`ChannelRecord`'s
#: default); :func:`kinematics` and the station use :func:`drift_cutoff_hz`.
HIGHPASS_HZ = 2.0
#: The free window ends at least this many periods of the drift high-pass's cut-off before the
#: record's end (the zero-phase filter's end transient, :func:`kinematics`).
EDGE_PERIODS = 2.5
#: :func:`lowest_mode_hz` resolves its lowest peak with at least this many Welch bins below it.
RESOLVE_BINS = 8


@dataclass(frozen=True)
class Kinematics:
    """``x, v, a`` of every channel, each (n_channels, n), the record's windows, the cut-off used;
    ``noise`` the displacement noise (the measured noise scaled by the channel's own window's RMS ratio
    of displacement to the measured quantity), ``measured_noise`` the noise RMS of the measured quantity
    itself (its units, per channel; None when not read)."""

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    impact: tuple[int, int]
    window: tuple[int, int]
    noise: np.ndarray
    highpass_hz: float
    measured_noise: np.ndarray | None = None


def lowest_mode_hz(y: np.ndarray, rate_hz: float, quantity: str, rel: float = 0.02) -> float:
    """Lowest spectral peak of the velocity of any channel [Hz] (Welch; peaks above ``rel`` of the largest).

    Parameters
    ----------
    y : ndarray, shape (n_channels, n)
    rate_hz : float
    quantity : {"acc", "vel", "disp"}
    """
    nper = int(min(y.shape[1], max(256, 2 ** int(np.log2(max(rate_hz, 256))))))
    f0 = _resolved_peak_hz(y, rate_hz, quantity, rel, nper, _lowest_peak_hz(y, rate_hz, quantity, rel, nper))
    # a maximum in the first Welch bin is a mode only when longer segments resolve it there (EDGE_REACH)
    edge = _lowest_peak_hz(y, rate_hz, quantity, rel, nper, edge=True)
    if edge < f0 and y.shape[1] > nper:
        resolved = _resolved_peak_hz(y, rate_hz, quantity, rel, nper, edge)
        if resolved < EDGE_REACH * edge:
            f0 = resolved
    return f0


#: :func:`lowest_mode_hz`: a maximum in the first Welch bin (frequency ``f_b``, the bin width) counts
#: as the lowest mode when the longer segments' lowest peak lies below this many ``f_b``: a Hann window
#: puts a mode between bins 1 and 2 into bin 1 when it is below 1.5 ``f_b`` (its main lobe spans
#: +-2 bins). Session 20 (s20weak): bench_mdof_fast's h2-lin (2.6 Hz mode, 1.63 Hz bins at 1667 Hz)
#: lost its first mode (the edge skipped; drift cut-off 3.66 Hz above the mode, its fit 20 % low);
#: counting every edge maximum also counted the 1/f^2-weighted slow content of the drift band
#: and of the rig ``nes`` sink's gliding motion (first bin 1.5-8 % of the largest on most rig
#: channels), whose longer segments resolve no peak there (the sink's lowest 7.3 Hz, the rig
#: two-mass chains' 23-25 Hz): those edges are not modes.
EDGE_REACH = 2.0


def _resolved_peak_hz(y: np.ndarray, rate_hz: float, quantity: str, rel: float, nper: int, f0: float) -> float:
    """:func:`_lowest_peak_hz` again on segments long enough for :data:`RESOLVE_BINS` bins below the
    peak ``f0`` found at ``nper`` (twice at most; when the record holds them)."""
    # a peak a few bins above 0 is not resolved (Welch's 1 Hz bins at 1 s segments put a 2 Hz mode
    # next to the leakage of bin 1 and returned the 4.8 Hz mode above it)
    for _ in range(2):
        need = 2 ** int(np.ceil(np.log2(RESOLVE_BINS * rate_hz / max(f0, 1e-9))))
        if need <= nper or y.shape[1] <= nper:
            break
        nper = int(min(need, y.shape[1]))
        f0 = _lowest_peak_hz(y, rate_hz, quantity, rel, nper)
    return f0


def _lowest_peak_hz(y: np.ndarray, rate_hz: float, quantity: str, rel: float, nper: int, edge: bool = False) -> float:
    """:func:`lowest_mode_hz` at one Welch segment length (``edge``: a maximum in the first bin counts).

    A peak counts only where the measured quantity's spectrum stands :data:`PEAK_OVER_NOISE` times
    above its white noise (:func:`white_density`; when the record leaves a band to read it in).
    Weighted as a velocity, white acceleration noise rises as ``1 / f^2``: on a record that rings
    for a tenth of its length (a 87 Hz mode at 2 % in 4 s, a 10.8 Hz mode at 0.27 % in 10 s) a
    noise bump at 1-2 Hz stood above 2 % of the largest peak and was taken as the lowest mode; the
    drift cut-off then fell to the record's floor (0.5-1.25 Hz), the doubly integrated noise
    swamped the displacement (the true model's own nrmse 0.4-0.8), the noise floor rose with it
    (0.6-0.96) and a linear model 1.7 off was called ``none`` (session 12).
    """
    f, p = signal.welch(y, fs=rate_hz, nperseg=nper, axis=1)
    f, p = f[1:], p[:, 1:]
    dens = white_density(f, p, rate_hz)
    stands = np.any(p > PEAK_OVER_NOISE * dens[:, None], axis=0) if dens is not None else np.ones(f.size, bool)
    p = np.max(p, axis=0)
    w = 2 * np.pi * f
    p = p / w**2 if quantity == "acc" else (p * w**2 if quantity == "disp" else p)
    p[f < 1.0] = 0.0
    if np.any(p[stands] > 0):
        p = np.where(stands, p, 0.0)
    # find_peaks skips an edge: a maximum in the first bin counts only with ``edge`` (lowest_mode_hz
    # then checks it on longer segments, EDGE_REACH)
    height = rel * float(p.max())
    peaks, _ = signal.find_peaks(p, height=height)
    if edge and p.size > 1 and p[0] > p[1] and p[0] >= height and p[0] > 0:
        return float(f[0])
    return float(f[peaks[0]]) if peaks.size else float(f[int(np.argmax(p))])


#: A spectral peak counts as a mode (:func:`lowest_mode_hz`) where the measured quantity's power
#: density is at least this many times its white noise's (as :mod:`eddi.mdof.rate` reads the highest).
PEAK_OVER_NOISE = 10.0
#: The band [fraction of the sample rate] where :func:`white_density` reads the white noise: above
#: the modes (the station works at >= 32 samples per period of the highest mode, so its cubic tones
#: are below an eighth of the rate) and below an acquisition's anti-alias roll-off.
NOISE_BAND = (0.125, 0.4)


def white_density(f: np.ndarray, p: np.ndarray, rate_hz: float) -> np.ndarray | None:
    """Per channel, the one-sided power density of the white measurement noise: the median of the
    Welch density ``p`` (channels x ``f``) over :data:`NOISE_BAND`; None when the band holds fewer
    than 4 bins. White noise of RMS ``s`` has the density ``2 s^2 / rate``."""
    band = (f >= NOISE_BAND[0] * rate_hz) & (f <= NOISE_BAND[1] * rate_hz)
    if np.count_nonzero(band) < 4:
        return None
    return np.median(p[:, band], axis=1)


def white_noise_rms(y: np.ndarray, rate_hz: float) -> np.ndarray | None:
    """Per channel, the RMS of the white measurement noise read from the spectrum of ``y``
    (channels x samples) above the modes (:func:`white_density`); None when it cannot be read.
    The median of Welch's density over 50 %-overlapping Hann segments is within a few per cent of
    the mean for the hundreds of bins of the band."""
    y = np.atleast_2d(np.asarray(y, float))
    if y.shape[1] < 64:
        return None
    nper = int(min(y.shape[1], 256))
    f, p = signal.welch(y, fs=rate_hz, nperseg=nper, axis=1)
    dens = white_density(f[1:], p[:, 1:], rate_hz)
    return None if dens is None else np.sqrt(dens * rate_hz / 2.0)


def drift_cutoff_hz(lowest_hz: float, duration_s: float | None = None) -> float:
    """Cut-off of the drift high-pass [Hz]: a quarter of the lowest mode ``lowest_hz``.

    No floor in hertz (session 10): the former ``max(2 Hz, f_1 / 4)`` put the cut-off at or above
    a slow structure's first mode (2 Hz on a 2 Hz mode: the zero-phase pass twice keeps 25 % of
    that mode's displacement), and what identification restores from its first-pass receptance
    (:func:`quasi_static`) then carries that model's own error: on a 400 / 150 kg chain with
    modes at 2 and 4.8 Hz (0.3 %) the model's first mode came out at 1.7 % damping and 0.7-0.9
    held-out nrmse. What sets the doubly integrated noise is the ratio ``f_1 / f_c``, not the
    hertz. The one floor left is the record: the window ends :data:`EDGE_PERIODS` cut-off periods
    before the record's end, so the cut-off keeps that under half of ``duration_s`` [s].
    """
    cut = 0.25 * float(lowest_hz)
    if duration_s is not None and duration_s > 0:
        cut = max(cut, 2.0 * EDGE_PERIODS / float(duration_s))
    return cut


def impact_window(force: np.ndarray, rest: int, force_sigmas: float = 8.0) -> tuple[int, int]:
    """``[start, end)`` of the first hammer pulse (``(0, 0)`` when none is found)."""
    f = np.asarray(force, float)
    base = f[:rest] if rest >= 8 else f[: max(16, f.size // 50)]
    f = f - float(np.median(base))
    sigma = float(np.std(base)) or 1e-12
    thr = max(force_sigmas * sigma, 0.01 * float(np.max(np.abs(f))))
    above = np.nonzero(np.abs(f) > thr)[0]
    if above.size == 0:
        return 0, 0
    start = int(above[0])
    gaps = np.nonzero(np.diff(above) > 1)[0]
    end = int(above[gaps[0]] if gaps.size else above[-1]) + 1
    return max(start - 1, 0), min(end + 1, f.size)


def motion_from_acc(a: np.ndarray, dt: float, sos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and displacement of every acceleration channel ``a`` (n_channels, n): each integral
    high-passed zero-phase from rest by ``sos`` (the drift removal of :func:`kinematics`)."""
    v = _filtfilt_from_rest(sos, np.array([integrate(c, dt) for c in a]))
    x = _filtfilt_from_rest(sos, np.array([integrate(c, dt) for c in v]))
    return v, x


def kinematics(t: np.ndarray, y: np.ndarray, quantity: str, *, force: np.ndarray | None = None,
               rest: int = 0, highpass_hz: float | None = None, noise_factor: float = 10.0,
               period_s: float = 0.05) -> Kinematics:
    """Integrate / differentiate every channel and find the windows (module docstring).

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    y : ndarray, shape (n_channels, n)
        Measured acceleration [m/s^2], velocity [m/s] or displacement [m].
    quantity : {"acc", "vel", "disp"}
    force : ndarray, shape (n,), optional
    rest : int
        Samples of rest before the trigger.
    highpass_hz : float, optional
        Drift-removal cut-off [Hz]; default :func:`drift_cutoff_hz` (a quarter of the lowest
        spectral peak, :func:`lowest_mode_hz`). The doubly integrated noise
        grows as ``1 / f_c^3``: at 2 Hz under a 25 Hz mode it was 6 % of the displacement of a
        45 dB record (measured), at ``f_1 / 4`` below 1 %.
    noise_factor : float
    period_s : float
        Longest period of interest [s] (envelope smoothing).
    """
    y = np.atleast_2d(np.asarray(y, float))
    dt = float((t[-1] - t[0]) / (t.size - 1))
    rate = 1.0 / dt
    if quantity not in ("acc", "vel", "disp"):
        raise SignalError(f"quantity must be acc, vel or disp, got {quantity!r}")
    impact = impact_window(force, rest) if force is not None else (0, 0)
    if highpass_hz is None:
        highpass_hz = drift_cutoff_hz(lowest_mode_hz(y[:, impact[1]:], rate, quantity),
                                      (t.size - impact[1]) * dt)
    start = impact[0] if impact[1] > 0 else 0
    sos = signal.butter(4, highpass_hz, btype="highpass", fs=rate, output="sos")
    y0 = y - (np.median(y[:, :rest], axis=1, keepdims=True) if rest > 8 else 0.0)
    if start > 0:
        y0[:, :start] = 0.0
    if quantity == "acc":
        a = y0
        v, x = motion_from_acc(a, dt, sos)
    elif quantity == "vel":
        v = _filtfilt_from_rest(sos, y0)
        x = _filtfilt_from_rest(sos, np.array([integrate(c, dt) for c in v]))
        a = np.array([differentiate(c, dt) for c in v])
    else:
        x = _filtfilt_from_rest(sos, y0)
        v = np.array([differentiate(c, dt) for c in x])
        a = np.array([differentiate(c, dt) for c in v])
    meas = {"acc": a, "vel": v, "disp": x}[quantity]
    if rest >= 8:
        noise = np.std(y[:, :rest], axis=1)
    else:  # the record's end, unless it still rings: then the white noise above the modes (session 12)
        noise = np.std(meas[:, -max(16, t.size // 20):], axis=1)
        white = white_noise_rms(meas[:, impact[1]:], rate) if quantity == "acc" else None
        if white is not None:
            noise = np.minimum(noise, np.maximum(white, 1e-300))
    win = max(3, int(period_s * rate))
    env = ndimage.maximum_filter1d(np.abs(meas), win, axis=1) / np.maximum(noise, 1e-300)[:, None]
    loud = np.nonzero(np.max(env, axis=0) > noise_factor)[0]
    free0 = impact[1] if impact[1] > 0 else int(np.argmax(np.max(np.abs(meas), axis=0)))
    stop = int(loud[-1]) + 1 if loud.size and loud[-1] > free0 + 10 else t.size
    # the zero-phase high-pass's backward pass starts at the record's end: its transient there
    # (measured on a lightly damped pair, f_c 5 Hz: x 54 % off in the last 0.06 s, 13 % at
    # 0.2 s, 2 % at 0.45 s) is no free response; a window that reaches the end stops before it
    stop = max(min(stop, t.size - int(EDGE_PERIODS * rate / highpass_hz)), min(stop, free0 + 10))
    # noise of the displacement: scale the measured noise by the dominant frequency
    scale = np.sqrt(np.mean(x[:, free0:stop] ** 2, axis=1)) / np.maximum(np.sqrt(np.mean(meas[:, free0:stop] ** 2, axis=1)), 1e-300)
    return Kinematics(x, v, a, impact, (free0, stop), noise * scale, float(highpass_hz), noise)


def highpass(y: np.ndarray, rate_hz: float, highpass_hz: float, times: int = 1) -> np.ndarray:
    """The zero-phase drift high-pass of :func:`kinematics`, along the last axis, ``times`` times.

    A signal at rest at its first sample is extended by :data:`REST_PAD` zeros once, before the
    first pass, and every pass runs on the extended signal. Before session 11 each pass decided
    alone: the first pass's backward sweep leaves the output nonzero before the blow, so the second
    pass took ``sosfiltfilt``'s odd extension, which with fewer than 16 samples before the blow
    mirrors the blow's rise in front of the record - while the measured displacement (integrated
    from zero, :func:`kinematics`) is extended by zeros at both passes. The two sides then differed:
    a 356 + 264 kg chain at 2.66 Hz, 1000 Hz, the true model's simulation against its own
    noise-free record at the driving point, 0.030 / 0.019 / 0.008 / 0.0004 nrmse with 8 / 10 / 12 /
    16 samples of rest; now 0.0004 with each.
    """
    sos = _highpass_sos(float(highpass_hz), float(rate_hz)).copy()
    y = np.asarray(y, float)
    if times < 1:
        return y
    if y.shape[-1] == 0 or np.any(y[..., 0] != 0.0):
        for _ in range(times):
            y = signal.sosfiltfilt(sos, y, axis=-1)
        return y
    z = np.concatenate([np.zeros(y.shape[:-1] + (REST_PAD,)), y], axis=-1)
    for _ in range(times):
        z = signal.sosfiltfilt(sos, z, axis=-1)
    return z[..., REST_PAD:]


#: Zeros put before a signal that starts at rest (:func:`_filtfilt_from_rest`), more than
#: ``sosfiltfilt``'s pad of a 4th-order design (15 samples).
REST_PAD = 64


def _filtfilt_from_rest(sos: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``sosfiltfilt`` along the last axis; a signal whose first sample is 0 on every row (at rest
    before the blow) is extended by zeros instead of ``sosfiltfilt``'s odd extension.

    With 16 or more samples of rest the two are the same; with fewer (a 50 ms pre-trigger at
    256 Hz holds 13) the odd extension mirrors the blow's velocity step in front of the record,
    and at a low cut-off its transient lasts seconds: the driving point's displacement of a
    1.5 Hz chain (cut-off 0.375 Hz) was 24 % off the filtered truth over the free window.
    """
    y = np.asarray(y, float)
    if y.shape[-1] == 0 or np.any(y[..., 0] != 0.0):
        return signal.sosfiltfilt(sos, y, axis=-1)
    pad = np.zeros(y.shape[:-1] + (REST_PAD,))
    return signal.sosfiltfilt(sos, np.concatenate([pad, y], axis=-1), axis=-1)[..., REST_PAD:]


@functools.lru_cache(maxsize=64)
def _highpass_sos(highpass_hz: float, rate_hz: float) -> np.ndarray:
    """The 4th-order Butterworth high-pass sections (cached: the design cost as much as the filtering,
    and a polish filters every simulation with the same few designs)."""
    sos = signal.butter(4, highpass_hz, btype="highpass", fs=rate_hz, output="sos")
    return sos


def quasi_static(force: np.ndarray, rate_hz: float, receptance, highpass_hz: float = HIGHPASS_HZ
                 ) -> tuple[np.ndarray, np.ndarray]:
    """What the drift high-pass removed from ``x`` and ``v``: the slow response to the impact.

    The high-pass also removes the part of the true displacement that follows the
    low-frequency content of the impact force: about ``2 f_c / f_1`` of the first mode's
    amplitude (3 % at 2 Hz and 23 Hz). It is put back from the linear model:
    ``x_low = IFFT[(1 - |HP|^4) H(f) F(f)]`` and ``v_low = IFFT[(1 - |HP|^2) i w H(f) F(f)]``
    (``v`` went through the zero-phase high-pass once, ``x`` twice, as :func:`kinematics`
    integrates the filtered velocity; ``|HP|^2 = 1 / (1 + (f_c / f)^8)`` for the 4th-order
    Butterworth run forward and backward; ``H`` the receptance of every channel at the
    driving point). Exact for a linear structure; the slow part of nonlinear forces is not
    restored.

    Parameters
    ----------
    force : ndarray, shape (n,), [N]
    rate_hz : float
    receptance : callable
        ``receptance(freqs_hz) -> ndarray (n_channels, n_freqs)`` complex [m/N].
    highpass_hz : float

    Returns
    -------
    x_low, v_low : ndarray, shape (n_channels, n)
    """
    f = np.asarray(force, float)
    n = f.size
    m = 1 << int(np.ceil(np.log2(2 * n)))
    freqs = np.fft.rfftfreq(m, 1.0 / rate_hz)
    spec = np.fft.rfft(f, m)
    ratio = highpass_hz / np.maximum(freqs, 1e-12 * highpass_hz)
    hp2 = np.where(ratio < 1e30, 1.0 / (1.0 + np.minimum(ratio, 1e30) ** 8), 0.0)
    band = (1.0 - hp2) > 1e-9
    hb = np.asarray(receptance(freqs[band]), complex)
    h = np.zeros((hb.shape[0], freqs.size), complex)
    h[:, band] = hb
    w = 2j * np.pi * freqs
    x_low = np.fft.irfft(h * ((1.0 - hp2**2) * spec)[None, :], m, axis=1)[:, :n]
    v_low = np.fft.irfft(h * ((1.0 - hp2) * w * spec)[None, :], m, axis=1)[:, :n]
    return x_low, v_low
