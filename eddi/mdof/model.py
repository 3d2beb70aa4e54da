"""A coupled equation of motion in several coordinates, as data (schema version 2).

::

    m_i q_i'' + sum_j b_ij B_ij(q, q') + sum_n k_in K_in(q) = u_i F(t),   i = 1..n
    y_c = sum_i phi_ci q_i                                                  (channel c)

``q`` are modal (``coordinates = "modal"``, ``phi`` the mode shapes at the channels) or
physical (``coordinates = "physical"``, ``phi`` the identity: one coordinate per channel).
``u`` is how the one measured force (at the driving point) enters each equation: the mode
shapes at the driving point for modal coordinates, 1 for the driven mass and 0 elsewhere for
physical ones. Terms are monomials in ``x1..xn`` and ``v1..vn`` (:mod:`eddi.mdof.terms`).

This is version 2 of the equation-of-motion schema (``eddi.model.SCHEMA_VERSION`` is 1):
a JSON object with ``"kind": "mdof"``. Single-coordinate models (version 1, no ``kind``)
load unchanged through :func:`load_model`.
"""

from __future__ import annotations

import json
import math
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError, model_validator

from eddi.errors import ModelError, TermError
from eddi.model import json_object
from eddi.mdof.terms import MultiTerm, parse_multi_term

MDOF_SCHEMA_VERSION = 2


