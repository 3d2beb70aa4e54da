"""The identification pipeline: conditioned record -> EDDI -> refinement -> validation.

:class:`Pipeline` is the one object every command and the library use (``station identify``,
``validate``, ``report``, ``replay``, ``demo``, ``diagnose``'s pipeline baseline): its
fields are the choices (term libraries, phase-two route, refinement) with one set of
defaults, and its steps add no numerics of their own:

1. :meth:`Pipeline.condition`: :func:`eddi.conditioning.condition` (drift-free integration,
   impact end, free-response window);
2. :meth:`Pipeline.fit`: :func:`eddi.identify.identify` (EDDI) on the free-response window,
   then the output-error refinement it seeds (:mod:`eddi.refine`), kept when it lowers the
   displacement nrmse of records not used for the fit or, with none, unless it fits the
   signal the fit record's sensor measured measurably worse (:mod:`eddi.judge`: the
   validation simulation, driven from rest by the measured force, against the measured
   acceleration, within the judge's own uncertainty; the refinement fitted a free response
   from a fitted state, not this. The conditioned displacement is no judge on the fit
   record: it carries the integration's error, and EDDI was fitted to it), then validation;
3. :meth:`Pipeline.validate`: the simulation of a model for a conditioned record:

   * with a measured force and a rest seen before the impact: simulated from rest at the
     start of the motion, driven by the measured hammer force (zero after the impact has
     ended). During the impact the accelerometer measures the force too
     (``F = m a + B + K``); when the acceleration was measured, the two estimates are
     averaged with inverse-variance weights (:func:`fused_impact_force`);
     ``nrmse_force_sensor`` reports the validation driven by the force sensor alone;
   * otherwise: a free response from the measured state at the start of the window.

The choices the pipeline made (route, refinement kept or not and why, terms) are in
:attr:`PipelineResult.choices`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from eddi.calculus import decimate_centred, decimation_factor, samples_per_cycle_note, signal_angular_frequency
from eddi.conditioning import ConditionedSignal, condition
from eddi.energy import noise_level
from eddi.errors import IdentificationError, SignalError
from eddi.identify import IdentifiedModel, identify
from eddi.intervals import loose_coefficient_warnings, sampling_kernel_warning
from eddi.model import EquationOfMotion
from eddi.stability import model_warnings, poor_fit_warnings
from eddi.terms import DEFAULT_DAMPING, DEFAULT_STIFFNESS, coefficient_unit, parse_terms
from eddi.validate import Validation, validate

if TYPE_CHECKING:
    from eddi.refine import Refinement

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


def _texts(spec: str | Sequence[str]) -> tuple[str, ...]:
    return tuple(t.text for t in parse_terms(spec if isinstance(spec, str) else list(spec)))


@dataclass(frozen=True)
class Pipeline:
    """The identification pipeline, with one set of defaults for every caller.

    Parameters
    ----------
    damping, stiffness : str or sequence of str
        Candidate terms (comma-separated text or a sequence; see :mod:`eddi.terms`).
    route : {"auto", "potential", "lagrangian"}
        Phase-two route.
    refine : bool
        Try the output-error refinement after EDDI and keep it when it lowers the held-out
        validation error or, with none, unless it fits the fit record measurably worse (see
        the module notes).
    select : bool
        With ``refine``: drop the terms the data do not support (BIC backward elimination
        in the refinement, :mod:`eddi.refine`); the dropped terms and why are in
        ``choices.dropped``.
    """

    damping: tuple[str, ...] = DEFAULT_DAMPING
    stiffness: tuple[str, ...] = DEFAULT_STIFFNESS
    route: str = "auto"
    refine: bool = True
    select: bool = True
    #: ``mapper(fn, items)`` for the refinement's independent term-selection trials and the
    #: validations of :meth:`fit` (possibly forked processes: :mod:`station.forkmap`); None: in
    #: turn. The result is the same.
    mapper: Any = field(default=None, compare=False, repr=False)

    @classmethod
    def create(cls, damping: str | Sequence[str] | None = None, stiffness: str | Sequence[str] | None = None,
               route: str = "auto", refine: bool = True, select: bool = True) -> "Pipeline":
        """A pipeline from CLI-style arguments (None: the default library).

        Raises
        ------
        TermError
            On an unknown or duplicated term.
        """
        return cls(damping=_texts(damping) if damping else DEFAULT_DAMPING,
                   stiffness=_texts(stiffness) if stiffness else DEFAULT_STIFFNESS,
                   route=route, refine=bool(refine), select=bool(select))

    def condition(self, t: np.ndarray, *, acc: np.ndarray | None = None, vel: np.ndarray | None = None,
                  disp: np.ndarray | None = None, force: np.ndarray | None = None,
                  pretrigger_samples: int | None = None, ac_coupling_s: float | None = None,
                  adc_sinc_order: int | None = None, adc_osr: int | None = None) -> ConditionedSignal:
        """Step 1: :func:`eddi.conditioning.condition` (see there).

        ``adc_sinc_order``: the order ``K`` of the DAQ's sinc^K decimation filter (the
        ADS131M04's is 3; 1 for a mean over each sample interval; None or 0 for point samples or a
        compensated, flat passband). Its passband droop ``1 - K (omega dt)^2 / 24`` is a gain on
        the measured acceleration that biases nonlinear coefficients (a ``k3`` by ~1 % at 33
        samples per cycle with sinc3); the refinement then compares the model through the same
        kernel (:attr:`ConditionedSignal.sample_kernel_var` ``= K (R^2 - 1) / (12 R^2)`` for
        ``R = adc_osr`` modulator samples per output sample; ``K / 12`` when not given, the
        limit of a large ``R``: the ADS131M04's is 128-16256).
        """
        cond = condition(t, acc=acc, vel=vel, disp=disp, force=force, pretrigger_samples=pretrigger_samples,
                         ac_coupling_s=ac_coupling_s)
        if adc_sinc_order:
            k = int(adc_sinc_order)
            if not (k == adc_sinc_order and 1 <= k <= 8):
                raise SignalError(f"adc_sinc_order must be an integer in 1..8, got {adc_sinc_order}")
            r = adc_osr
            if r is not None and not (int(r) == r and r >= 1):
                raise SignalError(f"adc_osr must be an integer >= 1, got {adc_osr}")
            var = k / 12.0 if r is None else k * (r * r - 1) / (12.0 * r * r)
            cond = replace(cond, sample_kernel_var=var,
                           notes=cond.notes + (f"samples are sinc{k} means (decimation filter): compared through it",))
        return cond

    def _identify(self, cond: ConditionedSignal, mass: float) -> tuple[IdentifiedModel, int]:
        """EDDI (on a decimated copy of a densely sampled window), then the refinement.

        Returns the model (``window`` in the indices of ``cond``) and the decimation factor
        EDDI ran at (1: every sample; :func:`eddi.calculus.decimation_factor`).
        """
        w0, w1 = cond.window
        tw, xw, vw, aw = cond.t[w0:w1], cond.x[w0:w1], cond.v[w0:w1], cond.a[w0:w1]
        channel = REFINE_CHANNEL[cond.response]
        q = decimation_factor(cond.rate_hz, signal_angular_frequency(xw, vw, aw))
        if q == 1:
            return identify(cond.t, cond.x, cond.v, mass, damping=self.damping, stiffness=self.stiffness,
                            route=self.route, a=cond.a, window=cond.window, refine=channel if self.refine else False,
                            select=self.refine and self.select, mapper=self.mapper,
                            kernel_var=cond.sample_kernel_var), 1
        td, xd, vd, ad, _ = decimate_centred(tw, xw, vw, aw, q)
        # the noise of the samples (what EDDI would estimate on every sample)
        model = identify(td, xd, vd, mass, damping=self.damping, stiffness=self.stiffness, route=self.route, a=ad,
                         noise=(noise_level(xw), noise_level(vw)))
        model = replace(model, window=cond.window)
        if self.refine:
            from eddi.refine import refine_output_error  # local: scipy.optimize

            eom, info = refine_output_error(model.eom, tw, xw, vw, aw, channel=channel, select=self.select,
                                            mapper=self.mapper, kernel_var=cond.sample_kernel_var)
            model = replace(model, eom=eom, unrefined=model.eom, refinement=info)
        return model, q

    @staticmethod
    def _intervals(eom: EquationOfMotion, cond: ConditionedSignal, refinement: str,
                   ref: "Refinement | None") -> dict[str, dict[str, float]]:
        """95 % intervals of the returned model's coefficients.

        The refined model: the output-error covariance (:attr:`eddi.refine.Refinement.ci95`).
        EDDI's estimate (refinement rejected or off): its distance from the output-error fit
        of the same terms plus that fit's interval (:func:`eddi.refine.bounded_intervals`;
        with ``--no-refine`` the output-error fit is run for this alone, without selection).
        """
        from eddi.refine import bounded_intervals, confidence_intervals, refine_output_error

        if refinement == "kept" and ref is not None and ref.ci95:
            return ref.ci95
        w0, w1 = cond.window
        args = (cond.t[w0:w1], cond.x[w0:w1], cond.v[w0:w1], cond.a[w0:w1])
        channel = REFINE_CHANNEL[cond.response]
        kv = cond.sample_kernel_var
        if ref is None or not ref.unselected:
            try:
                _, ref = refine_output_error(eom, *args, channel=channel, kernel_var=kv)
            except (IdentificationError, SignalError):  # too short a window: the covariance at EDDI
                return confidence_intervals(eom, *args, channel=channel, kernel_var=kv)
        return bounded_intervals(eom, ref.unselected, ref.unselected_ci95)

    def validate(self, eom: EquationOfMotion, cond: ConditionedSignal) -> tuple[Validation, bool]:
        """Step 3: simulate ``eom`` for a conditioned record, compare over its free response.

        Returns
        -------
        validation : Validation
            Window in the indices of ``cond``.
        driven_by_force : bool
        """
        return validate_conditioned(eom, cond)

    def fit(self, cond: ConditionedSignal, mass: float, *, held_out: Sequence[ConditionedSignal] = (),
            sensor_only: bool = False) -> PipelineResult:
        """Step 2: EDDI, the refinement when it helps, validation.

        Parameters
        ----------
        cond : ConditionedSignal
            The record to identify on.
        mass : float
            Mass [kg] (or inertia), > 0.
        held_out : sequence of ConditionedSignal
            Records not used for the fit: the refinement is kept only when it lowers their
            mean validation nrmse (with none: the fit record's).
        sensor_only : bool
            Also validate with the force sensor alone, filling ``nrmse_force_sensor``.

        Returns
        -------
        PipelineResult

        Raises
        ------
        ModelError, TermError, SignalError, IdentificationError
            As :func:`eddi.identify.identify`.
        """
        model, q = self._identify(cond, mass)
        # the fit record and the held-out ones validated with the model and with EDDI's (the
        # refinement's judge): independent simulations, through the mapper (station diagnose:
        # forked processes; 0.7 s of the double beam's ~5 s that ran in turn)
        models = [model.eom] + ([model.unrefined] if model.unrefined is not None else [])
        recs = [cond, *held_out]
        got = (self.mapper or _in_turn)(lambda ij: validate_conditioned(models[ij[0]], recs[ij[1]]),
                                        [(i, j) for i in range(len(models)) for j in range(len(recs))])
        val, by_force = got[0]
        pairs = got[1:len(recs)]
        eddi_vals = (got[len(recs)][0], tuple(v for v, _ in got[len(recs) + 1:])) if len(models) > 1 else None
        held = tuple(v for v, _ in pairs)
        held_force = tuple(f for _, f in pairs)
        judged_on = f"held-out records ({len(held)})" if held else "fit record"
        judged = _judge_refinement(model, cond, held_out, val, held, judged_on, eddi_vals)
        model, val, held, eddi_held, refinement, reason, n_eddi, n_ref = judged
        nrmse_sensor = None
        if sensor_only and by_force and cond.acc_measured:
            nrmse_sensor = validate_conditioned(model.eom, cond, fused=False)[0].nrmse
        elif by_force and not cond.acc_measured:
            nrmse_sensor = val.nrmse
        eom = model.eom
        w0, w1 = cond.window
        ref = model.refinement
        ci95 = self._intervals(eom, cond, refinement, ref)
        dropped = {t: "not in the model" for t in self.damping + self.stiffness
                   if t not in eom.damping and t not in eom.stiffness}
        if refinement == "kept" and ref is not None:
            dropped.update(ref.dropped)
        warnings = list(cond_warnings(cond))
        f_hi = highest_frequency(cond)
        coarse = samples_per_cycle_note(cond.rate_hz, f_hi)
        if coarse:
            warnings.append(coarse)
        warnings += sampling_kernel_warning(eom, ci95, cond.rate_hz, f_hi, cond.sample_kernel_var)
        warnings += loose_coefficient_warnings(eom, ci95)
        unsound = model_warnings(eom, cond.x[w0:w1], cond.v[w0:w1])
        warnings += unsound
        warnings += [f"fit record: {w}" for w in val.warnings]
        warnings += [f"held-out record {i}: {w}" for i, h in enumerate(held) for w in h.warnings]
        warnings += poor_fit_warnings(val.nrmse, [h.nrmse for h in held])
        choices = PipelineChoices(
            route=model.route, route_scores=dict(model.route_scores), refinement=refinement,
            refinement_reason=reason, judged_on=judged_on, nrmse_eddi=n_eddi, nrmse_refined=n_ref,
            damping_terms=tuple(eom.damping), stiffness_terms=tuple(eom.stiffness),
            dropped=dropped, warnings=tuple(warnings), decimation=q,
            unstable=bool(unsound) or val.diverged or any(h.diverged for h in held))
        return PipelineResult(cond, model, val, by_force, nrmse_sensor, choices, held, eddi_held, held_force,
                              ci95, units_of(eom))


def units_of(eom: EquationOfMotion) -> dict[str, dict[str, str]]:
    """SI unit of every coefficient of ``eom`` (``rad`` / ``N m`` for an angle)."""
    angle = "rad" in eom.coordinate
    cu, fu = ("rad", "N m") if angle else ("m", "N")
    return {"damping": {t: coefficient_unit(t, cu, fu) for t in eom.damping},
            "stiffness": {t: coefficient_unit(t, cu, fu) for t in eom.stiffness}}


def highest_frequency(cond: ConditionedSignal, half_cycles: int = 10) -> float:
    """Frequency [Hz] of the first ``half_cycles`` half cycles of ``x`` in the free response.

    For a hardening (softening) system this is the highest (lowest) of the record; 0 when
    ``x`` has fewer than two zero crossings there.
    """
    w0, w1 = cond.window
    x = cond.x[w0:w1]
    idx = np.nonzero(np.signbit(x[1:]) != np.signbit(x[:-1]))[0]
    if idx.size < 2:
        return 0.0
    idx = idx[: half_cycles + 1]
    return 0.5 * (idx.size - 1) * cond.rate_hz / float(idx[-1] - idx[0])


def cond_warnings(cond: ConditionedSignal) -> tuple[str, ...]:
    """Warnings the conditioning raised (notes starting with ``WARNING:``)."""
    return tuple(n.removeprefix("WARNING: ") for n in cond.notes if n.startswith("WARNING: "))


def _in_turn(fn: Any, items: Sequence[Any]) -> list:
    return [fn(x) for x in items]


def _judge_refinement(model: IdentifiedModel, cond: ConditionedSignal, held_out: Sequence[ConditionedSignal],
                      val: Validation, held: tuple[Validation, ...], judged_on: str,
                      eddi_vals: tuple[Validation, tuple[Validation, ...]] | None = None) -> tuple:
    """Keep the refined model or EDDI's (see the module notes); returns what :meth:`Pipeline.fit` needs.

    ``eddi_vals``: EDDI's model validated on ``cond`` and on ``held_out`` (computed here when None).

    Returns
    -------
    model, val, held, eddi_held, refinement, reason, n_eddi, n_ref
        The chosen model with its validations, EDDI's held-out validations, ``"kept"`` /
        ``"rejected"`` / ``"off"``, the one-line reason and the compared errors.
    """
    eddi_held: tuple[Validation, ...] = ()
    if model.unrefined is None:
        refinement, reason, n_eddi, n_ref = "off", "refinement not asked for (--no-refine)", None, None
    else:
        if eddi_vals is None:
            eddi_vals = (validate_conditioned(model.unrefined, cond)[0],
                         tuple(validate_conditioned(model.unrefined, c)[0] for c in held_out))
        eddi_val, eddi_held = eddi_vals
        # held-out records: their displacement; the fit record alone: the signal its sensor
        # measured (the conditioned displacement carries the integration's error, and EDDI
        # was fitted to it: judged on it, a better refined model lost to EDDI's), the refined
        # model kept unless measurably worse (eddi.judge)
        div_ref = val.diverged or any(h.diverged for h in held)
        div_eddi = eddi_val.diverged or any(h.diverged for h in eddi_held)
        what = "displacement" if held else f"{SIGNAL_NAME[REFINE_CHANNEL[cond.response]]} (measured)"
        if held:
            n_ref, n_eddi = _mean_nrmse(held), _mean_nrmse(eddi_held)
            better = (div_ref, n_ref) <= (div_eddi, n_eddi)
            margin = ""
        else:
            from eddi.judge import WHITE_SIGMAS, judge_fit_record

            jd = judge_fit_record(model.eom, model.unrefined, cond, validations=(val, eddi_val))
            n_ref, n_eddi = jd.nrmse_refined, jd.nrmse_eddi
            better = (div_ref, jd.refined_worse) <= (div_eddi, False)
            margin = (f" (difference {jd.excess_sigmas:+.1f} noise sd; rejected only beyond {WHITE_SIGMAS:g} at the "
                      f"measured impact drive and at each model's best within +-{2 * jd.drive_uncertainty:.2g} of it)")
        if better:
            refinement = "kept"
            reason = f"{what} nrmse on the {judged_on} {n_eddi:.4g} (EDDI) -> {n_ref:.4g} (refined){margin}"
        else:
            refinement = "rejected"
            if div_ref and not div_eddi:
                reason = (f"the refined model's simulation diverged on the {judged_on} ({what} nrmse "
                          f"{n_ref:.4g}) although it fitted the measured signal better; EDDI estimate kept")
            else:
                reason = (f"refinement raised the {what} nrmse on the {judged_on}: {n_eddi:.4g} (EDDI) -> "
                          f"{n_ref:.4g}{margin}; EDDI estimate kept")
            model = replace(model, eom=model.unrefined)
            val, held = eddi_val, eddi_held
    return model, val, held, eddi_held, refinement, reason, n_eddi, n_ref


def _mean_nrmse(vals: Sequence[Validation]) -> float:
    x = [v.nrmse for v in vals]
    return float(np.mean(x)) if x and all(math.isfinite(e) for e in x) else math.inf


def identify_measurement(
    cond: ConditionedSignal,
    mass: float,
    *,
    damping: str | tuple[str, ...] | list[str] = DEFAULT_DAMPING,
    stiffness: str | tuple[str, ...] | list[str] = DEFAULT_STIFFNESS,
    route: str = "auto",
    sensor_only: bool = False,
    refine: bool = True,
) -> PipelineResult:
    """Identify and validate one conditioned record: ``Pipeline.create(...).fit(cond, mass)``.

    Parameters
    ----------
    cond : ConditionedSignal
        From :func:`eddi.conditioning.condition`.
    mass : float
        Mass [kg] (or inertia), > 0.
    damping, stiffness : str or sequence of str
        Candidate terms.
    route : {"auto", "potential", "lagrangian"}
    sensor_only : bool
        Also validate with the force sensor alone (``nrmse_force_sensor``).
    refine : bool
        Try the output-error refinement (kept unless it validates worse, see :class:`Pipeline`).

    Returns
    -------
    PipelineResult
    """
    return Pipeline.create(damping, stiffness, route, refine).fit(cond, mass, sensor_only=sensor_only)


def validate_conditioned(eom: EquationOfMotion, cond: ConditionedSignal,
                         fused: bool = True, *, drive_scale: float = 1.0) -> tuple[Validation, bool]:
    """Simulate ``eom`` for a conditioned record, compare over its free-response window.

    Driven from rest by the measured impact force when the record has a force and a rest
    before the impact (fused with ``m a + B + K`` when the acceleration was measured and
    ``fused``, see :func:`fused_impact_force`; times ``drive_scale``, which the refinement's
    judge varies within the impulse's uncertainty, :mod:`eddi.judge`); otherwise a free
    response from the measured state at the start of the window.

    Returns
    -------
    validation : Validation
        Window in the indices of ``cond``.
    driven_by_force : bool
    """
    force = cond.impact_force
    if force is not None and cond.impact_start > 0:
        s, e = cond.impact_start, cond.free_stop
        drive = fused_impact_force(cond, eom) if (cond.acc_measured and fused) else force
        if cond.sample_kernel_var > 0:
            drive = unsharpened(drive, cond.sample_kernel_var)
            s = max(0, s - 1)  # the correction spills one sample before the impact: keep its impulse
        if drive_scale != 1.0:
            drive = drive * drive_scale
        val = validate(eom, cond.t[s:e], cond.x[s:e], v=cond.v[s:e], force=drive[s:e],
                       window=(cond.free_start - s, cond.free_stop - s))
        return _shift(val, s), True
    return validate(eom, cond.t, cond.x, v=cond.v, window=cond.window), False


def unsharpened(drive: np.ndarray, kernel_var: float) -> np.ndarray:
    """The force before the DAQ's decimation filter, to second order: ``f - kv/2 * second difference``.

    The filter (kernel variance ``kv`` sample intervals^2) spreads a blow over its kernel:
    the impulse is kept, but the mode is driven by the force's spectrum at its frequency,
    ``1 - kv (omega dt)^2 / 2`` of it, and a nonlinear mode then rings at another amplitude
    and frequency (sinc3 at 25 samples a cycle: the true model's driven validation of a
    hardening oscillator drifted in phase to a displacement nrmse above 0.1). The correction
    keeps the impulse (the second difference of a pulse inside the record sums to 0; it
    spills one sample to each side of the pulse, which the simulation must start before:
    cut, the 0.1 % of the impulse there moved a 1 t, 3 Hz response by 0.13 % and the judge
    rejected the exact model).
    """
    d2 = np.zeros_like(drive)
    d2[1:-1] = drive[2:] - 2.0 * drive[1:-1] + drive[:-2]
    return drive - 0.5 * kernel_var * d2


def fused_impact_force(cond: ConditionedSignal, eom: EquationOfMotion) -> np.ndarray:
    """Impact force from the force sensor and the accelerometer, inverse-variance weighted.

    Parameters
    ----------
    cond : ConditionedSignal
        With a force channel and a measured acceleration.
    eom : EquationOfMotion
        Gives ``F_acc = m a + restoring_force(x, v)`` during the impact.

    Returns
    -------
    ndarray, shape (n,), [N]
        Zero outside ``[impact_start, impact_end)``.
    """
    f = cond.impact_force
    assert f is not None
    s0, s1 = cond.impact_start, cond.impact_end
    f_acc = eom.mass * cond.a[s0:s1] + eom.restoring_force(cond.x[s0:s1], cond.v[s0:s1])
    var_f = cond.force_noise_rms**2
    var_a = (eom.mass * cond.noise_rms) ** 2
    w = var_a / (var_f + var_a) if var_f + var_a > 0 else 0.5
    out = np.zeros_like(f)
    out[s0:s1] = w * f[s0:s1] + (1.0 - w) * f_acc
    return out


def _shift(val: Validation, offset: int) -> Validation:
    """The same validation with its window in the indices of the whole record."""
    w0, w1 = val.window
    return replace(val, window=(w0 + offset, w1 + offset))
