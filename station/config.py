"""Bench configuration: one TOML file, validated with pydantic (see ``docs/bench-config.md``).

Example (``examples/bench.toml``)::

    notes = "Duffing oscillator, wires pre-tensioned"

    [device]
    url = "sim://duffing-smooth"
    rate_hz = 19200            # paper: 19200 Hz

    [[channels]]
    name = "force"
    quantity = "force"
    sensitivity = 2.25         # mV/N, from the hammer's calibration sheet
    sensitivity_unit = "mV/N"
    range = 2000.0             # N

    [trigger]
    level_n = 20.0
    pretrigger_s = 1.0         # paper: 1 s pre-trigger
    record_s = 4.0

    [specimen]
    mass_kg = 0.815            # paper: 0.815 kg

    [identify]
    damping = ["v", "x^2*v", "v^3"]
    stiffness = ["x", "x^3"]

Every invalid field is reported, each with its dotted path, in one line.
"""

from __future__ import annotations

import math
import sys
from datetime import date
from pathlib import Path
from typing import Any, Literal, Sequence

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from drivers.channels import QUANTITY_UNITS, ChannelInfo
from station.errors import ConfigError
from station.trigger import TriggerSettings

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib


#: Longest record, pre-trigger or hold-off [s]: an hour (a record is held in memory; 1e9 s is a typo).
MAX_RECORD_S = 3600.0


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class DeviceConfig(_Strict):
    """Which DAQ and how it runs."""

    url: str = Field(min_length=1, description="device URL: sim://SYSTEM, serial:///dev/ttyACM0, usb://VID:PID")
    rate_hz: float | None = Field(default=None, gt=0, le=10_000_000, allow_inf_nan=False,
                                  description="sample rate [Hz]; device default when absent")
    block_size: int | None = Field(default=None, ge=1, le=65535, description="samples per block; device default when absent")

    @field_validator("url")
    @classmethod
    def _scheme(cls, v: str) -> str:
        if "://" not in v:
            raise ValueError(f"expected a URL such as sim://duffing-smooth or serial:///dev/ttyACM0, got {v!r}")
        return v


class ChannelConfig(_Strict):
    """One channel to acquire (its name must match the device's)."""

    name: str = Field(min_length=1)
    quantity: Literal["force", "acceleration", "velocity", "displacement"]
    sensitivity: float | None = Field(default=None, gt=0, description="sensor sensitivity from its calibration sheet")
    sensitivity_unit: str | None = None
    range: float | None = Field(default=None, gt=0, allow_inf_nan=False,
                                description="largest valid magnitude [SI]; beyond it is overload")
    sensor_model: str | None = Field(default=None, min_length=1, description="sensor make and model (e.g. PCB 086C03)")
    sensor_serial: str | None = Field(default=None, min_length=1, description="sensor serial number")
    calibration_date: date | None = Field(default=None, description="date of the sensor's calibration (YYYY-MM-DD)")
    node: int | None = Field(default=None, ge=0, description="measurement point (UFF node number)")
    direction: Literal["+X", "-X", "+Y", "-Y", "+Z", "-Z"] | None = Field(
        default=None, description="measured direction at the node (UFF: +X=1, +Y=2, +Z=3, negative reversed)")


class TriggerConfig(_Strict):
    """Trigger and record length."""

    channel: str = Field(default="force", min_length=1)
    level_n: float | None = Field(default=None, description="trigger level [SI unit of the channel]; 5 % of its range when absent")
    slope: Literal["rising", "falling", "either"] = "rising"
    pretrigger_s: float = Field(default=1.0, ge=0, le=MAX_RECORD_S, allow_inf_nan=False,
                                description="paper: 1 s")  # paper Sec. 3.3.1 (pre-trigger length of 1 s)
    record_s: float = Field(default=4.0, gt=0, le=MAX_RECORD_S, allow_inf_nan=False,
                            description="record length from the trigger on [s]")
    holdoff_s: float = Field(default=0.0, ge=0, le=MAX_RECORD_S, allow_inf_nan=False,
                             description="wait after a record before re-arming [s]")
    release_fraction: float = Field(default=0.5, gt=0, lt=1)
    on_double_hit: Literal["flag", "reject"] = "flag"
    on_overload: Literal["flag", "reject"] = "flag"

    @field_validator("level_n")
    @classmethod
    def _finite(cls, v: float | None) -> float | None:
        if v is not None and (not math.isfinite(v) or v == 0):
            raise ValueError(f"expected a finite non-zero level, got {v}")
        return v


