"""The equation of motion as data.

One schema serves the identified model, the simulated rig's physics and the extended model
that diagnosis proposes::

    mass * x'' + sum_j b_j B_j(x, v) + sum_n k_n K_n(x) + sum(effect forces) = F(t)

``damping`` and ``stiffness`` map term text (see :mod:`eddi.terms`) to coefficients in SI
units. ``effects`` are named physical mechanisms with named parameters; their forces are
given by :func:`effect_force` and documented in ``docs/effects.md``.

The model serialises to JSON (:meth:`EquationOfMotion.to_json`) and loads back
(:meth:`EquationOfMotion.from_json`).
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from eddi.errors import ModelError, TermError
from eddi.terms import Term, parse_term

SCHEMA_VERSION = 1

#: Every effect the engine knows, with its parameters (name -> (unit, default or None when
#: required)). The physics of each is in ``docs/effects.md``.
EFFECTS: dict[str, dict[str, tuple[str, float | None]]] = {
    # F = force_n * tanh(v / velocity_scale): dry friction, regularised for the integrator
    "coulomb_friction": {"force_n": ("N", None), "velocity_scale": ("m/s", 1e-4)},
    # F = coefficient * |v| * v: drag on a bluff body
    "quadratic_damping": {"coefficient": ("N s^2/m^2", None)},
    # F = stiffness_n_per_m * sign(x) * max(|x| - gap_m, 0): contact beyond a gap
    "clearance": {"gap_m": ("m", None), "stiffness_n_per_m": ("N/m", None)},
    # F = k2 * x^2 (+ k4 * x^4): asymmetric (even-order) stiffness
    "asymmetric_stiffness": {"k2": ("N/m^2", None), "k4": ("N/m^4", 0.0)},
    # a second, lightly coupled linear mode y:
    #   mass_kg * y'' + damping * y' + stiffness * y + coupling * (y - x) = 0
    #   and coupling * (x - y) acts on the measured coordinate x
    "second_mode": {
        "mass_kg": ("kg", None),
        "stiffness_n_per_m": ("N/m", None),
        "damping_n_s_per_m": ("N s/m", 0.0),
        "coupling_n_per_m": ("N/m", None),
    },
    # F = yield_force_n * z, a Bouc-Wen element (beta = gamma = 1/2, eddi/hysteresis.py):
    #   dz = (dx / yield_displacement_m) (1 - |z|^exponent (sign(dx z) + 1) / 2)
    "hysteresis": {
        "yield_force_n": ("N", None),
        "yield_displacement_m": ("m", None),
        "exponent": ("1", 2.0),
    },
}


class Effect(BaseModel):
    """A named physical mechanism with its parameters.

    Attributes
    ----------
    name : str
        One of :data:`EFFECTS`.
    params : dict of str to float
        Parameters, SI units; missing optional ones take their default.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str
    params: dict[str, float] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _check(self) -> "Effect":
        spec = EFFECTS.get(self.name)
        if spec is None:
            raise ValueError(f"unknown effect {self.name!r}; known: {', '.join(EFFECTS)}")
        unknown = set(self.params) - set(spec)
        if unknown:
            raise ValueError(
                f"effect {self.name!r} has no parameter {sorted(unknown)[0]!r}; "
                f"expected {', '.join(spec)}"
            )
        for key, value in self.params.items():
            if not math.isfinite(value):
                raise ValueError(f"effect {self.name!r} parameter {key!r} is not finite")
        full = {}
        for key, (_unit, default) in spec.items():
            if key in self.params:
                full[key] = float(self.params[key])
            elif default is None:
                raise ValueError(f"effect {self.name!r} needs parameter {key!r}")
            else:
                full[key] = float(default)
        if self.name == "second_mode" and full["mass_kg"] <= 0:
            raise ValueError("effect 'second_mode' needs mass_kg > 0")
        if self.name == "clearance" and full["gap_m"] < 0:
            raise ValueError("effect 'clearance' needs gap_m >= 0")
        if self.name == "hysteresis" and not (full["yield_displacement_m"] > 0 and full["exponent"] > 0):
            raise ValueError("effect 'hysteresis' needs yield_displacement_m > 0 and exponent > 0")
        if self.name == "coulomb_friction" and full["velocity_scale"] <= 0:
            raise ValueError("effect 'coulomb_friction' needs velocity_scale > 0")
        object.__setattr__(self, "params", full)
        return self


