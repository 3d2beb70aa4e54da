"""The identification pipeline: conditioned record -> EDDI -> refinement -> validation.

:class:`Pipeline` is the one object every command and the library use (``station identify``,
``validate``, ``report``, ``replay``, ``demo``, ``diagnose``'s pipeline baseline): its
fields are the choices (term libraries, phase-two route, refinement) with one set of
defaults, and its steps add no numerics of their own:

1. :meth:`Pipeline.condition`: :func:`eddi.conditioning.condition` (drift-free integration,
   impact end, free-response window);
2. :meth:`Pipeline.fit`: :func:`eddi.identify.identify` (EDDI) on the free-response window
   (``route="auto"`` with the refinement and no held-out record: a seed, phase two on
   :data:`FIRST_ROUTE` alone on a coarser grid; both routes scored, on the default grid, only
   when EDDI's estimate is delivered), then the output-error refinement it seeds
   (:mod:`eddi.refine`), kept when it lowers the
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

Both steps run with one BLAS thread (:func:`eddi.threads.one_blas_thread`), as the station
CLI does for its whole process: on the 45 s x 19.2 kHz record an in-process call with
OpenBLAS's default pool (a second thread spin-waiting for small products) cost 1.7x the CPU
and 1.6x the wall time at load 7.6 (``benchmarks/bench_identify_speed.py --in-process``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from eddi.calculus import decimate_centred, decimation_factor, samples_per_cycle_note, signal_angular_frequency
from eddi.conditioning import ConditionedSignal, condition
from eddi.driven_validation import fused_impact_force, unsharpened, validate_conditioned
from eddi.energy import noise_level
from eddi.equation_error import equation_error_fit
from eddi.errors import IdentificationError, SignalError, TooShortToRefine
from eddi.identify import IdentifiedModel, identify
from eddi.intervals import (loose_coefficient_warnings, sampling_kernel_margin, sampling_kernel_warning,
                            selection_warning)
from eddi.memory import keep_freed_memory
from eddi.model import EquationOfMotion
from eddi.pipeline_result import REFINE_CHANNEL, SIGNAL_NAME, PipelineChoices, PipelineResult, units_of
from eddi.refinement_choice import judge_refinement
from eddi.stability import POOR_FIT_NRMSE, model_warnings, poor_fit_warnings
from eddi.terms import DEFAULT_DAMPING, DEFAULT_STIFFNESS, parse_terms
from eddi.threads import one_blas_thread
from eddi.validate import Validation

if TYPE_CHECKING:
    from eddi.refine import Refinement

__all__ = ["Pipeline", "PipelineChoices", "PipelineResult", "REFINE_CHANNEL", "SIGNAL_NAME", "cond_warnings",
           "fused_impact_force", "highest_frequency", "identify_measurement", "units_of", "unsharpened",
           "validate_conditioned"]


#: Phase-two route that seeds the refinement when ``route="auto"``, the refinement is asked for
#: and no held-out record judges it (the cheaper of the two: ~10 of EDDI's ~50 ms on the 45 s
#: record, where the potential route and the two route scores cost ~28); "" scores both first.
FIRST_ROUTE = "lagrangian"
#: ... and the grid EDDI seeds it on: ``omega q dt`` at most this [rad] (~21 samples a cycle of the
#: fastest local oscillation, against :data:`eddi.calculus.DECIMATE_H_OMEGA`'s ~63 for an EDDI
#: estimate that is delivered): the refinement fits every block mean from it.
SEED_H_OMEGA = 0.3
#: ... and that refinement ends a stage when a step lowers the sum of squares by less than this
#: many times its mean square per compared value (``refine_output_error(min_gain=)``: one unit of
#: chi-square once the model fits; the Gauss-Newton step then left moves the coefficients by well
#: under a standard error: <= 5.1e-5 of their ci95 on 57 records, 0.05-500 kg, 256 Hz-50 kHz,
#: 20-60 dB, docs/performance.md; one RK4 sensitivity pass less of 5 on the 45 s record). A fit
#: that is not kept, diverges or fits poorly (where the premise "the model fits" fails: a record
#: outside the library stopped early in a worse place, nrmse 0.53 -> 1.19) goes on to the scored
#: pipeline, which runs every stage to rounding (:func:`_needs_scored_pipeline`). Not for a model
#: with a ``sign`` term or an effect (:func:`eddi.refine_grid.smooth_model`: no smooth sum of
#: squares). None: to rounding here too (before session 15).
SEED_MIN_GAIN: float | None = 1.0


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

    @one_blas_thread()
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
        keep_freed_memory()  # the next call's arrays reuse this one's pages (eddi.memory)
        cond = condition(t, acc=acc, vel=vel, disp=disp, force=force, pretrigger_samples=pretrigger_samples,
                         ac_coupling_s=ac_coupling_s)
        if adc_sinc_order is not None:  # stated: 0 point samples (or a flat passband), K a sinc^K decimator
            cond = replace(cond, sample_kernel_known=True)
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

    def _eddi(self, cond: ConditionedSignal, mass: float, route: str,
              h_omega: float | None = None) -> tuple[IdentifiedModel, int]:
        """EDDI with phase two on ``route`` (on a decimated copy of a densely sampled window).

        Returns the model (``window`` in the indices of ``cond``) and the decimation factor
        EDDI ran at (1: every sample; :func:`eddi.calculus.decimation_factor` with ``h_omega``).
        """
        w0, w1 = cond.window
        tw, xw, vw, aw = cond.t[w0:w1], cond.x[w0:w1], cond.v[w0:w1], cond.a[w0:w1]
        q = decimation_factor(cond.rate_hz, signal_angular_frequency(xw, vw, aw), h_omega)
        if q == 1:
            return identify(cond.t, cond.x, cond.v, mass, damping=self.damping, stiffness=self.stiffness,
                            route=route, a=cond.a, window=cond.window), 1
        td, xd, vd, ad, _ = decimate_centred(tw, xw, vw, aw, q)
        # the noise of the samples (what EDDI would estimate on every sample)
        model = identify(td, xd, vd, mass, damping=self.damping, stiffness=self.stiffness, route=route, a=ad,
                         noise=(noise_level(xw), noise_level(vw)))
        return replace(model, window=cond.window), q

    def _identify(self, cond: ConditionedSignal, mass: float, route: str,
                  h_omega: float | None = None, min_gain: float | None = None) -> tuple[IdentifiedModel, int, str]:
        """:meth:`_eddi`, then the refinement it seeds (when asked for).

        Returns the model, the decimation factor and, when the record is too short to refine
        (:class:`~eddi.errors.TooShortToRefine`), why: EDDI's estimate is then returned as it is
        (a 28-sample, 256 Hz ring-down fitted 11 parameters by EDDI and was refused outright:
        "refinement of 11 parameters needs >= 44 compared values"); else ''.
        """
        model, q = self._eddi(cond, mass, route, h_omega)
        if self.refine:
            from eddi.refine import refine_output_error  # local: scipy.optimize
            from eddi.refine_grid import smooth_model

            w0, w1 = cond.window
            # a sign term's switches make the sum of squares rough (secant Jacobians, eddi.secant_jacobian):
            # no Gauss-Newton argument for stopping early there (a held-out Coulomb record moved 0.6 of its
            # ci95 with SEED_MIN_GAIN): to rounding, as before
            min_gain = min_gain if smooth_model(model.eom) else None
            try:
                eom, info = refine_output_error(model.eom, cond.t[w0:w1], cond.x[w0:w1], cond.v[w0:w1],
                                                cond.a[w0:w1], channel=REFINE_CHANNEL[cond.response],
                                                select=self.select, mapper=self.mapper,
                                                kernel_var=cond.sample_kernel_var,
                                                kernel_known=cond.sample_kernel_known, min_gain=min_gain)
            except TooShortToRefine as exc:
                return model, q, f"{TOO_SHORT_TO_REFINE} ({exc}): EDDI's estimate, not refined"
            model = replace(model, eom=eom, unrefined=model.eom, refinement=info)
        return model, q, ""

    @staticmethod
    def _intervals(eom: EquationOfMotion, cond: ConditionedSignal, refinement: str,
                   ref: "Refinement | None") -> tuple[dict[str, dict[str, float]], dict[str, dict[str, float]] | None]:
        """95 % intervals of the returned model's coefficients (the noise's), and the margin an
        unstated sampling kernel needs as the record measured it (None: not measured).

        The refined model: the output-error covariance (:attr:`eddi.refine.Refinement.ci95`).
        EDDI's estimate (refinement rejected or off): its distance from the output-error fit
        of the same terms plus that fit's interval (:func:`eddi.refine.bounded_intervals`;
        with ``--no-refine`` the output-error fit is run for this alone, without selection).
        """
        from eddi.refine import bounded_intervals, confidence_intervals, refine_output_error

        if refinement == "kept" and ref is not None and ref.ci95:
            return ref.ci95, ref.kernel_margin or None
        w0, w1 = cond.window
        args = (cond.t[w0:w1], cond.x[w0:w1], cond.v[w0:w1], cond.a[w0:w1])
        channel = REFINE_CHANNEL[cond.response]
        kv = cond.sample_kernel_var
        if ref is None or not ref.unselected:
            try:
                _, ref = refine_output_error(eom, *args, channel=channel, kernel_var=kv,
                                             kernel_known=cond.sample_kernel_known)
            except (IdentificationError, SignalError):  # too short a window: the covariance at EDDI
                return confidence_intervals(eom, *args, channel=channel, kernel_var=kv), None
        return bounded_intervals(eom, ref.unselected, ref.unselected_ci95), ref.unselected_kernel_margin or None

    def validate(self, eom: EquationOfMotion, cond: ConditionedSignal) -> tuple[Validation, bool]:
        """Step 3: simulate ``eom`` for a conditioned record, compare over its free response.

        Returns
        -------
        validation : Validation
            Window in the indices of ``cond``.
        driven_by_force : bool
        """
        return validate_conditioned(eom, cond)

    @one_blas_thread()
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
        keep_freed_memory()  # (eddi.memory)
        if self.route == "auto" and self.refine and FIRST_ROUTE and not held_out:
            # one route on a coarse grid seeds the refinement (from either route, on either grid, it
            # reaches the same optimum: <= 2.5e-4 of its ci95 on 55 records, docs/speed.md). The
            # scored pipeline (both routes on the default grid) runs again on the symptoms that it
            # may deliver something else (_needs_scored_pipeline). Held-out records judge the
            # refinement against its estimate (diagnose's baseline, sessions): scored, as before.
            res = self._fit(cond, mass, held_out, sensor_only, FIRST_ROUTE, SEED_H_OMEGA, SEED_MIN_GAIN)
            if not _needs_scored_pipeline(res):
                return res
        return self._fit(cond, mass, held_out, sensor_only, self.route)

    def _fit(self, cond: ConditionedSignal, mass: float, held_out: Sequence[ConditionedSignal],
             sensor_only: bool, route: str, h_omega: float | None = None,
             min_gain: float | None = None) -> PipelineResult:
        """:meth:`fit` with EDDI's phase two on ``route``, on a grid of ``h_omega`` (None: the default),
        the refinement's stages ended at ``min_gain`` (None: to rounding)."""
        model, q, too_short = self._identify(cond, mass, route, h_omega, min_gain)
        # the fit record and the held-out ones validated with the model and with EDDI's (the
        # refinement's judge): independent simulations, through the mapper (station diagnose:
        # forked processes; 0.7 s of the double beam's ~5 s that ran in turn)
        models = [model.eom] + ([model.unrefined] if model.unrefined is not None else [])
        # with held-out records, the equation-error fit of the same terms is judged beside them
        # (eddi.equation_error: it need not lose to an ill-determined refinement)
        ee = equation_error_fit(model.eom, cond) if held_out else None
        if ee is not None:
            models.append(ee)
        recs = [cond, *held_out]
        # EDDI's on the fit record alone serves the judge (eddi.judge), which reads every k-th
        # sample of it: simulated at those (the whole validation again only if it is delivered)
        from eddi.judge import judge_stride  # local, as refinement_choice imports the judge

        every = judge_stride(cond) if not held_out and not cond.sample_kernel_var else 1
        got = (self.mapper or _in_turn)(
            lambda ij: validate_conditioned(models[ij[0]], recs[ij[1]], every=every if ij == (1, 0) else 1),
            [(i, j) for i in range(len(models)) for j in range(len(recs))])
        n = len(recs)
        val, by_force = got[0]
        pairs = got[1:n]
        eddi_vals = (got[n][0], tuple(v for v, _ in got[n + 1:2 * n])) if model.unrefined is not None else None
        ee_vals = (ee, got[-n][0], tuple(v for v, _ in got[-n + 1:])) if ee is not None else None
        held = tuple(v for v, _ in pairs)
        held_force = tuple(f for _, f in pairs)
        judged_on = f"held-out records ({len(held)})" if held else "fit record"
        judged = judge_refinement(model, cond, held_out, val, held, judged_on, eddi_vals, off_reason=too_short,
                                  ee_vals=ee_vals)
        model, val, held, eddi_held, refinement, reason, n_eddi, n_ref = judged
        nrmse_sensor = None
        if sensor_only and by_force and cond.acc_measured:
            nrmse_sensor = validate_conditioned(model.eom, cond, fused=False)[0].nrmse
        elif by_force and not cond.acc_measured:
            nrmse_sensor = val.nrmse
        eom = model.eom
        w0, w1 = cond.window
        ref = model.refinement
        ci95, measured = self._intervals(eom, cond, refinement, ref)
        dropped = {t: "not in the model" for t in self.damping + self.stiffness
                   if t not in eom.damping and t not in eom.stiffness}
        if refinement == "kept" and ref is not None:
            dropped.update(ref.dropped)
        warnings = list(cond_warnings(cond)) + ([too_short] if too_short else [])
        f_hi = highest_frequency(cond)
        coarse = samples_per_cycle_note(cond.rate_hz, f_hi)
        ci95, margin_note = sampling_kernel_margin(eom, ci95, cond.rate_hz, f_hi, cond.sample_kernel_known,
                                                   measured, ref.kernel_estimate if ref is not None else None)
        if coarse:  # one sentence about coarse sampling
            warnings.append("; ".join((coarse, *margin_note)))
        else:
            warnings += margin_note
        warnings += sampling_kernel_warning(eom, ci95, cond.rate_hz, f_hi, cond.sample_kernel_var)
        if refinement == "kept" and ref is not None and ref.ci95_given_selection:
            warnings += selection_warning(eom, ref.ci95, ref.ci95_given_selection, tuple(ref.dropped))
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


#: How the refinement's reason and the warning begin when the fit record is too short to refine.
TOO_SHORT_TO_REFINE = "the record is too short to refine"


def _needs_scored_pipeline(res: PipelineResult) -> bool:
    """Whether a fit seeded by :data:`FIRST_ROUTE` may differ from the scored pipeline's.

    The refinement not kept (EDDI's estimate is delivered: the better-scored route's), the seed's
    or the delivered model's validation diverged (the judge compared the refinement with a seed
    that blew up: session 13's Coulomb record kept a refined model that blew up too), or a poor
    fit (nrmse above :data:`eddi.stability.POOR_FIT_NRMSE`: a model outside the library, where the
    start can decide the optimum).
    """
    ch = res.choices
    if ch is None or ch.refinement != "kept" or ch.unstable or res.validation.diverged:
        return True
    if ch.nrmse_eddi is None or not math.isfinite(ch.nrmse_eddi):
        return True
    return not res.validation.nrmse <= POOR_FIT_NRMSE


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

