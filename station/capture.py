"""Acquisition loop: device blocks -> trigger -> checks -> session file, with live status.

:func:`acquire` arms the trigger, reads blocks from a :class:`drivers.daq.Daq` (or anything
with the same ``info``/``start``/``stop``/``read_block`` members), saves every
accepted capture as soon as it completes (crash-safe, see :mod:`station.storage`) and stops
after ``n_impacts`` saved captures, on Ctrl-C, on a lost device or on a failed save. Whatever
ends the run, the captures saved before are kept, and a capture in progress is saved too,
flagged ``partial``. With a simulated rig (``sim://``) the loop asks the rig for each impact
(:class:`ImpactPlan`), so a run needs no operator.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Protocol, Sequence

import numpy as np

from drivers.channels import ChannelInfo
from drivers.errors import DriverError
from station.config import BenchConfig
from station.errors import ConfigError, StationError
from station.interrupts import held_interrupt
from station.storage import CaptureWriter
from station.trigger import Capture, Trigger, TriggerSettings


class DaqLike(Protocol):
    """The driver surface :func:`acquire` uses (``drivers.daq.Daq``)."""

    url: str
    info: Any

    def start(self) -> None: ...
    def stop(self) -> None: ...
    def read_block(self, timeout_s: float | None = None) -> Any: ...


@dataclass(frozen=True)
class ImpactPlan:
    """Impacts a simulated rig delivers: peak forces [N] and double-hit flags, in order.

    Attributes
    ----------
    peaks_n : tuple of float
        Peak force of each impact [N].
    double_hits : tuple of bool
        Whether each impact is a double hit.
    at_samples : tuple of int
        When given, each blow's device sample counter counted from the stream's first sample:
        the rig delivers them in sample time, so a run is the same whatever the host's speed.
        Empty: each blow is asked for when the trigger is armed.
    """

    peaks_n: tuple[float, ...]
    double_hits: tuple[bool, ...]
    at_samples: tuple[int, ...] = ()

    def scheduled(self, settings: TriggerSettings) -> "ImpactPlan":
        """The same blows at fixed sample times: the first once the pre-trigger is full, then one
        every record + hold-off + pre-trigger (plus a margin), so each meets an armed trigger."""
        margin = settings.pretrigger_samples // 2 + 1
        period = settings.posttrigger_samples + settings.holdoff_samples + settings.pretrigger_samples + margin
        first = settings.pretrigger_samples + margin
        return ImpactPlan(self.peaks_n, self.double_hits, tuple(first + k * period for k in range(len(self.peaks_n))))

    @classmethod
    def varied(cls, n: int, low_n: float, high_n: float, double_hit_every: int = 0, seed: int = 0) -> "ImpactPlan":
        """``n`` peaks spread geometrically over [low, high] N, in a shuffled (seeded) order.

        Enough entries are made for retries (3 n + 3): rejected or missed impacts are repeated.
        """
        m = 3 * n + 3
        base = np.geomspace(low_n, high_n, max(n, 1))
        rng = np.random.default_rng(seed)
        order = np.concatenate([rng.permutation(base) for _ in range(math.ceil(m / max(n, 1)))])[:m]
        dh = tuple(bool(double_hit_every) and (i + 1) % double_hit_every == 0 for i in range(m))
        return cls(tuple(float(p) for p in order), dh)


@dataclass(frozen=True)
class Status:
    """What the live display shows.

    Attributes
    ----------
    state : str
        The trigger's: ``waiting`` (filling the pre-trigger), ``armed``, ``triggered``,
        ``holdoff``. Events (saved, rejected, impact requested) are in ``message``.
    saved, target, rejected : int
        Captures saved, wanted and rejected so far.
    progress : float
        Fraction of the capture in progress [0, 1].
    levels : dict of str to float
        Largest magnitude of each channel in the last block [SI units].
    units : dict of str to str
    dropped_samples : int
        Samples lost by the device or link since the start.
    message : str
        Last event in words (``"capture 3 saved"``, ``"rejected: double hit"``).
    """

    state: str
    saved: int
    target: int
    rejected: int
    progress: float
    levels: dict[str, float]
    units: dict[str, str]
    dropped_samples: int
    message: str = ""


@dataclass
class AcquireResult:
    """Outcome of :func:`acquire` (one per run)."""

    file: Path
    indices: list[int] = field(default_factory=list)
    rejected: list[str] = field(default_factory=list)
    missed_impacts: int = 0
    dropped_samples: int = 0
    partial_index: int | None = None
    interrupted: bool = False
    error: str | None = None

    @property
    def captures(self) -> int:
        """Captures saved in this run (a partial one included)."""
        return len(self.indices)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {
            "file": str(self.file),
            "captures": self.captures,
            "indices": list(self.indices),
            "rejected": len(self.rejected),
            "rejected_reasons": list(self.rejected),
            "missed_impacts": self.missed_impacts,
            "dropped_samples": self.dropped_samples,
            "partial_index": self.partial_index,
            "interrupted": self.interrupted,
            "error": self.error,
        }


def configure_device(daq: Any, config: BenchConfig) -> None:
    """Apply the configured rate, channels and block size to the device (when any is set)."""
    dev = config.device
    names = [c.name for c in config.channels] or None
    rate = dev.rate_hz if dev is not None else None
    block = dev.block_size if dev is not None else None
    if rate is not None or names is not None or block is not None:
        daq.configure(rate_hz=rate, channels=names, block_size=block)


def default_impacts(
    config: BenchConfig,
    settings: TriggerSettings,
    channels: tuple[ChannelInfo, ...],
    n: int,
    scenario_json: str | None = None,
) -> ImpactPlan:
    """The impacts a simulated rig delivers.

    The configured ``simulation.peak_force_n`` range; else the span of the rig scenario's own
    impact levels (its ``impacts`` list); else 4..12 times the trigger level, at most 60 % of
    the force channel's range.
    """
    sim = config.simulation
    levels: list[float] = []
    if scenario_json:
        try:
            levels = [float(x) for x in json.loads(scenario_json).get("impacts") or []]
        except (ValueError, TypeError, AttributeError):
            levels = []
    if sim.peak_force_n is not None:
        low, high = sim.peak_force_n
    elif levels:
        low, high = min(levels), max(levels)
    else:
        level = abs(settings.level)
        low, high = 4.0 * level, 12.0 * level
        rng = channels[settings.channel].range_si
        if rng > 0:
            high = min(high, 0.6 * rng)
            low = min(low, high)
    return ImpactPlan.varied(n, low, high, sim.double_hit_every, sim.seed)


def acquire(
    daq: DaqLike,
    config: BenchConfig,
    writer: CaptureWriter,
    n_impacts: int,
    *,
    impacts: ImpactPlan | None = None,
    on_status: Callable[[Status], None] | None = None,
    idle_timeout_s: float | None = None,
    read_timeout_s: float = 0.25,
    device_meta: dict[str, Any] | None = None,
    wall_clock: Callable[[], float] = time.time,
) -> AcquireResult:
    """Record ``n_impacts`` accepted captures into ``writer``'s session file.

    Parameters
    ----------
    daq : Daq
        Opened (and configured) device; started and stopped here.
    config : BenchConfig
        Trigger, channel overrides, policies, mass and notes.
    writer : CaptureWriter
    n_impacts : int
        Accepted captures wanted (>= 1).
    impacts : ImpactPlan, optional
        Impacts to ask the simulated rig for (``daq.impact``); None waits for real hammer blows.
    on_status : callable, optional
        Called with a :class:`Status` after every block and event.
    idle_timeout_s : float, optional
        Give up (error) when no block comes for this long [s]; None waits for ever.
    read_timeout_s : float
        Wait per :meth:`read_block` call [s] (bounds the Ctrl-C latency).
    device_meta : dict, optional
        Stored as each capture's ``device`` group (default: from ``daq.info``).
    wall_clock : callable
        UTC wall clock [s since 1970]; read once when the stream starts. Each capture stores
        ``t0_unix_s`` = that time + (its first sample - the stream's first sample) / rate: the
        device's sample clock from one host time stamp (off by the start-up latency of the link).

    Returns
    -------
    AcquireResult
        Never raises for a lost device, a failed save or Ctrl-C: they end the run and are
        reported in ``error`` / ``interrupted``.
    """
    if n_impacts < 1:
        raise StationError(f"--impacts: expected at least 1, got {n_impacts}")
    run = _AcquisitionRun(daq, config, writer, n_impacts, impacts=impacts, on_status=on_status,
                          device_meta=device_meta)
    return run.execute(idle_timeout_s=idle_timeout_s, read_timeout_s=read_timeout_s, wall_clock=wall_clock)


class _AcquisitionRun:
    """The state of one :func:`acquire` call: trigger, schedule, status and the saves."""

    def __init__(self, daq: DaqLike, config: BenchConfig, writer: CaptureWriter, n_impacts: int, *,
                 impacts: ImpactPlan | None, on_status: Callable[[Status], None] | None,
                 device_meta: dict[str, Any] | None) -> None:
        info = daq.info
        self.daq, self.config, self.writer, self.n_impacts = daq, config, writer, n_impacts
        self.impacts, self.on_status = impacts, on_status
        self.channels = config.resolve_channels(info.channels)
        self.rate = float(info.rate_hz)
        self.settings = config.trigger_settings(self.channels, self.rate)
        self.scale = np.array([c.scale for c in self.channels])
        self.offset = np.array([c.offset for c in self.channels])
        _check_session(writer, self.rate, config.specimen.mass_kg, [c.name for c in self.channels])
        self.trig = Trigger(self.settings, self.channels, self.rate)
        self.policy = (config.trigger.on_double_hit, config.trigger.on_overload)
        self.units = {c.name: c.unit for c in self.channels}
        self.dev = device_meta if device_meta is not None else device_metadata(daq)
        self.scenario = getattr(info, "scenario_json", None)
        self.result = AcquireResult(file=writer.path)
        self.levels: dict[str, float] = {c.name: 0.0 for c in self.channels}
        self.message = "arming"
        self.next_impact = 0
        self.impact_at: int | None = None  # sample position when the pending impact was requested
        self.last_peak: tuple[float, bool] | None = None
        self.origin: list[float] = []  # [wall time at START, first sample of the stream]
        self.sensors = config.sensor_metadata()
        self.driving_point = _driving_point(config, self.channels, self.settings.channel, self.scenario)
        self.blows: list[tuple[int, float, bool]] = []  # (device sample, peak, double hit) of each scheduled blow

    def report(self) -> None:
        if self.on_status is not None:
            r, trig = self.result, self.trig
            self.on_status(Status(trig.state, len(r.indices), self.n_impacts, len(r.rejected), trig.progress,
                                  dict(self.levels), self.units, trig.dropped_total, self.message))

    def save(self, cap: Capture) -> None:
        rig = None
        if self.scenario is not None or self.last_peak is not None:
            rig = {"scenario": self.scenario or ""}
            if self.last_peak is not None:
                rig["requested_peak_force_n"] = self.last_peak[0]
                rig["requested_double_hit"] = self.last_peak[1]
        origin = self.origin
        t0 = origin[0] + (cap.first_sample - origin[1]) / self.rate if len(origin) == 2 else None
        peak = float(np.nanmax(np.abs(cap.si[:, self.settings.channel]))) if cap.n_samples else 0.0
        with held_interrupt():  # a Ctrl-C inside h5py's writes would print a traceback: held till saved
            idx = self._append(cap, rig, t0, peak)
            self.result.indices.append(idx)
            if cap.partial:
                self.result.partial_index = idx
            self.message = f"capture {idx} saved" + (" (partial)" if cap.partial else "")

    def _append(self, cap: Capture, rig: dict | None, t0: float | None, peak: float) -> int:
        return self.writer.append(
            cap, device=self.dev, rig=rig, notes=self.config.notes, mass_kg=self.config.specimen.mass_kg,
            t0_unix_s=t0, sensors=self.sensors, source=str(self.dev.get("url", "")),
            dropped_before_total=self.trig.dropped_total,
            extra={"peak_force": peak, **({"driving_point": self.driving_point} if self.driving_point else {})},
        )

    def execute(self, *, idle_timeout_s: float | None, read_timeout_s: float,
                wall_clock: Callable[[], float]) -> AcquireResult:
        result = self.result
        self.blows = _schedule(self.daq, self.impacts)
        self.daq.start()
        self.origin.append(wall_clock())
        self.report()
        idle_s = 0.0
        try:
            while len(result.indices) < self.n_impacts:
                self._check_schedule()
                block = self.daq.read_block(timeout_s=read_timeout_s)
                if block is None:
                    idle_s += read_timeout_s
                    if idle_timeout_s is not None and idle_s >= idle_timeout_s:
                        raise StationError(f"no data from {self.dev.get('url', 'the device')} for {idle_s:.1f} s; "
                                           f"expected a sample stream")
                    continue
                idle_s = 0.0
                self._feed(block)
                self._check_missed()
                self.report()
        except KeyboardInterrupt:
            result.interrupted = True
            self.message = "interrupted"
        except (DriverError, StationError) as exc:
            result.error = str(exc)
            self.message = f"stopped: {exc}"
        finally:
            self._finish()
        return result

    def _check_schedule(self) -> None:
        """Give up when the rig's schedule is spent; ask a rig without one for the next impact."""
        trig, settings, result = self.trig, self.settings, self.result
        blows = self.blows
        if blows and trig.next_sample is not None and trig.state != "triggered" and (
                trig.next_sample > blows[-1][0] + settings.record_samples + settings.holdoff_samples):
            raise StationError(f"the simulated rig gave all {len(blows)} scheduled impacts; "
                               f"{len(result.indices)} accepted, {len(result.rejected)} rejected; giving up")
        # a simulated rig without a schedule: ask for the next impact once the trigger is armed
        impacts = self.impacts
        if impacts is not None and not blows and self.impact_at is None and trig.state == "armed":
            if self.next_impact >= len(impacts.peaks_n):
                raise StationError(f"the simulated rig gave {result.missed_impacts} impacts that did not trigger "
                                   f"(level {settings.level:g}) and {len(result.rejected)} rejected; giving up")
            self.last_peak = (impacts.peaks_n[self.next_impact], impacts.double_hits[self.next_impact])
            self.daq.impact(self.last_peak[0], double_hit=self.last_peak[1])  # type: ignore[attr-defined]
            self.next_impact += 1
            self.impact_at = _device_position(self.daq, trig.next_sample or 0)
            self.message = f"impact {self.next_impact} requested ({self.last_peak[0]:.1f} N)"

    def _feed(self, block: Any) -> None:
        """Scale a block, update the levels, and save or reject the captures it completes."""
        result = self.result
        if len(self.origin) == 1:
            self.origin.append(float(block.first_sample))
        si = block.counts * self.scale + self.offset
        if block.counts.shape[0]:
            peaks = np.max(np.abs(si), axis=0)
            self.levels = {c.name: float(p) for c, p in zip(self.channels, peaks)}
        for cap in self.trig.feed(_Block(block.first_sample, block.counts, si)):
            if self.blows:
                self.last_peak = _blow_of(self.blows, cap.trigger_sample)
            reason = cap.rejection(*self.policy)
            if reason is not None:
                result.rejected.append(reason)
                self.message = f"rejected: {reason}"
            else:
                self.save(cap)
            self.impact_at = None
            if len(result.indices) >= self.n_impacts:
                break

    def _check_missed(self) -> None:
        """An impact that has not triggered within a record length is counted missed."""
        trig, settings = self.trig, self.settings
        if self.impact_at is not None and trig.state != "triggered" and trig.next_sample is not None:
            if trig.next_sample - self.impact_at > settings.record_samples + settings.holdoff_samples:
                self.result.missed_impacts += 1
                self.message = f"impact {self.next_impact} did not reach the trigger level {settings.level:g}"
                self.impact_at = None

    def _finish(self) -> None:
        """Save the partial capture in progress, stop the device, report; never raises."""
        result = self.result
        result.dropped_samples = self.trig.dropped_total
        partial = self.trig.flush()
        if partial is not None and partial.n_samples > 0:
            try:
                self.save(partial)
            except (StationError, OSError) as exc:
                result.error = result.error or str(exc)
            except KeyboardInterrupt:
                result.interrupted = True
        try:
            self.daq.stop()
        except (DriverError, OSError):
            pass
        except KeyboardInterrupt:
            result.interrupted = True
        self.report()


def _schedule(daq: Any, impacts: ImpactPlan | None) -> list[tuple[int, float, bool]]:
    """Send a plan's scheduled blows to the rig, before START (the counter stands still until then)."""
    if impacts is None or not impacts.at_samples:
        return []
    first = int(daq.status().get("next_sample", 0))
    blows = [(first + int(at), float(peak), bool(dh))
             for peak, dh, at in zip(impacts.peaks_n, impacts.double_hits, impacts.at_samples)]
    for at, peak, dh in blows:
        daq.impact(peak, double_hit=dh, at_sample=at)
    return blows


def _blow_of(blows: list[tuple[int, float, bool]], trigger_sample: int) -> tuple[float, bool] | None:
    """(peak, double hit) of the last scheduled blow at or before a trigger sample."""
    before = [b for b in blows if b[0] <= trigger_sample]
    return (before[-1][1], before[-1][2]) if before else None


def _check_session(writer: CaptureWriter, rate_hz: float, mass_kg: float | None, channels: list[str]) -> None:
    """Refuse to append a run whose rate, mass or channels disagree with the file's session."""
    from station.session_writer import disagreement, last_capture_attrs

    last = last_capture_attrs(writer.path)
    if last is None:
        return
    problem = disagreement(last, rate_hz, mass_kg, channels)
    if problem is not None:
        raise StationError(f"{writer.path}: this run's {problem} (capture {last.get('index', '?')}); "
                           "write this run to another file")


def _driving_point(config: BenchConfig, channels: Sequence[ChannelInfo], trigger_channel: int,
                   scenario: str | None) -> str | None:
    """The response channel at the hammer: ``[specimen] driving_point`` (``--driving-point``), else
    the simulated rig's (its scenario's ``driving_point``), else None (not stored).

    Raises
    ------
    ConfigError
        A configured driving point that is not one of the device's response channels.
    """
    names = [c.name for k, c in enumerate(channels) if k != trigger_channel and c.quantity != "force"]
    dp = config.specimen.driving_point
    if dp is None and scenario:
        try:
            dp = json.loads(scenario).get("driving_point")
        except (ValueError, AttributeError):
            dp = None
        return str(dp) if dp in names else None
    if dp is not None and dp not in names:
        raise ConfigError(f"specimen.driving_point: expected one of the device's response channels {names}, "
                          f"got {dp!r}")
    return dp


def device_metadata(daq: Any, url: str | None = None) -> dict[str, Any]:
    """What a capture stores about its device: model, serial, firmware, protocol, URLs.

    ``url`` is the URL the user gave (e.g. ``sim://duffing-smooth``); ``transport_url`` the one
    the driver opened (e.g. the pty of the simulated rig).
    """
    info = daq.info
    opened = str(getattr(daq, "url", ""))
    return {
        "model": str(info.model), "serial": str(info.serial), "firmware": str(info.firmware),
        "protocol_version": int(info.protocol_version), "url": url or opened, "transport_url": opened,
    }


def _device_position(daq: Any, fallback: int) -> int:
    """The device's next sample counter (STATUS ``next_sample``), else ``fallback``.

    Blocks wait in the driver's queue, so the device runs ahead of what was read: an impact
    lands at the device's counter, not at the host's.
    """
    status = getattr(daq, "status", None)
    if callable(status):
        try:
            return max(fallback, int(status().get("next_sample", fallback)))
        except (DriverError, TypeError, ValueError, AttributeError):
            return fallback
    return fallback


@dataclass(frozen=True)
class _Block:
    first_sample: int
    counts: np.ndarray
    si: np.ndarray