class EquationOfMotion(BaseModel):
    """``mass x'' + sum b_j B_j + sum k_n K_n + effects = F(t)``, as data.

    Attributes
    ----------
    mass : float
        Mass, or inertia for an angular coordinate (e.g. ``m l^2``), > 0.
    damping : dict of str to float
        Dissipative terms (text) and their coefficients.
    stiffness : dict of str to float
        Conservative terms (text, functions of ``x`` only) and their coefficients.
    effects : list of Effect
        Extra named mechanisms.
    coordinate : str
        What ``x`` is (``"displacement [m]"``, ``"angle [rad]"``), for people.
    notes : str
        Free text (where the model came from).
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    schema_version: int = SCHEMA_VERSION
    mass: float
    damping: dict[str, float] = Field(default_factory=dict)
    stiffness: dict[str, float] = Field(default_factory=dict)
    effects: tuple[Effect, ...] = ()
    coordinate: str = "displacement [m]"
    notes: str = ""

    @field_validator("mass")
    @classmethod
    def _mass_positive(cls, m: float) -> float:
        if not (math.isfinite(m) and m > 0):
            raise ValueError(f"mass must be > 0, got {m}")
        return m

    @field_validator("damping", "stiffness")
    @classmethod
    def _terms_parse(cls, d: dict[str, float]) -> dict[str, float]:
        for text, c in d.items():
            try:
                parse_term(text)
            except TermError as exc:
                raise ValueError(str(exc)) from None
            if not math.isfinite(c):
                raise ValueError(f"coefficient of {text!r} is not finite")
        return d

    @model_validator(mode="after")
    def _stiffness_has_no_v(self) -> "EquationOfMotion":
        for text in self.stiffness:
            if parse_term(text).depends_on_v:
                raise ValueError(f"stiffness term {text!r} depends on v; put it in damping")
        if self.schema_version != SCHEMA_VERSION:
            raise ValueError(
                f"schema_version {self.schema_version} is not supported (expected {SCHEMA_VERSION})"
            )
        names = [e.name for e in self.effects]
        if len(set(names)) != len(names):
            raise ValueError("an effect is listed twice")
        return self

    # -- construction -----------------------------------------------------------------
    @classmethod
    def create(cls, **kwargs: Any) -> "EquationOfMotion":
        """Build a model, raising :class:`ModelError` (one line) instead of a pydantic error."""
        try:
            return cls(**kwargs)
        except ValidationError as exc:
            raise ModelError(_first_error(exc)) from None

    @classmethod
    def from_json(cls, text: str) -> "EquationOfMotion":
        """Load from JSON text.

        A model file holds a restoring force: at least one stiffness term or effect (a file
        with only a mass, or only damping, is truncated or incomplete, and simulating it
        would report a meaningless nrmse).

        Raises
        ------
        ModelError
            If the text is not JSON or not a valid equation of motion, or holds no stiffness
            term and no effect.
        """
        data = json_object(text)
        if "equation_of_motion" in data and isinstance(data["equation_of_motion"], dict):
            data = data["equation_of_motion"]
        try:
            # strict JSON: a number written as a string ("mass": "0.7") is a damaged file, not a
            # value to guess at; integers are numbers
            eom = cls.model_validate_json(json.dumps(data), strict=True)
        except ValidationError as exc:
            raise ModelError(_first_error(exc)) from None
        if not eom.stiffness and not eom.effects:
            raise ModelError("invalid model: no stiffness terms and no effects (an incomplete model file?); "
                             "expected e.g. \"stiffness\": {\"x\": 1000.0} next to \"mass\" and \"damping\"")
        return eom

    def to_json(self, indent: int | None = 2) -> str:
        """Serialise to JSON text."""
        return self.model_dump_json(indent=indent)

    def to_dict(self) -> dict[str, Any]:
        """A plain dict (JSON-ready)."""
        return json.loads(self.model_dump_json())

    # -- derived ----------------------------------------------------------------------
    def damping_terms(self) -> tuple[Term, ...]:
        return tuple(parse_term(t) for t in self.damping)

    def stiffness_terms(self) -> tuple[Term, ...]:
        return tuple(parse_term(t) for t in self.stiffness)

    def effect(self, name: str) -> Effect | None:
        """The effect of that name, or None."""
        for e in self.effects:
            if e.name == name:
                return e
        return None

    def with_effect(self, effect: Effect) -> "EquationOfMotion":
        """A copy with ``effect`` added (replacing one of the same name)."""
        others = tuple(e for e in self.effects if e.name != effect.name)
        return self.model_copy(update={"effects": others + (effect,)})

    def restoring_force(self, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Internal force ``sum b_j B_j + sum k_n K_n + effects`` (second mode at rest).

        Parameters
        ----------
        x, v : ndarray, shape (n,)

        Returns
        -------
        ndarray, shape (n,), [N]
        """
        x = np.asarray(x, float)
        v = np.asarray(v, float)
        shape = np.broadcast(x, v).shape
        total = None
        # summed in place in the order they always had; the first term is not added to an
        # array of zeros (``0.0 + y`` is ``y`` except for ``-0.0``, which ``+= 0.0`` makes
        # ``+0.0`` as that sum did): the same numbers bit for bit, a pass and a temporary fewer
        for text, c in {**self.damping, **self.stiffness}.items():
            f = c * parse_term(text)(x, v)
            total = _first(f, shape) if total is None else _add(total, f)
        for e in self.effects:
            f = effect_force(e, x, v)
            total = _first(f, shape) if total is None else _add(total, f)
        return np.zeros(shape) if total is None else total

    def linear_stiffness(self) -> float:
        """Coefficient of the ``x`` term (0 when absent)."""
        for text, c in self.stiffness.items():
            if parse_term(text).exponents == (1, 0, 0, 0, 0, 0):
                return float(c)
        return 0.0

    def equation_text(self) -> str:
        """The equation written out, for people."""
        parts = [f"{self.mass:.6g}*x''"]
        for text, c in {**self.damping, **self.stiffness}.items():
            parts.append(f"{c:+.6g}*{text}")
        for e in self.effects:
            args = ", ".join(f"{k}={v:.4g}" for k, v in e.params.items())
            parts.append(f"+ {e.name}({args})")
        return " ".join(parts) + " = F(t)"


