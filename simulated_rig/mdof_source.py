"""The live sample-time source of a multi-DOF rig system: one force and N accelerometers.

:class:`MdofRigSource` is :class:`simulated_rig.source.RigSource` for the systems of
:mod:`simulated_rig.mdof_systems` (``two-mass-cubic``, ``nes``, ``internal-1-3`` or a system
file): ``read(n)`` returns ADC counts of ``force, acc1..accN`` in sample time (no wall
clock), so the emulated firmware (:class:`simulated_rig.device.EmulatedDaq`) streams
``1 + N`` channels (a DATA frame names its channels in a 32-bit mask; the emulated firmware
takes up to 32). At rest the channels carry sensor noise; :meth:`MdofRigSource.deliver_impact`
schedules a hammer blow on the driving mass ``impact_delay_s`` after the current sample and
integrates the coupled equations (:func:`eddi.mdof.simulate.simulate_mdof`) one second at a
time from the state at the blow, continuing from the last state as the reads go on, until
every acceleration is below 1 % of its quantisation step; it then snaps to rest. A blow
during a ring-down is simulated from the current state.

Noise and ranges are fixed once: each sensor is resolved on the noise-free response to the
system's largest impact (as :func:`simulated_rig.mdof_systems.mdof_impact_test` does per
record, 45 dB SNR per accelerometer by default), so that blow never clips. The sensors are
DC-coupled (the MDOF systems model no IEPE coupling).

The source's ``scenario_json`` names the system, its impact levels (``impacts``, which
``station acquire`` uses for a simulated rig's blows) and the driving point (``driving_point``,
the accelerometer on the struck mass), so a capture knows where the hammer was.
"""

from __future__ import annotations

import json
import math

import numpy as np

from drivers.channels import ChannelInfo
from eddi.mdof.model import MdofModel
from eddi.mdof.simulate import simulate_mdof
from simulated_rig.bench import measure
from simulated_rig.errors import ScenarioError
from simulated_rig.hammer import HammerSpec, hammer_force
from simulated_rig.measured_channels import MeasuredChannels
from simulated_rig.mdof_systems import MdofSystem, load_mdof_system, mdof_impact_test
from simulated_rig.sensors import SensorSpec
from simulated_rig.source import IMPACT_DELAY_S  # the same delay as the 1-DOF rig's

#: Length of each simulated chunk of a ring-down [s].
CHUNK_S = 1.0


