"""The modal-sum model: a sum of uncoupled single-coordinate modes, as data (JSON schema v1)."""

from __future__ import annotations

import json
import math
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError, model_validator

from eddi.errors import ModelError
from eddi.model import EquationOfMotion, json_object
from eddi.terms import parse_term

MODAL_SUM_SCHEMA_VERSION = 1

#: Default damping library per mode: viscous plus amplitude-proportional (joint micro-slip)
#: loss; ``abs(v)*v`` makes the loss per cycle grow like amplitude cubed.
MODAL_DAMPING: tuple[str, ...] = ("v", "abs(v)*v")
#: Default stiffness library per mode: linear plus ``abs(x)*x``, a frequency shift that is
#: linear in amplitude (softening when negative), as a frictional joint shows.
MODAL_STIFFNESS: tuple[str, ...] = ("x", "abs(x)*x")


class ModalSumModel(BaseModel):
    """Measured velocity = sum of modal velocities, each mode an EDDI equation per unit mass.

    Attributes
    ----------
    kind : "modal_sum"
        Tag telling this model from a single :class:`~eddi.model.EquationOfMotion` in JSON.
    modes : tuple of EquationOfMotion
        One single-coordinate equation per mode, ``mass = 1`` (per unit modal mass).
    bands_hz : tuple of (float, float)
        Pass band used to separate each mode [Hz], same order as ``modes``.
    filter_order : int
        Butterworth order of the separation band-pass (applied forward and backward).
    initial_window_s : float
        Length of raw record after ``t0`` used to estimate the modal initial states [s].
    observable : str
        What the summed coordinate rate is, for people.
    notes : str
        Where the model came from.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    kind: Literal["modal_sum"] = "modal_sum"
    schema_version: int = MODAL_SUM_SCHEMA_VERSION
    modes: tuple[EquationOfMotion, ...]
    bands_hz: tuple[tuple[float, float], ...]
    filter_order: int = 8
    initial_window_s: float = 0.02
    observable: str = "velocity [m/s]"
    notes: str = ""

    @model_validator(mode="after")
    def _check(self) -> "ModalSumModel":
        if not self.modes:
            raise ValueError("a modal-sum model needs at least one mode")
        if len(self.bands_hz) != len(self.modes):
            raise ValueError(
                f"expected one band per mode ({len(self.modes)}), got {len(self.bands_hz)}"
            )
        for lo, hi in self.bands_hz:
            if not (0 <= lo < hi):
                raise ValueError(f"band ({lo}, {hi}) Hz must satisfy 0 <= low < high")
        if self.schema_version != MODAL_SUM_SCHEMA_VERSION:
            raise ValueError(
                f"schema_version {self.schema_version} is not supported "
                f"(expected {MODAL_SUM_SCHEMA_VERSION})"
            )
        if self.filter_order < 1 or not self.initial_window_s > 0:
            raise ValueError("filter_order must be >= 1 and initial_window_s > 0")
        return self

    @classmethod
    def from_json(cls, text: str) -> "ModalSumModel":
        """Load from JSON text, raising :class:`ModelError` (one line) when invalid."""
        data = json_object(text)
        try:
            return cls(**data)
        except ValidationError as exc:
            err = exc.errors()[0]
            where = ".".join(str(p) for p in err.get("loc", ()))
            msg = str(err.get("msg", "invalid")).removeprefix("Value error, ")
            raise ModelError(f"invalid modal-sum model: {where + ': ' if where else ''}{msg}") from None

    def to_json(self, indent: int | None = 2) -> str:
        """Serialise to JSON text (``"kind": "modal_sum"``)."""
        return self.model_dump_json(indent=indent)

    def natural_frequencies_hz(self) -> np.ndarray:
        """Small-amplitude natural frequency of each mode [Hz], shape (n_modes,)."""
        return np.array(
            [math.sqrt(max(m.linear_stiffness(), 0.0) / m.mass) / (2 * math.pi) for m in self.modes]
        )

    def damping_ratios(self) -> np.ndarray:
        """Small-amplitude (viscous ``v`` term) damping ratio of each mode, shape (n_modes,)."""
        out = []
        for m in self.modes:
            w = math.sqrt(max(m.linear_stiffness(), 0.0) / m.mass)
            b = sum(float(c) for text, c in m.damping.items()
                    if parse_term(text).exponents == (0, 1, 0, 0, 0, 0))
            out.append(b / (2.0 * m.mass * w) if w > 0 else math.nan)
        return np.array(out)

    def to_dict(self) -> dict[str, Any]:
        """A plain dict (JSON-ready), the same content as :meth:`to_json`."""
        return json.loads(self.model_dump_json())

    def equation_text(self) -> str:
        """One equation per mode, for people: ``v = sum_k v_k`` and each mode's equation."""
        f = self.natural_frequencies_hz()
        parts = [f"v = sum of {len(self.modes)} modal velocities;"]
        for k, (m, fk) in enumerate(zip(self.modes, f)):
            lo, hi = self.bands_hz[k]
            text = m.equation_text().replace(" = F(t)", " = 0")
            parts.append(f"mode {k + 1} ({fk:.5g} Hz, band {lo:.4g}-{hi:.4g} Hz): {text}")
        return " ".join(parts[:1]) + " " + "; ".join(parts[1:])


def load_any_model(text: str) -> EquationOfMotion | ModalSumModel:
    """Load either a single equation of motion or a modal-sum model from JSON text.

    A JSON object with ``"kind": "modal_sum"`` is a :class:`ModalSumModel`; anything else is
    read as an :class:`~eddi.model.EquationOfMotion` (also inside ``"equation_of_motion"``).

    Raises
    ------
    ModelError
        If the text is not JSON or not a valid model of either kind.
    """
    data = json_object(text)
    if data.get("kind") == "modal_sum":
        return ModalSumModel.from_json(text)
    if data.get("kind") == "mdof":  # schema version 2: several coordinates (eddi.mdof.model)
        from eddi.mdof.model import MdofModel

        return MdofModel.from_json(text)  # type: ignore[return-value]
    return EquationOfMotion.from_json(text)



def as_modal_sum(eom: EquationOfMotion, band_hz: tuple[float, float]) -> ModalSumModel:
    """Wrap a single equation of motion as a one-mode modal-sum model (for prediction)."""
    return ModalSumModel(modes=(eom,), bands_hz=(band_hz,))
