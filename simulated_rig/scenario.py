"""Rig scenarios: a test case as a validated TOML file.

A scenario names the physics (a system of :mod:`simulated_rig.systems`, or an
equation-of-motion JSON file, e.g. an identified or extended model), the hammer, the sensors,
hidden effects, the time base and the impacts. Example (all keys but ``system`` optional)::

    name = "duffing-smooth"
    system = "duffing-smooth"          # or: model = "my-model.json" (relative to this file)
    seed = 0
    rate_hz = 19200.0                  # paper Sec. 3.3.1
    pretrigger_s = 1.0
    record_s = 45.0
    impacts = [246.0, 600.0, 1110.0]   # peak forces [N]
    double_hit = false

    [hammer]
    tip = "plastic"                    # steel | plastic | rubber, or pulse_width_s = 1e-3

    [sensors.acc]
    snr_db = 45.0
    adc_bits = 24
    iepe_highpass_hz = 0.5

    [[effects]]                        # effects with explicit parameters
    name = "coulomb_friction"
    params = { force_n = 0.2 }

    [[hidden]]                         # effects sized by hide_effect (magnitude, seed)
    name = "quadratic_damping"
    magnitude = 0.05

    [base_motion]                      # the base moves on its suspension (the sensor sees it;
                                       # Scenario.impact only, not the streaming sim:// source)
    mass_kg = 20.0
    frequency_hz = 1.5
    damping_ratio = 0.05

Measurement-chain effects are scenario data too: ``[sensors.acc] iepe_highpass_hz`` (an
AC-coupled accelerometer), ``range_si`` (clipping when exceeded), ``double_hit = true``,
``mains_si = 0.05``, ``mains_hz = 50.0`` (``mains_phase_rad``, ``mains_harmonics = [0.3]``): a
mains tone on the channel (:func:`simulated_rig.sensors.mains_tone`).

Bad values are refused by :func:`load_scenario` with a one-line :class:`ScenarioError` that
names the file, the field and the limit (``scenario x.toml: rate_hz: Input should be less
than or equal to 1000000 (got 2000000.0)``).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from eddi.errors import ModelError
from eddi.model import EFFECTS, Effect, EquationOfMotion
from simulated_rig.bench import ImpactRecord, impact_test
from simulated_rig.errors import ScenarioError
from simulated_rig.hammer import HammerSpec
from simulated_rig.sensors import FORCE_NOISE_RMS_N, SensorSpec
from simulated_rig.systems import DEFAULT_SYSTEM, SYSTEMS, get_system, hide_effect, system_info

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

#: Folder of the scenarios shipped with the package.
SCENARIO_DIR = Path(__file__).with_name("scenarios")

_FORCE_DEFAULTS: dict[str, Any] = {"sensitivity": 2.25, "sensitivity_unit": "mV/N",
                                   "snr_db": None, "noise_rms_si": FORCE_NOISE_RMS_N}
_ACC_DEFAULTS: dict[str, Any] = {"sensitivity": 1.0, "sensitivity_unit": "mV/(m/s^2)",
                                 "snr_db": 45.0}


class _Strict(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class HammerConfig(_Strict):
    """``[hammer]``: see :class:`simulated_rig.hammer.HammerSpec`."""

    tip: Literal["steel", "plastic", "rubber"] = "plastic"
    pulse_width_s: float | None = Field(None, ge=1e-5, le=0.1)
    double_hit_delay_s: float = Field(4.0e-3, gt=0.0, le=0.1)
    double_hit_ratio: float = Field(0.3, gt=0.0, le=1.0)

    def spec(self) -> HammerSpec:
        """As a :class:`HammerSpec`."""
        return HammerSpec(**self.model_dump())


class SensorConfig(_Strict):
    """``[sensors.force]`` / ``[sensors.acc]``: see :class:`simulated_rig.sensors.SensorSpec`."""

    sensitivity: float = Field(1.0, gt=0.0)
    sensitivity_unit: str = ""
    snr_db: float | None = Field(45.0, ge=0.0, le=200.0)
    noise_rms_si: float | None = Field(None, ge=0.0)
    range_si: float | None = Field(None, gt=0.0)
    range_headroom: float = Field(1.5, ge=1.0, le=100.0)
    adc_bits: Literal[16, 24] = 24
    iepe_highpass_hz: float | None = Field(None, gt=0.0, le=100.0)
    mains_si: float = Field(0.0, ge=0.0)
    mains_hz: float = Field(50.0, gt=0.0, le=1000.0)
    mains_phase_rad: float | None = None
    mains_harmonics: tuple[float, ...] = ()

    def spec(self, name: str, quantity: str) -> SensorSpec:
        """As a :class:`SensorSpec` of that channel."""
        return SensorSpec(name=name, quantity=quantity, **self.model_dump())


class SensorsConfig(_Strict):
    """``[sensors]``: the force and acceleration channels (each merged onto its defaults)."""

    force: SensorConfig = SensorConfig(**_FORCE_DEFAULTS)
    acc: SensorConfig = SensorConfig(**_ACC_DEFAULTS)

    @field_validator("force", mode="before")
    @classmethod
    def _force_defaults(cls, v: Any) -> Any:
        if isinstance(v, dict):
            merged = {**_FORCE_DEFAULTS, **v}
            if ("snr_db" in v) and "noise_rms_si" not in v:
                merged["noise_rms_si"] = None
            return merged
        return v

    @field_validator("acc", mode="before")
    @classmethod
    def _acc_defaults(cls, v: Any) -> Any:
        return {**_ACC_DEFAULTS, **v} if isinstance(v, dict) else v


class BaseMotionConfig(_Strict):
    """``[base_motion]``: the base moves as a rigid body on its suspension (a measurement effect:
    the accelerometer sees it), see :func:`simulated_rig.bench.base_acceleration`."""

    mass_kg: float = Field(gt=0.0, le=1e4)
    frequency_hz: float = Field(gt=0.0, le=1e3)
    damping_ratio: float = Field(0.05, ge=0.0, le=2.0)


class EffectConfig(_Strict):
    """``[[effects]]``: an effect of :data:`eddi.model.EFFECTS` with explicit parameters."""

    name: str
    params: dict[str, float] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _valid(self) -> "EffectConfig":
        Effect(name=self.name, params=self.params)  # raises ValueError with the reason
        return self


class HiddenConfig(_Strict):
    """``[[hidden]]``: an effect sized by :func:`simulated_rig.systems.hide_effect`."""

    name: str
    magnitude: float = Field(gt=0.0, le=10.0)
    seed: int = Field(0, ge=0)

    @field_validator("name")
    @classmethod
    def _known(cls, v: str) -> str:
        if v not in EFFECTS:
            raise ValueError(f"unknown effect {v!r}; known: {', '.join(EFFECTS)}")
        return v


class Scenario(_Strict):
    """A rig test case. Fields as in the module docstring; units in the names."""

    name: str = ""
    description: str = ""
    system: str | None = None
    model: str | None = None
    seed: int = Field(0, ge=0)
    rate_hz: float = Field(19200.0, ge=100.0, le=1.0e6)
    pretrigger_s: float = Field(1.0, ge=0.0, le=60.0)
    record_s: float | None = Field(None, gt=0.0, le=600.0)
    impacts: tuple[float, ...] = Field((), min_length=0, max_length=1000)
    double_hit: bool = False
    hammer: HammerConfig = HammerConfig()
    sensors: SensorsConfig = SensorsConfig()
    effects: tuple[EffectConfig, ...] = ()
    hidden: tuple[HiddenConfig, ...] = ()
    base_motion: BaseMotionConfig | None = None

    @field_validator("system")
    @classmethod
    def _known_system(cls, v: str | None) -> str | None:
        if v is not None and v not in SYSTEMS:
            raise ValueError(f"unknown system {v!r}; known: {', '.join(SYSTEMS)}")
        return v

    @field_validator("impacts")
    @classmethod
    def _positive_impacts(cls, v: tuple[float, ...]) -> tuple[float, ...]:
        for f in v:
            if not (0.0 < f <= 1.0e5):
                raise ValueError(f"each peak force must be in (0, 100000] N, got {f}")
        return v

    @model_validator(mode="after")
    def _one_physics(self) -> "Scenario":
        if self.system is None and self.model is None:
            object.__setattr__(self, "system", DEFAULT_SYSTEM)
        elif self.system is not None and self.model is not None:
            raise ValueError("give either system or model, not both")
        if self.hidden and self.system is None:
            raise ValueError("hidden effects need a named system (or give effects explicitly)")
        self.hammer.spec()  # cross-field checks (double-hit delay >= pulse width)
        self.sensor_specs()  # the sensors' own checks
        names = [e.name for e in self.effects] + [h.name for h in self.hidden]
        if len(set(names)) != len(names):
            raise ValueError("an effect is listed twice across effects and hidden")
        return self

    # -- what it means ------------------------------------------------------------------
    def base_eom(self) -> EquationOfMotion:
        """The physics before effects: the named system or the model file."""
        if self.model is not None:
            path = Path(self.model)
            try:
                text = path.read_text(encoding="utf-8")
            except OSError as exc:
                raise ScenarioError(f"model: cannot read {path}: {exc.strerror}") from None
            try:
                return EquationOfMotion.from_json(text)
            except ModelError as exc:
                raise ScenarioError(f"model: {path}: {exc}") from None
        return get_system(self.system or DEFAULT_SYSTEM)

    def eom(self) -> EquationOfMotion:
        """The true physics: base model, explicit effects, then hidden ones."""
        eom = self.base_eom()
        for e in self.effects:
            eom = eom.with_effect(Effect(name=e.name, params=e.params))
        for h in self.hidden:
            sized = hide_effect(self.system or DEFAULT_SYSTEM, h.name, h.magnitude, h.seed)
            eom = eom.with_effect(sized.effects[-1])
        return eom

    def resolved_record_s(self) -> float:
        """``record_s``, or the system's suggestion (45 s for ``duffing-smooth``)."""
        if self.record_s is not None:
            return self.record_s
        if self.system is not None:
            return system_info(self.system).record_s
        from simulated_rig.bench import default_record_s

        return default_record_s(self.eom())

    def resolved_impacts(self) -> tuple[float, ...]:
        """``impacts``, or the system's demo levels."""
        if self.impacts:
            return self.impacts
        if self.system is not None:
            return system_info(self.system).demo_forces_n
        raise ScenarioError("impacts: a scenario with a model file must list its impacts")

    def hammer_spec(self) -> HammerSpec:
        return self.hammer.spec()

    def sensor_specs(self) -> tuple[SensorSpec, SensorSpec]:
        """Force and acceleration sensors."""
        return (self.sensors.force.spec("force", "force"),
                self.sensors.acc.spec("acc", "acceleration"))

    def impact(self, index: int = 0, *, peak_force_n: float | None = None,
               seed: int | None = None) -> ImpactRecord:
        """Run one impact test of this scenario.

        Parameters
        ----------
        index : int
            Which of :meth:`resolved_impacts` (ignored when ``peak_force_n`` is given).
        peak_force_n : float, optional
            Override the peak force [N].
        seed : int, optional
            Noise seed; default ``self.seed + index``.
        """
        impacts = self.resolved_impacts()
        if peak_force_n is None:
            if not (0 <= index < len(impacts)):
                raise ScenarioError(f"impact index {index} out of range 0..{len(impacts) - 1}")
            peak_force_n = impacts[index]
        return impact_test(
            self.eom(),
            peak_force_n,
            rate_hz=self.rate_hz,
            pretrigger_s=self.pretrigger_s,
            record_s=self.resolved_record_s(),
            sensors=self.sensor_specs(),
            hammer=self.hammer_spec(),
            double_hit=self.double_hit,
            seed=self.seed + index if seed is None else seed,
            base_motion=self.base_motion.model_dump() if self.base_motion is not None else None,
        )

    def to_json(self) -> str:
        """The scenario and its resolved physics as one JSON object (stored with captures)."""
        data = json.loads(self.model_dump_json())
        data["equation_of_motion"] = self.eom().to_dict()
        return json.dumps(data)