class MdofModel(BaseModel):
    """``M q'' + B(q, q') + K(q) = u F``, ``y = Phi q``.

    Attributes
    ----------
    kind : "mdof"
    schema_version : int
        2.
    coordinates : "modal" or "physical"
    mass : tuple of float
        ``m_i`` [kg] (modal mass for the shape scaling of ``shapes``), > 0.
    input : tuple of float
        ``u_i``: share of the driving-point force in equation ``i`` (dimensionless).
    damping, stiffness : tuple of dict of str to float
        One dict per equation: term text -> coefficient (SI). Stiffness terms must not
        involve rates.
    channels : tuple of str
        Response channel names (``acc1``, ``acc2`` ...), in the order of ``shapes`` rows.
    shapes : tuple of tuple of float
        ``phi``, shape (n_channels, n_coords): channel displacement per unit coordinate.
    driving_point : str
        The channel at the hammer.
    stiffness_ci95 : tuple of dict of str to float
        Optional: half-width of the 95 % interval of each stiffness coefficient (same units),
        one dict per equation (empty: not estimated).
    notes : str
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    kind: Literal["mdof"] = "mdof"
    schema_version: int = MDOF_SCHEMA_VERSION
    coordinates: Literal["modal", "physical"] = "physical"
    mass: tuple[float, ...]
    input: tuple[float, ...]
    damping: tuple[dict[str, float], ...]
    stiffness: tuple[dict[str, float], ...]
    channels: tuple[str, ...]
    shapes: tuple[tuple[float, ...], ...]
    driving_point: str
    stiffness_ci95: tuple[dict[str, float], ...] = ()
    notes: str = ""

    @model_validator(mode="after")
    def _check(self) -> "MdofModel":
        n = len(self.mass)
        if self.schema_version != MDOF_SCHEMA_VERSION:
            raise ValueError(f"schema_version {self.schema_version} is not supported for kind 'mdof' "
                             f"(expected {MDOF_SCHEMA_VERSION})")
        if n < 1:
            raise ValueError("an mdof model needs at least one coordinate")
        for name, seq in (("input", self.input), ("damping", self.damping), ("stiffness", self.stiffness)):
            if len(seq) != n:
                raise ValueError(f"{name}: expected {n} entries (one per coordinate), got {len(seq)}")
        if any(not (math.isfinite(m) and m > 0) for m in self.mass):
            raise ValueError(f"mass: every entry must be > 0, got {list(self.mass)}")
        if len(self.shapes) != len(self.channels) or any(len(r) != n for r in self.shapes):
            raise ValueError(f"shapes: expected {len(self.channels)} rows of {n} values")
        if self.stiffness_ci95 and len(self.stiffness_ci95) != n:
            raise ValueError(f"stiffness_ci95: expected {n} entries (one per coordinate), got {len(self.stiffness_ci95)}")
        if self.driving_point not in self.channels:
            raise ValueError(f"driving_point {self.driving_point!r} is not among channels {list(self.channels)}")
        for i, (bd, kd) in enumerate(zip(self.damping, self.stiffness)):
            for text, c in {**bd, **kd}.items():
                try:
                    term = parse_multi_term(text, n)
                except TermError as exc:
                    raise ValueError(f"equation {i + 1}: {exc}") from None
                if not math.isfinite(c):
                    raise ValueError(f"equation {i + 1}: coefficient of {text!r} is not finite")
                if text in kd and term.depends_on_v:
                    raise ValueError(f"equation {i + 1}: stiffness term {text!r} depends on a rate")
        return self

    # -- construction -----------------------------------------------------------------
    @classmethod
    def create(cls, **kwargs: Any) -> "MdofModel":
        """Build a model, raising :class:`ModelError` (one line) when invalid."""
        try:
            return cls(**kwargs)
        except ValidationError as exc:
            err = exc.errors()[0]
            where = ".".join(str(p) for p in err.get("loc", ()))
            msg = str(err.get("msg", "invalid")).removeprefix("Value error, ")
            raise ModelError(f"invalid mdof model: {where + ': ' if where else ''}{msg}") from None

    @classmethod
    def from_json(cls, text: str) -> "MdofModel":
        """Load from JSON text (:class:`ModelError` when invalid)."""
        return cls.create(**json_object(text))

    def to_json(self, indent: int | None = 2) -> str:
        """Serialise to JSON text."""
        return self.model_dump_json(indent=indent)

    # -- derived ----------------------------------------------------------------------
    @property
    def n_coords(self) -> int:
        return len(self.mass)

    @property
    def phi(self) -> np.ndarray:
        """Shapes, shape (n_channels, n_coords)."""
        return np.array(self.shapes, dtype=float).reshape(len(self.channels), self.n_coords)

    def terms(self, i: int) -> list[tuple[MultiTerm, float]]:
        """Parsed terms of equation ``i`` (damping then stiffness) with their coefficients."""
        return [(parse_multi_term(t, self.n_coords), float(c))
                for t, c in {**self.damping[i], **self.stiffness[i]}.items()]

    def internal_force(self, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``B + K`` of every equation for states of shape (n_coords, n_samples)."""
        out = np.zeros((self.n_coords, x.shape[1]))
        for i in range(self.n_coords):
            for term, c in self.terms(i):
                out[i] += c * term(x, v)
        return out

    def linear_matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``M``, ``C``, ``K`` of the linear terms, each (n, n)."""
        n = self.n_coords
        c_mat = np.zeros((n, n))
        k_mat = np.zeros((n, n))
        for i in range(n):
            for term, c in self.terms(i):
                e = term.exponents
                if term.degree == 1 and (e[0].any() or e[1].any()):
                    k = int(np.nonzero(e[0] + e[1])[0][0])
                    (c_mat if e[1].any() else k_mat)[i, k] += c
        return np.diag(self.mass), c_mat, k_mat

    def natural_frequencies_hz(self) -> np.ndarray:
        """Undamped small-amplitude frequencies [Hz], ascending (``K phi = w^2 M phi``)."""
        m, _c, k = self.linear_matrices()
        w2 = np.linalg.eigvals(np.linalg.solve(m, k))
        return np.sort(np.sqrt(np.clip(w2.real, 0.0, None)) / (2 * math.pi))

    def equation_text(self) -> str:
        """Every equation written out, for people."""
        lines = []
        for i in range(self.n_coords):
            rhs = f"{self.input[i]:+.4g}*F(t)" if self.input[i] else "0"
            parts = [f"{self.mass[i]:.6g}*q{i + 1}''"]
            parts += [f"{c:+.5g}*{t}" for t, c in {**self.damping[i], **self.stiffness[i]}.items()]
            lines.append(" ".join(parts) + f" = {rhs}")
        return "; ".join(lines)



def is_mdof_json(text: str) -> bool:
    """True when the JSON text is an object with ``"kind": "mdof"`` (no error otherwise)."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError:
        return False
    return isinstance(data, dict) and data.get("kind") == "mdof"