def effect_force(effect: Effect, x: np.ndarray, v: np.ndarray, y: np.ndarray | None = None) -> np.ndarray:
    """Force of one effect on the measured coordinate (added to the left-hand side).

    Parameters
    ----------
    effect : Effect
    x, v : ndarray, shape (n,)
        Coordinate and rate.
    y : ndarray, shape (n,), optional
        Second-mode coordinate (``second_mode`` only; taken as 0 when absent).
    """
    p = effect.params
    x = np.asarray(x, float)
    v = np.asarray(v, float)
    if effect.name == "coulomb_friction":
        return p["force_n"] * np.tanh(v / p["velocity_scale"])
    if effect.name == "quadratic_damping":
        return p["coefficient"] * np.abs(v) * v
    if effect.name == "clearance":
        return p["stiffness_n_per_m"] * np.sign(x) * np.maximum(np.abs(x) - p["gap_m"], 0.0)
    if effect.name == "asymmetric_stiffness":
        return p["k2"] * x**2 + p["k4"] * x**4
    if effect.name == "second_mode":
        yy = np.zeros_like(x) if y is None else np.asarray(y, float)
        return p["coupling_n_per_m"] * (x - yy)
    if effect.name == "hysteresis":  # history dependent: x is taken as a path from z = 0
        from eddi.hysteresis import bouc_wen_z

        flat = np.ravel(x)
        z = bouc_wen_z(flat, p["yield_displacement_m"], p["exponent"]) if flat.size else flat
        return p["yield_force_n"] * z.reshape(np.shape(x))
    raise ModelError(f"unknown effect {effect.name!r}")  # pragma: no cover - validated earlier


def _first_error(exc: ValidationError) -> str:
    err = exc.errors()[0]
    where = ".".join(str(p) for p in err.get("loc", ()) if p != "__root__")
    msg = str(err.get("msg", "invalid model")).removeprefix("Value error, ")
    return f"invalid model: {where + ': ' if where else ''}{msg}"


def json_object(text: str) -> dict[str, Any]:
    """The JSON object a model file holds; one-line ModelError for anything else.

    Shared by every model schema (:class:`EquationOfMotion`, the modal sum of
    :mod:`eddi.multimode`, the multi-DOF model of :mod:`eddi.mdof.model`).
    """
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ModelError(f"model is not valid JSON: {exc.msg} at line {exc.lineno}") from None
    if not isinstance(data, dict):
        raise ModelError(f"model JSON must be an object, got {type(data).__name__}")
    return data


def _first(f: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """``np.zeros(shape) + f`` bit for bit: float64, broadcast to ``shape``, ``-0.0`` as ``+0.0``."""
    out = np.array(np.broadcast_to(np.asarray(f, dtype=float), shape), dtype=float)
    out += 0.0
    return out


def _add(total: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``total + f``, in place when the shapes and types allow (else a new array, as before)."""
    f = np.asarray(f)
    if np.result_type(total, f) == total.dtype and np.broadcast_shapes(total.shape, f.shape) == total.shape:
        total += f
        return total
    return total + f