def _one_line(exc: ValidationError, where: str) -> str:
    err = exc.errors()[0]
    loc = ".".join(str(p) for p in err.get("loc", ()))
    msg = str(err.get("msg", "invalid")).removeprefix("Value error, ")
    got = err.get("input")
    plain = isinstance(got, dict) or err.get("type") == "missing" or "got " in msg
    tail = "" if plain else f" (got {got!r})"
    return f"scenario {where}: {loc + ': ' if loc else ''}{msg}{tail}"


def scenario_from_dict(data: dict[str, Any], *, where: str = "<dict>",
                       base_dir: Path | None = None) -> Scenario:
    """Validate a scenario given as a dict (as parsed from TOML).

    ``model`` paths are taken relative to ``base_dir`` when given.

    Raises
    ------
    ScenarioError
        One line naming ``where``, the field and the limit.
    """
    data = dict(data)
    if base_dir is not None and isinstance(data.get("model"), str):
        data["model"] = str((base_dir / data["model"]).resolve())
    try:
        return Scenario(**data)
    except ValidationError as exc:
        raise ScenarioError(_one_line(exc, where)) from None
    except ScenarioError as exc:  # from HammerSpec / SensorSpec checks
        raise ScenarioError(f"scenario {where}: {exc}") from None


def builtin_scenarios() -> tuple[str, ...]:
    """Names of the scenarios shipped in :data:`SCENARIO_DIR`."""
    return tuple(sorted(p.stem for p in SCENARIO_DIR.glob("*.toml")))


def load_scenario(path: str | Path) -> Scenario:
    """Load and validate a scenario TOML file (or a built-in one by name).

    Parameters
    ----------
    path : str or Path
        A ``.toml`` file, or the name of a built-in scenario (:func:`builtin_scenarios`).

    Raises
    ------
    ScenarioError
        Missing file, bad TOML or an invalid value (one line naming the field).
    """
    p = Path(path)
    if not p.exists() and p.suffix == "" and (SCENARIO_DIR / f"{p.name}.toml").exists():
        p = SCENARIO_DIR / f"{p.name}.toml"
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ScenarioError(f"scenario {path}: cannot read ({exc.strerror}); built-in: "
                            f"{', '.join(builtin_scenarios())}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"scenario {p.name}: not valid TOML: {exc}") from None
    data.setdefault("name", p.stem)
    return scenario_from_dict(data, where=p.name, base_dir=p.parent)


__all__ = [
    "BaseMotionConfig",
    "EffectConfig",
    "HammerConfig",
    "HiddenConfig",
    "SCENARIO_DIR",
    "Scenario",
    "SensorConfig",
    "SensorsConfig",
    "builtin_scenarios",
    "load_scenario",
    "scenario_from_dict",
]
