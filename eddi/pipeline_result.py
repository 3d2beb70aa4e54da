"""What :class:`eddi.fit_record.Pipeline` returns: the result, the choices it made, the units.

:class:`PipelineResult` (the model, its validations and 95 % intervals) and
:class:`PipelineChoices` (route, refinement kept or not and why, terms, warnings) are frozen
dataclasses; :func:`units_of` gives every coefficient's SI unit. No numerics here.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from eddi.conditioning import ConditionedSignal
from eddi.identify import IdentifiedModel
from eddi.model import EquationOfMotion
from eddi.terms import coefficient_unit
from eddi.validate import Validation

#: The measured-signal name of each conditioned response: what the refinement fits.
REFINE_CHANNEL = {"acc": "a", "vel": "v", "disp": "x"}
#: Words for the signals.
SIGNAL_NAME = {"a": "acceleration", "v": "velocity", "x": "displacement"}


@dataclass(frozen=True)
class PipelineChoices:
    """What the pipeline chose, and why (for the JSON and the report).

    Attributes
    ----------
    route : str
        Phase-two route used (``"potential"`` or ``"lagrangian"``).
    route_scores : dict of str to float
        Free-response nrmse of each route tried (``route="auto"``).
    refinement : str
        ``"kept"``, ``"rejected"`` (tried, EDDI estimate kept) or ``"off"``.
    refinement_reason : str
        One line: the errors compared and on what.
    judged_on : str
        ``"held-out records (N)"`` or ``"fit record"``.
    nrmse_eddi, nrmse_refined : float or None
        The compared validation errors (None when not refined): mean displacement nrmse of
        the held-out records, or the fit record's measured-signal nrmse of
        :func:`eddi.judge.judge_fit_record` (each at its best drive within the impulse's
        uncertainty).
    damping_terms, stiffness_terms : tuple of str
        Terms in the returned model.
    dropped : dict of str to str
        Candidate terms not in the model, and why.
    warnings : tuple of str
        Plain sentences (unstable model, coarse sampling...).
    unstable : bool
        The model is not a trustworthy equation of motion: negative stiffness or damping at
        the record's amplitudes (:func:`eddi.stability.model_warnings`), or a simulation of the
        fit or a held-out record that blows up, grows or does not decay
        (:func:`eddi.stability.response_warnings`). The station's commands exit with code 1.
    decimation : int
        EDDI ran on every ``decimation``-th sample of the window (acceleration: block means;
        :func:`eddi.calculus.decimate_centred`), 1 for every sample: a record sampled far
        faster than it moves (>= 5x more than ~63 samples per fastest local cycle) gives the
        same coefficients on the coarser grid at a fraction of the cost. The refinement and
        the validation always use every sample.
    """

    route: str
    route_scores: dict[str, float]
    refinement: str
    refinement_reason: str
    judged_on: str
    nrmse_eddi: float | None
    nrmse_refined: float | None
    damping_terms: tuple[str, ...]
    stiffness_terms: tuple[str, ...]
    dropped: dict[str, str] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    decimation: int = 1
    unstable: bool = False

    def as_dict(self) -> dict[str, object]:
        """JSON-ready."""
        return {"route": self.route, "route_scores": dict(self.route_scores),
                "refinement": self.refinement, "refinement_reason": self.refinement_reason,
                "judged_on": self.judged_on, "nrmse_eddi": self.nrmse_eddi,
                "nrmse_refined": self.nrmse_refined, "damping_terms": list(self.damping_terms),
                "stiffness_terms": list(self.stiffness_terms), "dropped": dict(self.dropped),
                "warnings": list(self.warnings), "eddi_decimation": self.decimation,
                "unstable": self.unstable}


@dataclass(frozen=True)
class PipelineResult:
    """An identified and validated model.

    Attributes
    ----------
    conditioned : ConditionedSignal
        The signals identification ran on.
    model : IdentifiedModel
        What :func:`eddi.identify.identify` returned, with ``model.eom`` the model the
        pipeline chose (refined or EDDI's; ``model.unrefined`` is EDDI's when refinement ran).
    validation : Validation
        Simulation of ``model.eom`` against ``conditioned.x`` over the free-response window
        (``validation.window`` is in the indices of ``conditioned``).
    driven_by_force : bool
        True when the validation was driven by the measured force from rest.
    nrmse_force_sensor : float or None
        The nrmse when driven by the force sensor alone (None when not computed).
    choices : PipelineChoices or None
        What the pipeline chose (None only for results built by hand).
    held_out : tuple of Validation
        Validation of ``model.eom`` on the held-out records given to :meth:`Pipeline.fit`.
    eddi_held_out : tuple of Validation
        The same for the EDDI estimate, when refinement ran.
    held_out_driven_by_force : tuple of bool
        Per held-out record: simulated from rest with its measured force.
    ci95 : dict
        ``{"damping": {term: half width}, "stiffness": {...}}``: 95 % confidence intervals of
        ``model.eom``'s coefficients (refined: the output-error covariance; EDDI's estimate:
        its distance from the output-error fit plus that fit's interval; see
        :meth:`Pipeline._intervals`).
    units : dict
        The same keys: SI unit of each coefficient (:func:`eddi.terms.coefficient_unit`).
    """

    conditioned: ConditionedSignal
    model: IdentifiedModel
    validation: Validation
    driven_by_force: bool
    nrmse_force_sensor: float | None = None
    choices: PipelineChoices | None = None
    held_out: tuple[Validation, ...] = ()
    eddi_held_out: tuple[Validation, ...] = ()
    held_out_driven_by_force: tuple[bool, ...] = ()
    ci95: dict[str, dict[str, float]] = field(default_factory=dict)
    units: dict[str, dict[str, str]] = field(default_factory=dict)

    def driven_by_force_of(self, i: int) -> bool:
        """Whether held-out record ``i`` was simulated driven by its measured force."""
        return self.held_out_driven_by_force[i]

    @property
    def warnings(self) -> tuple[str, ...]:
        """The pipeline's warnings (empty when none)."""
        return self.choices.warnings if self.choices is not None else ()

    @property
    def unstable(self) -> bool:
        """The model is flagged (:attr:`PipelineChoices.unstable`)."""
        return self.choices.unstable if self.choices is not None else False


def units_of(eom: EquationOfMotion) -> dict[str, dict[str, str]]:
    """SI unit of every coefficient of ``eom`` (``rad`` / ``N m`` for an angle)."""
    angle = "rad" in eom.coordinate
    cu, fu = ("rad", "N m") if angle else ("m", "N")
    return {"damping": {t: coefficient_unit(t, cu, fu) for t in eom.damping},
            "stiffness": {t: coefficient_unit(t, cu, fu) for t in eom.stiffness}}

