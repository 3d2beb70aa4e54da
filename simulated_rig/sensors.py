"""Sensor and ADC models: noise, IEPE AC coupling, range, quantisation and clipping.

What a channel measures, in this order:

1. the true signal (force [N] or acceleration [m/s^2]);
2. IEPE AC coupling, when enabled: a first-order high-pass at ``iepe_highpass_hz``
   (bilinear transform of ``s / (s + 2 pi f_c)``, starting from rest);
3. mains interference, when enabled (``mains_si`` > 0): a tone picked up by the cable or the
   conditioner, ``mains_si cos(2 pi mains_hz t + phase)`` plus harmonics ``k mains_hz`` of
   relative amplitudes ``mains_harmonics`` (k = 2, 3, ...), phase-continuous over the whole
   capture, pre-trigger included (:func:`mains_tone`);
4. additive white Gaussian noise of standard deviation ``sigma``;
5. the ADC: ``counts = round(value / scale)`` with ``scale = range_si / 2^(adc_bits - 1)``,
   clipped to ``[-2^(bits-1), 2^(bits-1) - 1]``; a value beyond the range *clips*.

Noise level. Either absolute (``noise_rms_si``), or as a signal-to-noise ratio::

    snr_db = 20 log10(rms_active / sigma)

where ``rms_active`` is the RMS of the noise-free (AC-coupled) signal over its *active
window*: the post-trigger samples up to the one by which 99 % of the signal's energy (sum of
squares) has arrived (:func:`active_rms`). For the force that window is the hammer pulse; for
the acceleration it is the ring-down until it has mostly died out. The definition does not
depend on the record length as long as the record holds the ring-down.

Range. ``range_si`` when given; otherwise ``range_headroom`` (1.5) times the peak of the
noise-free signal, so an automatic range never clips.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import signal as sps

from drivers.channels import QUANTITY_UNITS, ChannelInfo
from simulated_rig.errors import ScenarioError

#: Fraction of the energy that defines the active window of :func:`active_rms`.
ACTIVE_ENERGY_FRACTION = 0.99


@dataclass(frozen=True)
class SensorSpec:
    """One sensor and its ADC channel.

    Attributes
    ----------
    name : str
        Channel name (``"force"``, ``"acc"``).
    quantity : str
        ``"force"`` or ``"acceleration"`` (see :data:`drivers.channels.QUANTITY_UNITS`).
    sensitivity : float
        Calibration-sheet sensitivity (metadata: the model works in SI units).
    sensitivity_unit : str
        Its unit (``"mV/N"``, ``"mV/(m/s^2)"``).
    snr_db : float or None
        Signal-to-noise ratio [dB] as defined in the module docstring; None for no noise.
    noise_rms_si : float or None
        Absolute noise standard deviation [SI]; overrides ``snr_db`` when given.
    range_si : float or None
        Full scale [SI]; None for automatic (``range_headroom`` times the peak).
    range_headroom : float
        Automatic range over the peak of the noise-free signal.
    adc_bits : int
        16 or 24.
    iepe_highpass_hz : float or None
        Corner of the IEPE AC coupling [Hz]; None for DC coupling.
    mains_si : float
        Amplitude (peak) of a mains tone on the channel [SI]; 0 for none.
    mains_hz : float
        Its frequency [Hz] (the grid's 50 or 60 Hz, or a drifted value).
    mains_phase_rad : float or None
        Its phase at t = 0 (the trigger); None: drawn from the capture's seed (the grid is not
        synchronous with the blow).
    mains_harmonics : tuple of float
        Amplitudes of harmonics 2, 3, ... relative to the fundamental (each at a phase of its own
        drawn from the seed, or ``k`` times the fundamental's when that is given).
    """

    name: str
    quantity: str
    sensitivity: float = 1.0
    sensitivity_unit: str = ""
    snr_db: float | None = 45.0
    noise_rms_si: float | None = None
    range_si: float | None = None
    range_headroom: float = 1.5
    adc_bits: int = 24
    iepe_highpass_hz: float | None = None
    mains_si: float = 0.0
    mains_hz: float = 50.0
    mains_phase_rad: float | None = None
    mains_harmonics: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        where = f"sensors.{self.name}"
        if self.quantity not in QUANTITY_UNITS:
            raise ScenarioError(f"{where}.quantity: unknown {self.quantity!r}; known: "
                                f"{', '.join(QUANTITY_UNITS)}")
        if self.adc_bits not in (16, 24):
            raise ScenarioError(f"{where}.adc_bits: must be 16 or 24, got {self.adc_bits}")
        if self.snr_db is not None and not (0.0 <= self.snr_db <= 200.0):
            raise ScenarioError(f"{where}.snr_db: must be in [0, 200] dB, got {self.snr_db}")
        if self.noise_rms_si is not None and not (self.noise_rms_si >= 0 and math.isfinite(self.noise_rms_si)):
            raise ScenarioError(f"{where}.noise_rms_si: must be >= 0, got {self.noise_rms_si}")
        if self.range_si is not None and not (self.range_si > 0 and math.isfinite(self.range_si)):
            raise ScenarioError(f"{where}.range_si: must be > 0, got {self.range_si}")
        if not (self.range_headroom >= 1.0):
            raise ScenarioError(f"{where}.range_headroom: must be >= 1, got {self.range_headroom}")
        if self.iepe_highpass_hz is not None and not (0.0 < self.iepe_highpass_hz <= 100.0):
            raise ScenarioError(f"{where}.iepe_highpass_hz: must be in (0, 100] Hz, "
                                f"got {self.iepe_highpass_hz}")
        if not (self.mains_si >= 0 and math.isfinite(self.mains_si)):
            raise ScenarioError(f"{where}.mains_si: must be >= 0, got {self.mains_si}")
        if not (0.0 < self.mains_hz <= 1000.0):
            raise ScenarioError(f"{where}.mains_hz: must be in (0, 1000] Hz, got {self.mains_hz}")
        if not all(math.isfinite(h) and h >= 0 for h in self.mains_harmonics):
            raise ScenarioError(f"{where}.mains_harmonics: must be >= 0, got {self.mains_harmonics}")
        if self.mains_phase_rad is not None and not math.isfinite(self.mains_phase_rad):
            raise ScenarioError(f"{where}.mains_phase_rad: must be finite, got {self.mains_phase_rad}")
        if not (self.sensitivity > 0):
            raise ScenarioError(f"{where}.sensitivity: must be > 0, got {self.sensitivity}")

    @property
    def unit(self) -> str:
        """SI unit of the channel."""
        return QUANTITY_UNITS[self.quantity]

    def channel_info(self, range_si: float) -> ChannelInfo:
        """The ADC channel for a resolved full scale ``range_si`` [SI]."""
        return ChannelInfo(
            name=self.name,
            quantity=self.quantity,
            unit=self.unit,
            scale=range_si / float(1 << (self.adc_bits - 1)),
            offset=0.0,
            range_si=range_si,
            adc_bits=self.adc_bits,
            sensitivity=self.sensitivity,
            sensitivity_unit=self.sensitivity_unit,
        )

    def resolved(self, clean: np.ndarray, trigger_index: int = 0) -> "SensorSpec":
        """A copy with absolute noise and range fixed from a noise-free signal.

        Parameters
        ----------
        clean : ndarray, shape (n,), [SI]
            Noise-free signal as the sensor sees it (after AC coupling).
        trigger_index : int
            First post-trigger sample (start of the active window).
        """
        sigma = self.noise_rms_si
        if sigma is None:
            sigma = 0.0 if self.snr_db is None else active_rms(clean[trigger_index:]) / 10 ** (self.snr_db / 20)
        rng = self.range_si
        if rng is None:
            peak = float(np.max(np.abs(clean))) if clean.size else 0.0
            rng = self.range_headroom * peak if peak > 0 else 1.0
        return replace(self, noise_rms_si=float(sigma), range_si=float(rng))


#: Default noise of the force channel [N rms]. Our choice: a hammer's noise floor does not
#: scale with the blow, and a force noise proportional to the peak (45 dB below a 600 N
#: pulse is 2.5 N rms) would shake the oscillator for the whole record.
FORCE_NOISE_RMS_N = 0.01


def force_sensor(**kwargs: object) -> SensorSpec:
    """The force channel: a PCB 086C03-like hammer (2.25 mV/N; paper Sec. 3.3.1 names the
    model), noise :data:`FORCE_NOISE_RMS_N` unless ``snr_db`` or ``noise_rms_si`` is given."""
    base: dict[str, object] = dict(name="force", quantity="force", sensitivity=2.25,
                                   sensitivity_unit="mV/N", snr_db=None,
                                   noise_rms_si=FORCE_NOISE_RMS_N)
    if "snr_db" in kwargs and "noise_rms_si" not in kwargs:
        base["noise_rms_si"] = None
    base.update(kwargs)
    return SensorSpec(**base)  # type: ignore[arg-type]


def accelerometer(**kwargs: object) -> SensorSpec:
    """The acceleration channel: 1 mV/(m/s^2) nominal (PCB 353B15, paper Sec. 3.3.1)."""
    base: dict[str, object] = dict(name="acc", quantity="acceleration", sensitivity=1.0,
                                   sensitivity_unit="mV/(m/s^2)", snr_db=45.0)
    base.update(kwargs)
    return SensorSpec(**base)  # type: ignore[arg-type]


def active_window(clean: np.ndarray, fraction: float = ACTIVE_ENERGY_FRACTION) -> int:
    """Number of leading samples holding ``fraction`` of the signal's energy.

    Parameters
    ----------
    clean : ndarray, shape (n,)
        Noise-free signal from the trigger on.

    Returns
    -------
    int
        At least 1 (0 for an empty signal).
    """
    e = np.cumsum(np.asarray(clean, dtype=float) ** 2)
    if e.size == 0:
        return 0
    if e[-1] <= 0:
        return int(e.size)
    return int(np.searchsorted(e, fraction * e[-1]) + 1)


def active_rms(clean: np.ndarray, fraction: float = ACTIVE_ENERGY_FRACTION) -> float:
    """RMS of a noise-free signal over its active window (see the module docstring).

    Parameters
    ----------
    clean : ndarray, shape (n,)
        Noise-free signal from the trigger on.
    """
    n = active_window(clean, fraction)
    if n == 0:
        return 0.0
    c = np.asarray(clean[:n], dtype=float)
    return float(np.sqrt(np.mean(c**2)))


def mains_tone(spec: SensorSpec, t: np.ndarray, seed: int = 0) -> np.ndarray:
    """The mains tone a channel picks up [SI], shape of ``t`` [s] (0 without one): the
    fundamental at ``spec.mains_hz`` and its harmonics (module docstring, step 3)."""
    t = np.asarray(t, dtype=float)
    if not spec.mains_si > 0:
        return np.zeros_like(t)
    # a stream of its own: the noise draws of a capture do not change with the tone
    rng = np.random.default_rng([int(seed), 5060])
    draws = rng.uniform(0.0, 2 * math.pi, 1 + len(spec.mains_harmonics))
    phase = spec.mains_phase_rad
    out = np.zeros_like(t)
    for k, rel in enumerate((1.0,) + tuple(spec.mains_harmonics), start=1):
        ph = float(draws[k - 1]) if phase is None else k * float(phase)
        out += spec.mains_si * rel * np.cos(2 * math.pi * k * spec.mains_hz * t + ph)
    return out


def iepe_filter(cutoff_hz: float, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """First-order high-pass ``(b, a)`` of an IEPE AC coupling (bilinear, prewarped)."""
    return sps.butter(1, cutoff_hz, btype="highpass", fs=rate_hz)


def ac_couple(x: np.ndarray, cutoff_hz: float | None, rate_hz: float) -> np.ndarray:
    """Apply the IEPE high-pass from rest (identity when ``cutoff_hz`` is None).

    Parameters
    ----------
    x : ndarray, shape (n,), [SI]
    cutoff_hz : float or None
    rate_hz : float

    Returns
    -------
    ndarray, shape (n,), [SI]
    """
    if cutoff_hz is None:
        return np.asarray(x, dtype=float)
    b, a = iepe_filter(cutoff_hz, rate_hz)
    return sps.lfilter(b, a, np.asarray(x, dtype=float))