class SpecimenConfig(_Strict):
    """The structure under test."""

    mass_kg: float | None = Field(default=None, gt=0, allow_inf_nan=False, description="oscillating mass [kg]")
    name: str = ""
    driving_point: str | None = Field(default=None, description="multi-DOF: the response channel at the "
                                      "hammer (acc1, acc_tip ...); default the first response channel")


class IdentifyConfig(_Strict):
    """Candidate terms for identification (text, see ``eddi.terms``)."""

    damping: tuple[str, ...] | None = None
    stiffness: tuple[str, ...] | None = None

    @field_validator("damping", "stiffness")
    @classmethod
    def _terms(cls, v: tuple[str, ...] | None) -> tuple[str, ...] | None:
        if v is None:
            return v
        from eddi.terms import parse_terms

        if not v:
            raise ValueError("expected at least one term, got an empty list")
        try:
            parse_terms(list(v))
        except ValueError as exc:
            raise ValueError(str(exc)) from None
        return v


class SimulationConfig(_Strict):
    """Impacts the simulated rig delivers during ``station acquire`` (``sim://`` devices only)."""

    peak_force_n: tuple[float, float] | None = Field(default=None, description="[low, high] peak force [N]; varied inside")
    double_hit_every: int = Field(default=0, ge=0, description="every k-th impact is a double hit (0: never)")
    seed: int = 0

    @field_validator("peak_force_n")
    @classmethod
    def _order(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and not 0 < v[0] <= v[1]:
            raise ValueError(f"expected 0 < low <= high, got {list(v)}")
        return v


class BenchConfig(_Strict):
    """A whole bench configuration."""

    device: DeviceConfig | None = None
    channels: tuple[ChannelConfig, ...] = ()
    trigger: TriggerConfig = TriggerConfig()
    specimen: SpecimenConfig = SpecimenConfig()
    identify: IdentifyConfig = IdentifyConfig()
    simulation: SimulationConfig = SimulationConfig()
    notes: str = ""

    @model_validator(mode="after")
    def _consistent(self) -> "BenchConfig":
        names = [c.name for c in self.channels]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"channels: names must be unique, {dup} given twice")
        if self.channels and self.trigger.channel not in names:
            raise ValueError(f"trigger.channel: expected one of the channels {names}, got {self.trigger.channel!r}")
        return self

    # ------------------------------------------------------------------ use
    def resolve_channels(self, device_channels: Sequence[ChannelInfo]) -> tuple[ChannelInfo, ...]:
        """Apply the configured channels to what the device reports.

        A configured sensitivity replaces the device's (the scale changes in proportion:
        the ADC's volts per count stay, the sensor's volts per SI unit change); a configured
        range replaces ``range_si``. Channels not configured are returned unchanged.

        Raises
        ------
        ConfigError
            When a configured channel is missing from the device or has another quantity.
        """
        by_name = {c.name: c for c in self.channels}
        out = []
        for ch in device_channels:
            cfg = by_name.get(ch.name)
            if cfg is None:
                out.append(ch)
                continue
            if cfg.quantity != ch.quantity:
                raise ConfigError(f"channels.{ch.name}.quantity: the device reports {ch.quantity!r}, the configuration says {cfg.quantity!r}")
            scale, rng, sens, unit = ch.scale, ch.range_si, ch.sensitivity, ch.sensitivity_unit
            if cfg.sensitivity is not None:
                if ch.sensitivity > 0:
                    scale = ch.scale * ch.sensitivity / cfg.sensitivity
                    rng = ch.range_si * ch.sensitivity / cfg.sensitivity
                sens = cfg.sensitivity
            if cfg.sensitivity_unit is not None:
                unit = cfg.sensitivity_unit
            if cfg.range is not None:
                rng = cfg.range
            out.append(ChannelInfo(ch.name, ch.quantity, ch.unit, scale, ch.offset, rng, ch.adc_bits, sens, unit))
        missing = sorted(set(by_name) - {c.name for c in device_channels})
        if missing:
            raise ConfigError(f"channels: {missing} not found on the device, which has {[c.name for c in device_channels]}")
        return tuple(out)

    def sensor_metadata(self) -> dict[str, dict[str, Any]]:
        """Per-channel sensor fields that are set: ``{name: {sensor_model, ..., node, direction}}``.

        Stored with each capture (``docs/capture-format.md``); dates as ISO text.
        """
        out: dict[str, dict[str, Any]] = {}
        for c in self.channels:
            d = {k: getattr(c, k) for k in ("sensor_model", "sensor_serial", "calibration_date", "node", "direction")
                 if getattr(c, k) is not None}
            if "calibration_date" in d:
                d["calibration_date"] = d["calibration_date"].isoformat()
            if d:
                out[c.name] = d
        return out

    def trigger_settings(self, channels: Sequence[ChannelInfo], rate_hz: float) -> TriggerSettings:
        """Trigger settings in samples for a device running at ``rate_hz`` [Hz]."""
        names = [c.name for c in channels]
        if self.trigger.channel not in names:
            raise ConfigError(f"trigger.channel: expected one of the device channels {names}, got {self.trigger.channel!r}")
        j = names.index(self.trigger.channel)
        level = self.trigger.level_n
        if level is None:
            rng = channels[j].range_si
            if not rng > 0:
                raise ConfigError(f"trigger.level_n: required, the channel {names[j]!r} reports no range")
            level = 0.05 * rng * (-1.0 if self.trigger.slope == "falling" else 1.0)
        return TriggerSettings(
            channel=j,
            level=float(level),
            slope=self.trigger.slope,
            pretrigger_samples=int(round(self.trigger.pretrigger_s * rate_hz)),
            posttrigger_samples=max(1, int(round(self.trigger.record_s * rate_hz))),
            holdoff_samples=int(round(self.trigger.holdoff_s * rate_hz)),
            release_fraction=self.trigger.release_fraction,
        )


