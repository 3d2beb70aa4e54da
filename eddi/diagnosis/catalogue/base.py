"""The mechanism interface of the catalogue: what a mechanism sees and what it returns.

Each mechanism says three things (the physics is written out in ``docs/effects.md``):

* its **signature**: what a test engineer sees when the model lacks it (``symptom``);
* its **regressors**: columns that enter the equation of motion linearly,
  ``m a + sum_j b_j B_j + sum_n k_n K_n + sum_i c_i C_i(x, v; h) = F``, for a given value
  of its few *shape* parameters ``h`` (a gap, a frequency...), found by a small search
  (:meth:`Mechanism.shape_grid`);
* how to turn fitted coefficients into a named effect or extra terms (:meth:`Mechanism.to_fit`),
  so the extended model is plain data the simulator and the simulated rig load.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass, field

import numpy as np

from eddi.identify_many import Basis
from eddi.model import Effect
from eddi.terms import parse_term


@dataclass(frozen=True)
class Signal:
    """One measured record as the mechanisms see it.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
        Uniform sample times.
    x, v, a : ndarray, shape (n,)
        Coordinate [m], rate [m/s] and its derivative [m/s^2].
    force : ndarray, shape (n,), [N]
        External force (zeros when not measured).
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    force: np.ndarray

    @property
    def dt(self) -> float:
        return float(self.t[1] - self.t[0])


@dataclass(frozen=True)
class Context:
    """What a mechanism may look at to choose its shape parameters (training data only).

    Attributes
    ----------
    signals : tuple of Signal
        Training records (whole records; the mask says which samples are used).
    masks : tuple of ndarray of bool
        Training samples of each record.
    residual : tuple of ndarray
        Equation-error residual of the baseline fit on each record (``F - m a - base``),
        NaN outside the training samples.
    mass : float
    x_peak, v_peak : float
        Largest ``|x|`` and ``|v|`` over the training samples.
    base_frequency_hz : float
        Linearised natural frequency of the baseline model.
    """

    signals: tuple[Signal, ...]
    masks: tuple[np.ndarray, ...]
    residual: tuple[np.ndarray, ...]
    mass: float
    x_peak: float
    v_peak: float
    base_frequency_hz: float


@dataclass(frozen=True)
class MechanismFit:
    """A mechanism's fitted parameters.

    Attributes
    ----------
    effect : Effect or None
        The named effect added to the model (None for a mechanism that adds plain terms).
    linear_stiffness_shift : float
        Amount to subtract from the model's ``x`` coefficient (second mode only) [N/m].
    damping, stiffness : dict of str to float
        Plain terms added to the model's damping / stiffness (term mechanisms, e.g. a smooth
        ``abs(x)*x`` stiffening).
    term_params : dict of str to float
        The parameters of a term mechanism, by name (SI units).
    """

    effect: Effect | None
    linear_stiffness_shift: float = 0.0
    damping: dict[str, float] = field(default_factory=dict)
    stiffness: dict[str, float] = field(default_factory=dict)
    term_params: dict[str, float] = field(default_factory=dict)

    @property
    def params(self) -> dict[str, float]:
        """The mechanism's parameters (SI units)."""
        return dict(self.effect.params) if self.effect is not None else dict(self.term_params)


class Mechanism(abc.ABC):
    """A physical mechanism: its signature, regressors and conversion to an effect."""

    #: Name (an effect of :data:`eddi.model.EFFECTS`, or a term mechanism).
    name: str = ""
    #: One-line physics, for people.
    physics: str = ""
    #: Shape parameters refined continuously (on a log scale) after the grid search.
    refine: tuple[str, ...] = ()
    #: The parameter that says how strong the mechanism is (its spread over folds is checked).
    strength: str = ""
    #: How EDDI fits it natively: ``"damping"`` (phase one), ``"stiffness"`` (phase two) or
    #: ``""`` (not a single-coordinate term: fitted on the baseline's residual force).
    native: str = ""
    #: Mechanisms that can reproduce the same held-out displacement (same loss per cycle, same
    #: frequency shift): a name needs the held-out records to tell them apart
    #: (:mod:`eddi.diagnosis.lookalike`).
    lookalikes: tuple[str, ...] = ()

    def bases(self, shape: dict[str, float], stiffness: tuple[str, ...]) -> tuple[Basis, ...]:
        """EDDI bases of the mechanism, in the order of :meth:`columns` (native ones only)."""
        return ()

    def strength_key(self, stiffness: tuple[str, ...]) -> str:
        """Name of the strength parameter for a baseline with these stiffness terms."""
        return self.strength

    def skip_reason(self, damping: tuple[str, ...], stiffness: tuple[str, ...],
                    effects: tuple[str, ...]) -> str | None:
        """Why this mechanism cannot be added to a model with these terms (None: it can)."""
        if self.name in effects:
            return "already in the model"
        return None

    def shape_grid(self, ctx: Context) -> list[dict[str, float]]:
        """Values of the shape parameters to try (one empty dict when there are none)."""
        return [{}]

    @abc.abstractmethod
    def columns(self, sig: Signal, shape: dict[str, float], stiffness: tuple[str, ...]) -> np.ndarray:
        """Regressors, shape (n, p), for one record."""

    def masked_columns(self, sig: Signal, shape: dict[str, float], stiffness: tuple[str, ...],
                       mask: np.ndarray) -> np.ndarray:
        """The rows ``mask`` of :meth:`columns` (a mechanism may compute only what they need)."""
        return self.columns(sig, shape, stiffness)[mask]

    @abc.abstractmethod
    def to_fit(self, coefs: np.ndarray, shape: dict[str, float], mass: float,
               stiffness: tuple[str, ...]) -> MechanismFit | None:
        """The effect for fitted coefficients (None when they are not physical)."""

    @abc.abstractmethod
    def symptom(self, fit: MechanismFit) -> str:
        """What the baseline got wrong, in a test engineer's words."""


def _has(terms: tuple[str, ...], text: str) -> bool:
    key = parse_term(text).canonical()
    return any(parse_term(t).canonical() == key for t in terms)