class MdofRigSource(MeasuredChannels):
    """Sample-time source of ``force, acc1..accN`` counts for the emulated DAQ.

    Parameters
    ----------
    system : MdofSystem
    sensors : tuple of SensorSpec
        Force first, then one accelerometer per channel of the model; resolved (absolute
        ``noise_rms_si`` and ``range_si``).
    model : MdofModel, optional
        Physics (default ``system.model()``).
    seed : int
        Seed of the noise (``default_rng(seed).standard_normal((n, 1 + N))`` per read).
    impact_delay_s : float

    Attributes
    ----------
    rate_hz : float
    channels : tuple of ChannelInfo
    scenario_json : str
    sample_index : int
    clip_counts : dict of str to int
    impacts : list of (int, float)
        Sample index of each pulse start and its peak force [N].
    """

    def __init__(self, system: MdofSystem, sensors: tuple[SensorSpec, ...], *, model: MdofModel | None = None,
                 seed: int = 0, impact_delay_s: float = IMPACT_DELAY_S) -> None:
        self.model = model if model is not None else system.model()
        if len(sensors) != 1 + len(self.model.channels):
            raise ScenarioError(f"{system.name}: expected a force sensor and {len(self.model.channels)} "
                                f"accelerometers, got {len(sensors)} sensors")
        for s in sensors:
            if s.noise_rms_si is None or s.range_si is None:
                raise ScenarioError(f"sensors.{s.name}: the source needs an absolute noise and range")
        self.system = system
        self.sensors = tuple(sensors)
        self.hammer = HammerSpec(tip=system.tip)
        self.seed = int(seed)
        self.impact_delay_s = float(impact_delay_s)
        self.channels: tuple[ChannelInfo, ...] = tuple(s.channel_info(float(s.range_si)) for s in sensors)
        self.sample_index = 0
        self.clip_counts = {s.name: 0 for s in sensors}
        self.impacts: list[tuple[int, float]] = []
        self._rng = np.random.default_rng(self.seed)
        n = self.model.n_coords
        # the simulated future from absolute sample _seg_start: force, channel accelerations, state
        self._force = np.zeros(0)
        self._acc = np.zeros((len(self.model.channels), 0))
        self._state = np.zeros((2 * n, 0))
        self._seg_start = 0
        self._substeps: int | None = None
        self._x_scale = np.ones(n)
        self.rate_hz = float(system.rate_hz)
        self.scenario_json = json.dumps({
            "system": system.name, "kind": "mdof", "description": system.description,
            "impacts": list(system.impacts_n), "driving_point": self.model.driving_point,
            "channels": list(self.model.channels), "rate_hz": self.rate_hz, "seed": self.seed,
            "model": json.loads(self.model.to_json(indent=None)),
            "source": {"noise_rms": self.noise_rms, "range_si": {c.name: c.range_si for c in self.channels},
                       "impact_delay_s": self.impact_delay_s,
                       "reference_force_n": float(max(system.impacts_n))},
        })

    @classmethod
    def from_system(cls, name: str, seed: int | None = None, snr_db: float | None = 45.0) -> "MdofRigSource":
        """A source for a built-in system name or a system file, sensors resolved on its largest impact."""
        system = load_mdof_system(name)
        ref = mdof_impact_test(system, max(system.impacts_n), snr_db=snr_db, seed=0)
        return cls(system, ref.sensors, seed=0 if seed is None else int(seed))

    # -- the DAQ-facing interface -------------------------------------------------------
    def configure(self, rate_hz: float | None = None) -> None:
        """Only the system's own rate is served (its physics and sensors are resolved there).

        Raises
        ------
        ScenarioError
            For another rate.
        """
        if rate_hz is not None and abs(float(rate_hz) - self.rate_hz) > 1e-9 * self.rate_hz:
            raise ScenarioError(f"rate_hz: the MDOF system {self.system.name} runs at {self.rate_hz:g} Hz, "
                                f"got {rate_hz:g}")

    def deliver_impact(self, peak_force_n: float, double_hit: bool = False) -> None:
        """Schedule a blow on the driving mass ``impact_delay_s`` after the current sample.

        Raises
        ------
        ScenarioError
            Bad peak, or a blow that makes the system diverge.
        """
        if not (math.isfinite(peak_force_n) and peak_force_n > 0):
            raise ScenarioError(f"peak_force_n: must be > 0, got {peak_force_n}")
        start = self.sample_index + int(round(self.impact_delay_s * self.rate_hz))
        begin = start - 1  # the sample before the pulse: its state seeds the simulation
        x0, v0 = self._state_at(begin)
        n = int(round(max(CHUNK_S, 2 * self.hammer.duration_s) * self.rate_hz)) + 1
        t = (np.arange(n) - 1) / self.rate_hz
        force = hammer_force(t, peak_force_n, self.hammer, double_hit)
        impulse = 2.0 * peak_force_n * self.hammer.width_s / math.pi
        f = self.model.natural_frequencies_hz()
        w = 2 * math.pi * max(float(f[f > 0].min()) if np.any(f > 0) else 1.0, 1.0)
        self._x_scale = np.maximum(np.abs(x0), impulse / (min(self.model.mass) * w))
        sim = simulate_mdof(self.model, t, force, x0=x0, v0=v0, x_scale=self._x_scale)
        if sim.diverged or not np.all(np.isfinite(sim.x)):
            raise ScenarioError(f"impacts: {self.system.name} diverges under a {peak_force_n:.4g} N blow")
        self._substeps = sim.substeps
        keep = max(0, begin - self._seg_start)
        self._pad_to(keep)
        self._force = np.concatenate([self._force[:keep], force])
        self._acc = np.hstack([self._acc[:, :keep], self.model.phi @ sim.a])
        self._state = np.hstack([self._state[:, :keep], np.vstack([sim.x, sim.v])])
        self.impacts.append((start, float(peak_force_n)))

    def read(self, n: int) -> np.ndarray:
        """The next ``n`` samples as ADC counts, shape (n, 1 + N) int32: ``force, acc1..accN``."""
        n = int(n)
        if n < 0:
            raise ScenarioError(f"read: n must be >= 0, got {n}")
        self._ensure(self.sample_index + n)
        k0 = self.sample_index - self._seg_start
        clean = np.zeros((n, len(self.channels)))
        avail = max(0, min(n, self._force.size - k0))
        clean[:avail, 0] = self._force[k0:k0 + avail]
        clean[:avail, 1:] = self._acc[:, k0:k0 + avail].T
        counts, _infos, _clipped = measure(self.sensors, clean, self._rng.standard_normal((n, len(self.channels))))
        self._count_clips(counts)
        self.sample_index += n
        # drop what has been consumed, keeping the last row (the state continuation starts from)
        used = max(0, min(self._force.size - 1, k0 + n))
        self._force, self._acc, self._state = self._force[used:], self._acc[:, used:], self._state[:, used:]
        self._seg_start += used
        return counts

    # -- internals ----------------------------------------------------------------------
    def _pad_to(self, k: int) -> None:
        """Extend the segment with rest up to ``k`` samples."""
        gap = k - self._force.size
        if gap > 0:
            self._force = np.concatenate([self._force, np.zeros(gap)])
            self._acc = np.hstack([self._acc, np.zeros((self._acc.shape[0], gap))])
            self._state = np.hstack([self._state, np.zeros((self._state.shape[0], gap))])

    def _at_rest(self) -> bool:
        if self._force.size == 0 or self._force[-1] != 0.0:
            return self._force.size == 0
        tail = np.abs(self._acc[:, -max(1, int(0.1 * self.rate_hz)):])
        steps = np.array([c.scale for c in self.channels[1:]])
        return bool(np.all(np.max(tail, axis=1) < 0.01 * steps))

    def _ensure(self, end: int) -> None:
        """Simulate the ring-down on, chunk by chunk, up to absolute sample ``end`` or rest."""
        n = self.model.n_coords
        while self._seg_start + self._force.size < end and not self._at_rest():
            last = self._state[:, -1]
            m = int(round(CHUNK_S * self.rate_hz)) + 1
            t = np.arange(m) / self.rate_hz
            sim = simulate_mdof(self.model, t, None, x0=last[:n], v0=last[n:], x_scale=self._x_scale,
                                substeps=self._substeps)
            self._force = np.concatenate([self._force, np.zeros(m - 1)])
            self._acc = np.hstack([self._acc, (self.model.phi @ sim.a)[:, 1:]])
            self._state = np.hstack([self._state, np.vstack([sim.x, sim.v])[:, 1:]])

    def _state_at(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        self._ensure(index + 1)
        n = self.model.n_coords
        k = index - self._seg_start
        if 0 <= k < self._force.size:
            return self._state[:n, k].copy(), self._state[n:, k].copy()
        return np.zeros(n), np.zeros(n)
