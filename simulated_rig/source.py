"""The live sample-time source behind the emulated DAQ firmware.

:class:`RigSource` produces ADC counts of the force and acceleration channels, ``read(n)``
samples at a time, in *sample time* (no wall clock). At rest it emits sensor noise;
:meth:`RigSource.deliver_impact` schedules a hammer blow ``impact_delay_s`` (5 ms) after the
current sample and simulates the first second of the response with
:func:`eddi.simulate.simulate`; the following reads stream it out. As the reads go on the
source keeps simulating from the last state, one second at a time and with the same RK4
sub-steps (so the result is bit-identical to one long simulation), until the acceleration
falls below 1 % of a quantisation step; it then snaps to rest.
A blow that comes while the structure still rings is simulated forward from the current
state (the rest of an earlier pulse still under way is dropped).

Noise and ranges are fixed once, when the source is built: each sensor is resolved
(:meth:`simulated_rig.sensors.SensorSpec.resolved`) on the noise-free response to the
scenario's *largest* impact (the reference blow), so that blow never clips with automatic
ranges and a larger one may.

Equivalence with :func:`simulated_rig.bench.impact_test` (tested): for a source built from
a scenario with seed ``s``, reading ``p - d`` samples, delivering the reference blow
(``d`` = delay in samples) and reading on gives, from sample 0, exactly the counts of
``impact_test`` of that scenario at the reference force with seed ``s`` and
``pretrigger_s = p / rate``: same noise draws (``default_rng(s).standard_normal((n, 2))``
in order), same RK4 steps, same quantisation.
"""

from __future__ import annotations

import json
import math

import numpy as np
from scipy import signal as sps

from drivers.channels import ChannelInfo
from eddi.model import EquationOfMotion
from eddi.simulate import simulate
from simulated_rig.bench import impact_test, measure, simulate_truth
from simulated_rig.errors import ScenarioError
from simulated_rig.hammer import HammerSpec, hammer_force
from simulated_rig.measured_channels import MeasuredChannels
from simulated_rig.scenario import Scenario
from simulated_rig.sensors import SensorSpec, iepe_filter

#: Delay from :meth:`RigSource.deliver_impact` to the start of the pulse [s].
IMPACT_DELAY_S = 5.0e-3
#: Length of the window simulated at a blow, and of each continuation chunk [s]. Short, so
#: a blow costs a paced server ~10 ms, not the 0.5 s of a whole 45 s ring-down.
CONTINUATION_S = 1.0


