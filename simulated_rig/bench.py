"""One impact test on the simulated rig, as a complete record in memory.

:func:`impact_test` hits a system with the hammer (:mod:`simulated_rig.hammer`), integrates
its true equation of motion from rest over the whole record with :func:`eddi.simulate.simulate`
(driven by the sampled force, interpolated linearly between samples), and measures force and
acceleration through the sensor and ADC models of :mod:`simulated_rig.sensors`.

Time base: ``t[i] = (i - pretrigger_samples) / rate_hz``, so the record starts at
``-pretrigger_s`` and the hammer pulse starts exactly at ``t = 0`` (sample
``pretrigger_samples``).

Noise is drawn as ``numpy.random.default_rng(seed).standard_normal((n, 2))`` (column 0 the
force, column 1 the acceleration) times each channel's sigma, so the live
:class:`simulated_rig.source.RigSource` can reproduce it sample for sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterable, Mapping

import numpy as np

from drivers.channels import ChannelInfo
from eddi.model import Effect, EquationOfMotion
from eddi.simulate import SimulationResult, simulate
from simulated_rig.errors import ScenarioError
from simulated_rig.hammer import HammerSpec, hammer_force
from simulated_rig.sensors import SensorSpec, ac_couple, accelerometer, force_sensor, mains_tone
from simulated_rig.systems import system_info


@dataclass(frozen=True)
class ImpactRecord:
    """A simulated impact test: what the DAQ measured and the exact truth.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
        Starts at ``-pretrigger_s``; the pulse starts at 0.
    force_n : ndarray, shape (n,), [N]
        Measured force (noisy, quantised, clipped if beyond range).
    acc_m_s2 : ndarray, shape (n,), [m/s^2]
        Measured acceleration (noisy, quantised, clipped, AC-coupled if the sensor is IEPE).
    counts : ndarray, shape (n, 2), int32
        Raw ADC counts, columns in the order of ``channels``.
    channels : tuple of ChannelInfo, length 2
        ``("force", "acc")``.
    rate_hz : float
    pretrigger_samples : int
    eom : EquationOfMotion
        The true physics, effects included.
    truth_x, truth_v, truth_a : ndarray, shape (n,)
        Exact displacement [m], velocity [m/s], acceleration [m/s^2].
    truth_force_n : ndarray, shape (n,), [N]
        Exact applied force.
    peak_force_n : float
        Requested peak of the (first) hammer pulse [N].
    clipped : tuple of str
        Names of the channels that clipped (empty when none did).
    sensors : tuple of SensorSpec
        The sensors with their noise and range resolved to absolute values.
    hammer : HammerSpec
    double_hit : bool
    seed : int
    """

    t: np.ndarray
    force_n: np.ndarray
    acc_m_s2: np.ndarray
    counts: np.ndarray
    channels: tuple[ChannelInfo, ...]
    rate_hz: float
    pretrigger_samples: int
    eom: EquationOfMotion
    truth_x: np.ndarray
    truth_v: np.ndarray
    truth_a: np.ndarray
    truth_force_n: np.ndarray
    peak_force_n: float
    clipped: tuple[str, ...]
    sensors: tuple[SensorSpec, ...]
    hammer: HammerSpec
    double_hit: bool
    seed: int

    def __post_init__(self) -> None:
        n = self.t.shape[0]
        for name in ("force_n", "acc_m_s2", "truth_x", "truth_v", "truth_a", "truth_force_n"):
            arr = getattr(self, name)
            if arr.shape != (n,):
                raise ValueError(f"ImpactRecord.{name} has shape {arr.shape}; expected ({n},)")
        if self.counts.shape != (n, len(self.channels)):
            raise ValueError(f"ImpactRecord.counts has shape {self.counts.shape}; "
                             f"expected ({n}, {len(self.channels)})")
        for arr in (self.t, self.force_n, self.acc_m_s2, self.counts, self.truth_x, self.truth_v,
                    self.truth_a, self.truth_force_n):
            arr.setflags(write=False)

    @property
    def n_samples(self) -> int:
        """Samples in the record."""
        return int(self.t.shape[0])

    @property
    def noise_rms(self) -> dict[str, float]:
        """Noise standard deviation of each channel [SI]."""
        return {s.name: float(s.noise_rms_si or 0.0) for s in self.sensors}

    def channel(self, name: str) -> ChannelInfo:
        """The channel of that name."""
        for c in self.channels:
            if c.name == name:
                return c
        raise KeyError(name)


def resolve_system(system: str | EquationOfMotion) -> tuple[EquationOfMotion, float | None]:
    """The equation of motion and the suggested record length [s] (None if unknown)."""
    if isinstance(system, EquationOfMotion):
        return system, None
    info = system_info(system)
    return info.eom, info.record_s


def default_record_s(eom: EquationOfMotion) -> float:
    """A record length [s] that holds the ring-down: 7 linear time constants ``2m/b1``
    (amplitude down to ~1e-3), between 1 and 60 s; 10 s without linear damping."""
    b1 = float(eom.damping.get("v", 0.0))
    if b1 <= 0:
        return 10.0
    return float(min(60.0, max(1.0, 7.0 * 2.0 * eom.mass / b1)))


def with_effects(eom: EquationOfMotion,
                 effects: Iterable[Effect | Mapping[str, Any]]) -> EquationOfMotion:
    """``eom`` with the given effects added (an effect of the same name is replaced)."""
    for e in effects:
        eff = e if isinstance(e, Effect) else _make_effect(e)
        eom = eom.with_effect(eff)
    return eom


def _make_effect(spec: Mapping[str, Any]) -> Effect:
    try:
        return Effect(name=str(spec["name"]), params=dict(spec.get("params", {})))
    except KeyError:
        raise ScenarioError(f"effects: each effect needs a 'name'; got {dict(spec)}") from None
    except ValueError as exc:  # pydantic ValidationError is a ValueError
        msg = str(exc).splitlines()
        detail = msg[2].strip() if len(msg) > 2 else msg[0]
        raise ScenarioError(f"effects: {detail.removeprefix('Value error, ')}") from None


def default_sensors(snr_db: float | None = 45.0, adc_bits: int = 24,
                    force_snr_db: float | None = None) -> tuple[SensorSpec, SensorSpec]:
    """Force and acceleration sensors on the same ADC.

    ``snr_db`` sets the accelerometer's noise; the force channel has the absolute noise
    :data:`simulated_rig.sensors.FORCE_NOISE_RMS_N` unless ``force_snr_db`` is given;
    ``snr_db=None`` without ``force_snr_db`` gives noise-free channels (quantisation only).
    """
    if force_snr_db is not None:
        force = force_sensor(snr_db=force_snr_db, adc_bits=adc_bits)
    elif snr_db is None:  # a noise-free record
        force = force_sensor(noise_rms_si=0.0, adc_bits=adc_bits)
    else:
        force = force_sensor(adc_bits=adc_bits)
    return force, accelerometer(snr_db=snr_db, adc_bits=adc_bits)


def simulate_truth(eom: EquationOfMotion, force_n: np.ndarray, rate_hz: float,
                   x0: float = 0.0, v0: float = 0.0, substeps: int | None = None) -> SimulationResult:
    """Integrate ``eom`` under ``force_n`` (one sample per output); raise if it diverges.

    Returns
    -------
    eddi.simulate.SimulationResult
    """
    res = simulate(eom, rate_hz=rate_hz, n_samples=force_n.shape[0], force=force_n,
                   x0=x0, v0=v0, substeps=substeps)
    if res.diverged:
        peak = float(np.max(np.abs(force_n))) if force_n.size else 0.0
        raise ScenarioError(f"impacts: the system diverges under a {peak:.4g} N blow; "
                            "choose a smaller peak force")
    return res


def measure(sensors: tuple[SensorSpec, ...], clean: np.ndarray, normals: np.ndarray
            ) -> tuple[np.ndarray, tuple[ChannelInfo, ...], tuple[str, ...]]:
    """Add noise, quantise and clip.

    Parameters
    ----------
    sensors : tuple of SensorSpec, length c
        Resolved (absolute noise and range).
    clean : ndarray, shape (n, c), [SI]
        Noise-free signals as the sensors see them (after AC coupling).
    normals : ndarray, shape (n, c)
        Standard normal draws.

    Returns
    -------
    counts : ndarray, shape (n, c), int32
    channels : tuple of ChannelInfo
    clipped : tuple of str
        Channels with at least one clipped sample.
    """
    counts = np.empty(clean.shape, dtype=np.int32)
    channels = []
    clipped = []
    for j, s in enumerate(sensors):
        ch = s.channel_info(float(s.range_si))  # type: ignore[arg-type]
        value = clean[:, j] + float(s.noise_rms_si or 0.0) * normals[:, j]
        raw = np.rint(value / ch.scale)
        if np.any(raw > ch.max_count) or np.any(raw < ch.min_count):
            clipped.append(s.name)
        counts[:, j] = np.clip(raw, ch.min_count, ch.max_count).astype(np.int32)
        channels.append(ch)
    return counts, tuple(channels), tuple(clipped)


def impact_test(
    system: str | EquationOfMotion,
    peak_force_n: float,
    *,
    rate_hz: float = 19200.0,
    pretrigger_s: float = 1.0,
    record_s: float | None = None,
    snr_db: float | None = 45.0,
    force_snr_db: float | None = None,
    adc_bits: int = 24,
    sensors: tuple[SensorSpec, SensorSpec] | None = None,
    hammer: HammerSpec = HammerSpec(),
    double_hit: bool = False,
    effects: Iterable[Effect | Mapping[str, Any]] = (),
    seed: int = 0,
    base_motion: Mapping[str, float] | None = None,
) -> ImpactRecord:
    """Hit a system once and record force and acceleration.

    Parameters
    ----------
    system : str or EquationOfMotion
        A name of :data:`simulated_rig.systems.SYSTEMS` or a model.
    peak_force_n : float
        Peak of the hammer pulse [N] (> 0).
    rate_hz : float
        Sample rate [Hz] (19200 as in paper Sec. 3.3.1).
    pretrigger_s : float
        Record before the blow [s] (1 s in paper Sec. 3.3.1).
    record_s : float, optional
        Record after the blow [s]; default: the system's (45 s for ``duffing-smooth``, paper
        Sec. 3.3.1) or :func:`default_record_s`.
    snr_db : float or None
        SNR of the default accelerometer [dB] (definition in :mod:`simulated_rig.sensors`);
        None for a noise-free record (both channels, unless ``force_snr_db`` is given).
        Ignored when ``sensors`` is given.
    force_snr_db : float or None
        SNR of the default force sensor [dB]; None for its absolute noise floor
        (:data:`simulated_rig.sensors.FORCE_NOISE_RMS_N`). Ignored when ``sensors`` is given.
    adc_bits : int
        ADC resolution of both default sensors; ignored when ``sensors`` is given.
    sensors : (SensorSpec, SensorSpec), optional
        Force and acceleration sensors (names ``force`` and ``acc``).
    hammer : HammerSpec
    double_hit : bool
        Add a second, smaller pulse (see :class:`HammerSpec`).
    effects : iterable of Effect or {"name", "params"} mappings
        Hidden effects added to the system's physics.
    seed : int
        Seed of the noise.
    base_motion : mapping, optional
        A hidden measurement effect: the base the structure sits on moves as a rigid body on
        its own suspension (``mass_kg``, ``frequency_hz``, ``damping_ratio``), driven by the same
        blow; the accelerometer measures the structure's acceleration plus the base's.

    Returns
    -------
    ImpactRecord

    Raises
    ------
    ScenarioError
        Bad arguments, an unknown system, or a blow that makes the system diverge.
    """
    if not (math.isfinite(peak_force_n) and peak_force_n > 0):
        raise ScenarioError(f"peak_force_n: must be > 0, got {peak_force_n}")
    if not (100.0 <= rate_hz <= 1.0e6):
        raise ScenarioError(f"rate_hz: must be in [100, 1e6] Hz, got {rate_hz}")
    if not (0.0 <= pretrigger_s <= 60.0):
        raise ScenarioError(f"pretrigger_s: must be in [0, 60] s, got {pretrigger_s}")
    eom, suggested = resolve_system(system)
    eom = with_effects(eom, effects)
    if record_s is None:
        record_s = suggested if suggested is not None else default_record_s(eom)
    if not (0.0 < record_s <= 600.0):
        raise ScenarioError(f"record_s: must be in (0, 600] s, got {record_s}")
    if sensors is None:
        sensors = default_sensors(snr_db, adc_bits, force_snr_db)
    if tuple(s.name for s in sensors) != ("force", "acc"):
        raise ScenarioError(f"sensors: expected ('force', 'acc'), got {tuple(s.name for s in sensors)}")

    n_pre = int(round(pretrigger_s * rate_hz))
    n = n_pre + int(round(record_s * rate_hz))
    t = (np.arange(n) - n_pre) / rate_hz
    force = hammer_force(t, peak_force_n, hammer, double_hit)
    res = simulate_truth(eom, force, rate_hz)
    a_meas = res.a
    if base_motion:
        a_meas = res.a + base_acceleration(force, rate_hz, **base_motion)
    return _finish(eom, t, force, res.x, res.v, res.a, n_pre, rate_hz, sensors, hammer,
                   double_hit, seed, peak_force_n, a_meas=a_meas)


def base_acceleration(force: np.ndarray, rate_hz: float, *, mass_kg: float, frequency_hz: float,
                      damping_ratio: float = 0.05) -> np.ndarray:
    """Acceleration [m/s^2] of a rigid base of mass ``mass_kg`` on a linear suspension
    (``frequency_hz``, ``damping_ratio``) driven by ``force`` [N] (shape (n,))."""
    if not (mass_kg > 0 and frequency_hz > 0 and damping_ratio >= 0):
        raise ScenarioError(f"base_motion: mass_kg and frequency_hz must be > 0, damping_ratio >= 0; got "
                            f"{mass_kg}, {frequency_hz}, {damping_ratio}")
    w = 2 * math.pi * frequency_hz
    base = EquationOfMotion.create(mass=mass_kg, damping={"v": 2 * damping_ratio * w * mass_kg},
                                   stiffness={"x": mass_kg * w * w})
    return simulate_truth(base, force, rate_hz).a


def _finish(eom: EquationOfMotion, t: np.ndarray, force: np.ndarray, x: np.ndarray, v: np.ndarray,
            a: np.ndarray, n_pre: int, rate_hz: float, sensors: tuple[SensorSpec, ...],
            hammer: HammerSpec, double_hit: bool, seed: int, peak_force_n: float,
            a_meas: np.ndarray | None = None) -> ImpactRecord:
    """Measure the simulated truth through the sensors (all arrays shape (n,); ``a_meas``: the
    acceleration the accelerometer sees when it differs from the structure's, e.g. base motion)."""
    clean = np.column_stack([
        ac_couple(force, sensors[0].iepe_highpass_hz, rate_hz),
        ac_couple(a if a_meas is None else a_meas, sensors[1].iepe_highpass_hz, rate_hz),
    ])
    resolved = tuple(s.resolved(clean[:, j], n_pre) for j, s in enumerate(sensors))
    # mains pick-up after the sensor (cable, conditioner): not in the SNR's or the range's reference
    clean = clean + np.column_stack([mains_tone(s, t, seed) for s in resolved])
    normals = np.random.default_rng(seed).standard_normal((t.shape[0], 2))
    counts, channels, clipped = measure(resolved, clean, normals)
    return ImpactRecord(
        t=t,
        force_n=channels[0].to_si(counts[:, 0]),
        acc_m_s2=channels[1].to_si(counts[:, 1]),
        counts=counts,
        channels=channels,
        rate_hz=float(rate_hz),
        pretrigger_samples=n_pre,
        eom=eom,
        truth_x=x,
        truth_v=v,
        truth_a=a,
        truth_force_n=force,
        peak_force_n=float(peak_force_n),
        clipped=clipped,
        sensors=resolved,
        hammer=hammer,
        double_hit=bool(double_hit),
        seed=int(seed),
    )