def _describe(exc: ValidationError, where: str) -> str:
    parts = []
    for err in exc.errors():
        loc = ".".join(str(p) for p in err.get("loc", ()))
        msg = str(err.get("msg", "invalid")).removeprefix("Value error, ")
        if err.get("type") == "extra_forbidden":
            msg = "unknown field (check the spelling)"
        got = err.get("input")
        shown = "" if err.get("type") in ("missing",) or isinstance(got, dict) else f" (got {got!r})"
        parts.append(f"{loc + ': ' if loc else ''}{msg}{shown}")
    return f"{where}: " + "; ".join(parts)


def parse_config(data: dict[str, Any], where: str = "configuration") -> BenchConfig:
    """Validate a configuration given as a dict (as TOML parses it)."""
    try:
        return BenchConfig.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(_describe(exc, where)) from None


def load_config(path: str | Path) -> BenchConfig:
    """Read and validate a bench configuration TOML file.

    Raises
    ------
    ConfigError
        Missing file, bad TOML (with line), or any invalid field (all listed, one line).
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"{p}: no such configuration file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{p}: cannot read it ({exc})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: not valid TOML ({exc})") from None
    return parse_config(data, str(p))


__all__ = [
    "BenchConfig",
    "ChannelConfig",
    "DeviceConfig",
    "IdentifyConfig",
    "SimulationConfig",
    "SpecimenConfig",
    "TriggerConfig",
    "load_config",
    "parse_config",
    "QUANTITY_UNITS",
]