class RigSource(MeasuredChannels):
    """Sample-time source of ADC counts for the emulated DAQ.

    Parameters
    ----------
    eom : EquationOfMotion
        True physics.
    sensors : (SensorSpec, SensorSpec)
        Force and acceleration sensors, resolved (absolute ``noise_rms_si`` and ``range_si``).
    rate_hz : float
        Sample rate [Hz].
    hammer : HammerSpec
    ringdown_s : float
        Longest window simulated at once at a blow [s] (at most :data:`CONTINUATION_S`;
        the ring-down then continues chunk by chunk).
    seed : int
        Seed of the noise.
    scenario_json : str
        Metadata stored with captures.
    impact_delay_s : float
        Delay from :meth:`deliver_impact` to the pulse [s].

    Attributes
    ----------
    rate_hz : float
    channels : tuple of ChannelInfo
        ``force`` [N] and ``acc`` [m/s^2].
    scenario_json : str
    sample_index : int
        Samples produced so far.
    clip_counts : dict of str to int
        Clipped samples per channel so far.
    impacts : list of (int, float)
        Sample index of each pulse start and its peak force [N].
    """

    def __init__(self, eom: EquationOfMotion, sensors: tuple[SensorSpec, SensorSpec], *,
                 rate_hz: float, hammer: HammerSpec = HammerSpec(), ringdown_s: float = 10.0,
                 seed: int = 0, scenario_json: str = "", impact_delay_s: float = IMPACT_DELAY_S
                 ) -> None:
        for s in sensors:
            if s.noise_rms_si is None or s.range_si is None:
                raise ScenarioError(f"sensors.{s.name}: the source needs an absolute noise and range")
        if not (ringdown_s > 0):
            raise ScenarioError(f"record_s: must be > 0, got {ringdown_s}")
        self.eom = eom
        self.sensors = tuple(sensors)
        self.hammer = hammer
        self.ringdown_s = float(ringdown_s)
        self.seed = int(seed)
        self.scenario_json = scenario_json
        self.impact_delay_s = float(impact_delay_s)
        self.channels: tuple[ChannelInfo, ...] = tuple(s.channel_info(float(s.range_si)) for s in sensors)
        self.sample_index = 0
        self.clip_counts = {s.name: 0 for s in sensors}
        self.impacts: list[tuple[int, float]] = []
        self._rng = np.random.default_rng(self.seed)
        # simulated future: columns force, x, v, a, from absolute sample self._seg_start
        self._seg = np.zeros((0, 4))
        self._seg_start = 0
        self._substeps: int | None = None
        self.rate_hz = 0.0
        self._filters: list[tuple[np.ndarray, np.ndarray] | None] = []
        self._zi: list[np.ndarray | None] = []
        self._set_rate(rate_hz)

    # -- construction -------------------------------------------------------------------
    @classmethod
    def from_scenario(cls, scenario: Scenario, seed: int | None = None) -> "RigSource":
        """A source for a scenario; noise and ranges resolved on its largest impact."""
        eom = scenario.eom()
        reference = max(scenario.resolved_impacts())
        record_s = scenario.resolved_record_s()
        ref = impact_test(eom, reference, rate_hz=scenario.rate_hz, pretrigger_s=scenario.pretrigger_s,
                          record_s=record_s, sensors=scenario.sensor_specs(),
                          hammer=scenario.hammer_spec(), double_hit=scenario.double_hit, seed=0)
        seed = scenario.seed if seed is None else int(seed)
        meta = json.loads(scenario.to_json())
        meta["source"] = {
            "reference_force_n": reference,
            "noise_rms": ref.noise_rms,
            "range_si": {c.name: c.range_si for c in ref.channels},
            "impact_delay_s": IMPACT_DELAY_S,
            "seed": seed,
        }
        return cls(eom, ref.sensors, rate_hz=scenario.rate_hz, hammer=scenario.hammer_spec(),
                   ringdown_s=record_s, seed=seed, scenario_json=json.dumps(meta))

    @classmethod
    def from_system(cls, name: str, seed: int | None = None) -> "RigSource":
        """A source for a named system with the default scenario settings."""
        return cls.from_scenario(Scenario(system=name, seed=0 if seed is None else int(seed)))

    # -- the DAQ-facing interface -------------------------------------------------------
    def configure(self, rate_hz: float | None = None) -> None:
        """Change the sample rate [Hz]; a ring-down under way continues at the new rate."""
        if rate_hz is None or float(rate_hz) == self.rate_hz:
            return
        x, v = self._state_at(self.sample_index)
        self._seg = np.zeros((0, 4))
        self._seg_start = self.sample_index
        self._set_rate(rate_hz)
        if x != 0.0 or v != 0.0:
            res = simulate(self.eom, rate_hz=self.rate_hz, n_samples=2, x0=x, v0=v)
            self._substeps = res.substeps
            self._seg = np.array([[0.0, x, v, res.a[0]]])

    def deliver_impact(self, peak_force_n: float, double_hit: bool = False) -> None:
        """Schedule a blow ``impact_delay_s`` after the current sample.

        Parameters
        ----------
        peak_force_n : float
            Peak of the pulse [N], > 0.
        double_hit : bool
            Add the hammer's second, smaller pulse.
        """
        if not (math.isfinite(peak_force_n) and peak_force_n > 0):
            raise ScenarioError(f"peak_force_n: must be > 0, got {peak_force_n}")
        start = self.sample_index + int(round(self.impact_delay_s * self.rate_hz))
        begin = start - 1  # the sample before the pulse: its state seeds the simulation
        x0, v0 = self._state_at(begin)
        window_s = max(min(self.ringdown_s, CONTINUATION_S), 2 * self.hammer.duration_s)
        n = int(round(window_s * self.rate_hz)) + 1
        t = (np.arange(n) - 1) / self.rate_hz
        force = hammer_force(t, peak_force_n, self.hammer, double_hit)
        res = simulate_truth(self.eom, force, self.rate_hz, x0=x0, v0=v0)
        self._substeps = res.substeps
        keep = self._seg[: max(0, begin - self._seg_start)]
        if begin < self._seg_start:  # cannot happen: begin >= sample_index >= _seg_start
            raise AssertionError("impact scheduled in the past")  # pragma: no cover
        if keep.shape[0] < begin - self._seg_start:  # rest between the segment and the blow
            gap = np.zeros((begin - self._seg_start - keep.shape[0], 4))
            keep = np.vstack([keep, gap])
        new = np.column_stack([force, res.x, res.v, res.a])
        self._seg = np.vstack([keep, new])
        self.impacts.append((start, float(peak_force_n)))

    def read(self, n: int) -> np.ndarray:
        """The next ``n`` samples as ADC counts.

        Returns
        -------
        ndarray, shape (n, 2), int32
            Columns ``force``, ``acc``.
        """
        n = int(n)
        if n < 0:
            raise ScenarioError(f"read: n must be >= 0, got {n}")
        seg = self._take(n)
        clean = np.column_stack([seg[:, 0], seg[:, 3]])
        for j in range(2):
            filt = self._filters[j]
            if filt is not None:
                clean[:, j], self._zi[j] = sps.lfilter(filt[0], filt[1], clean[:, j], zi=self._zi[j])
        normals = self._rng.standard_normal((n, 2))
        counts, _channels, _clipped = measure(self.sensors, clean, normals)
        self._count_clips(counts)
        self.sample_index += n
        return counts

    # -- internals ----------------------------------------------------------------------
    def _set_rate(self, rate_hz: float) -> None:
        rate_hz = float(rate_hz)
        if not (100.0 <= rate_hz <= 1.0e6):
            raise ScenarioError(f"rate_hz: must be in [100, 1e6] Hz, got {rate_hz}")
        self.rate_hz = rate_hz
        self._filters = [None if s.iepe_highpass_hz is None else iepe_filter(s.iepe_highpass_hz, rate_hz)
                         for s in self.sensors]
        self._zi = [None if f is None else np.zeros(1) for f in self._filters]

    def _at_rest_after_segment(self) -> bool:
        if self._seg.shape[0] == 0:
            return True
        last = self._seg[-1]
        step = self.channels[1].scale
        tail = self._seg[-max(1, int(0.1 * self.rate_hz)):, 3]
        return bool(np.max(np.abs(tail)) < 0.01 * step and last[0] == 0.0)

    def _extend(self) -> None:
        """Simulate one continuation chunk from the segment's last state (zero force)."""
        last = self._seg[-1]
        n = int(round(CONTINUATION_S * self.rate_hz)) + 1
        res = simulate(self.eom, rate_hz=self.rate_hz, n_samples=n, x0=float(last[1]),
                       v0=float(last[2]), substeps=self._substeps)
        new = np.column_stack([np.zeros(n - 1), res.x[1:], res.v[1:], res.a[1:]])
        self._seg = np.vstack([self._seg, new])

    def _ensure(self, end: int) -> None:
        """Make the segment cover absolute samples up to ``end`` (exclusive), or stop at rest."""
        while self._seg_start + self._seg.shape[0] < end and not self._at_rest_after_segment():
            self._extend()

    def _state_at(self, index: int) -> tuple[float, float]:
        self._ensure(index + 1)
        k = index - self._seg_start
        if 0 <= k < self._seg.shape[0]:
            return float(self._seg[k, 1]), float(self._seg[k, 2])
        return 0.0, 0.0

    def _take(self, n: int) -> np.ndarray:
        self._ensure(self.sample_index + n)
        k0 = self.sample_index - self._seg_start
        out = np.zeros((n, 4))
        avail = self._seg[k0:k0 + n]
        out[: avail.shape[0]] = avail
        # drop what has been consumed (keep memory bounded), but keep the last row: it
        # holds the state that continuation and the rest test start from
        consumed = max(0, min(self._seg.shape[0] - 1, k0 + n))
        self._seg = self._seg[consumed:]
        self._seg_start += consumed
        return out
