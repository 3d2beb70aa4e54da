"""Results of the loop as frozen dataclasses (arrays only where figures need them)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from eddi.diagnosis.records import Part
from eddi.model import EquationOfMotion
from eddi.multimode import ModalSumModel


@dataclass(frozen=True)
class Symptom:
    """One thing the baseline (or the measurement chain) gets wrong, in numbers and words.

    Attributes
    ----------
    kind : str
        ``frequency_bias``, ``energy_mismatch``, ``residual_peak``, ``low_frequency_drift``,
        ``growth``, ``clipping``, ``double_hit``, ``impulse_mass``, ``base_motion``.
    text : str
        One sentence for a test engineer.
    values : dict of str to float
        The numbers behind it (units in the key names: ``_pct``, ``_hz``, ``_m``...).
    """

    kind: str
    text: str
    values: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class NoiseFloor:
    """The held-out error a correct model would have, given the records' noise and conditioning.

    Attributes
    ----------
    nrmse : float
        Mean over the held-out parts of :attr:`fold_nrmse`.
    fold_nrmse : tuple of float
        Per held-out part: how far one more draw of the measured noise moves the conditioned
        coordinate and the baseline's held-out simulation, ``sqrt(d_cond^2 + d_pred^2)``
        relative to the part's norm, the median over
        :data:`~eddi.diagnosis.measure.DRAWS` draws (:mod:`eddi.diagnosis.measure`).
    noise_rms : tuple of float
        Measured noise RMS of each record's response channel (SI units).
    conditioning_nrmse : tuple of float
        Per record: change of the conditioned coordinate over its free response under one
        more draw of the noise (relative to its norm; the median over the draws).
    method : str
    prediction_nrmse : tuple of float
        Per held-out part: ``d_pred``, how far the baseline's refit simulation moves under
        a draw (the median over the draws; NaN where the refit failed). When it dominates, the floor is mostly the
        refit's sensitivity to one noise draw (see the "uncertain none" note of the loop).
    chain_nrmse : tuple of float
        Per held-out part: how far the baseline's held-out simulation moves when the record is
        measured through a chain off by the stated tolerances (sensor gain, sample clock),
        ``sqrt(d_gain^2 + d_clock^2)`` (:mod:`eddi.diagnosis.tolerance`); it joins the noise's
        share in quadrature in :attr:`fold_nrmse`. Empty when not measured.
    chain : dict
        The tolerances used: ``gain_tolerance`` (relative), ``clock_ppm``, ``gain_per_part``
        (the gain assumed for each part: the tolerance, or the smaller difference the
        impulse/momentum ratios measured), ``source``.
    noise_fold_nrmse : tuple of float
        Per held-out part: the floor of the noise and conditioning alone (the session-8 floor,
        at least :data:`~eddi.diagnosis.settings.MIN_FLOOR`), before the chain's share joined.
    part_conditioning_nrmse : tuple of float
        Per held-out part: ``d_cond``, how far a draw moves the conditioned coordinate over the
        part (the median over the draws; NaN where the draws failed).
    data_fold_nrmse : tuple of float
        Per held-out part: the floor of the data, :attr:`fold_nrmse` with ``d_pred`` counted
        at most :data:`~eddi.diagnosis.settings.PRED_CAP` times ``sqrt(d_cond^2 + d_chain^2)``
        (session 12): a baseline whose own refit swings with the noise is ill-determined, and
        that is no excuse for its error. ``none`` is judged against it (its mean
        :attr:`data_nrmse`). Empty when not measured (then :attr:`nrmse` serves).
    """

    nrmse: float
    fold_nrmse: tuple[float, ...]
    noise_rms: tuple[float, ...]
    conditioning_nrmse: tuple[float, ...]
    method: str
    prediction_nrmse: tuple[float, ...] = ()
    chain_nrmse: tuple[float, ...] = ()
    chain: dict[str, Any] = field(default_factory=dict)
    noise_fold_nrmse: tuple[float, ...] = ()
    part_conditioning_nrmse: tuple[float, ...] = ()
    data_fold_nrmse: tuple[float, ...] = ()

    @property
    def data_nrmse(self) -> float:
        """Mean of :attr:`data_fold_nrmse` (:attr:`nrmse` when it was not measured)."""
        return float(sum(self.data_fold_nrmse) / len(self.data_fold_nrmse)) if self.data_fold_nrmse else self.nrmse

    def to_dict(self) -> dict[str, Any]:
        return {"nrmse": self.nrmse, "fold_nrmse": list(self.fold_nrmse),
                "noise_rms": list(self.noise_rms), "conditioning_nrmse": list(self.conditioning_nrmse),
                "prediction_nrmse": list(self.prediction_nrmse), "chain_nrmse": list(self.chain_nrmse),
                "chain": dict(self.chain), "noise_fold_nrmse": list(self.noise_fold_nrmse),
                "part_conditioning_nrmse": list(self.part_conditioning_nrmse),
                "data_nrmse": self.data_nrmse, "data_fold_nrmse": list(self.data_fold_nrmse), "method": self.method}


@dataclass(frozen=True)
class Score:
    """A model and its held-out error.

    Attributes
    ----------
    model : EquationOfMotion or ModalSumModel
        Fitted on all the data (a modal sum when the cause is an observed second mode).
    nrmse : float
        Mean over held-out parts of ``||x_sim - x|| / ||x||`` (capped at :data:`NRMSE_CAP`).
    fold_nrmse : tuple of float
        One value per held-out part.
    nmte : float
        Mean over held-out parts of the velocity NMTE ``mean |v_sim - v| / max |v|``
        (Cenedese et al. 2022), for people comparing with that literature.
    """

    model: EquationOfMotion | ModalSumModel
    nrmse: float
    fold_nrmse: tuple[float, ...]
    nmte: float = float("nan")


#: What the judging baseline is, and why it is not the pipeline's model (JSON and docs).
JUDGED_WHAT = ("the pipeline's procedure on the training records of each fold: its selected terms fitted by "
               "EDDI, refined by output error when the pipeline kept its refinement (and kept only when "
               "that lowers the error of the other training records), simulated as the pipeline "
               "validates (from the impact, driven by the fused impact force, compared over the free "
               "response). A held-out judgement needs a model that has not seen the part it is judged "
               "on (the pipeline's model saw its fit record). Candidates extend EDDI's per-fold fit and "
               "their cut is measured against it (unrefined_fold_nrmse) and against this baseline: the "
               "gain must come from the mechanism, not from refined vs not")


@dataclass(frozen=True)
class PipelineBaseline:
    """The baseline every other command gives (:class:`eddi.fit_record.Pipeline`).

    ``station identify`` / ``report`` / ``replay`` / ``demo`` fit one record (the median
    blow) with the pipeline (EDDI, the refinement when it lowers the held-out error) and
    validate on the others; given to :func:`~eddi.diagnosis.diagnose`, this is the
    diagnosis's ``baseline`` (the same model and held-out error, bit for bit).

    Attributes
    ----------
    model : EquationOfMotion
    nrmse : float
        Mean displacement nrmse over the records not used for the fit (over the fit record
        itself when there is no other).
    fit_record : int
        Index of the record the pipeline fitted.
    held_out : dict of int to float
        Record index -> its held-out nrmse.
    choices : dict
        What the pipeline chose (route, refinement and why, terms; JSON-ready).
    """

    model: EquationOfMotion
    nrmse: float
    fit_record: int
    held_out: dict[int, float] = field(default_factory=dict)
    choices: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Candidate:
    """One mechanism tried.

    Attributes
    ----------
    name : str
        Mechanism name (:data:`eddi.mechanisms.MECHANISM_NAMES`).
    nrmse : float
        Mean held-out nrmse of the extended model (NaN when skipped).
    fold_nrmse : tuple of float
    gain : float
        ``1 - nrmse / baseline nrmse`` (NaN when skipped).
    wins_every_part : bool
        Lower held-out nrmse than the baseline on every part.
    consistent : bool
        The strength parameter fitted on each fold agrees: spread below
        ``consistency`` times its value.
    params : dict of str to float
        Mechanism parameters fitted on all the data (SI units).
    spread : dict of str to float
        Standard deviation of each parameter over the folds.
    model : EquationOfMotion or None
        The extended model fitted on all the data.
    symptom : str
        What the baseline got wrong if this mechanism is the cause.
    skipped : str
        Why the mechanism was not tried (empty when tried).
    reference_nrmse : float
        Mean held-out nrmse of the model the gain is measured against.
    reference : str
        ``"baseline"``, or ``"equation-error baseline"`` for a mechanism refitted by
        equation error (hidden second mode) when the baseline is fitted by EDDI, or
        ``"main-mode modal baseline"`` for the observed second mode (``sensor_highpass`` is
        judged against the baseline on the records as conditioned).
    form : str
        Second mode only: ``"hidden"`` (a coupled coordinate that is not measured) or
        ``"observed"`` (a modal sum: both modes in the measured signal); the one with the lower
        held-out nrmse is kept.
    nmte, reference_nmte : float
        Mean held-out velocity NMTE of the candidate and of its reference.
    within_cycle : dict of str to dict
        Against each look-alike tried (by name): the within-cycle comparison of the held-out
        residual forces (``z``, ``parts_won``, ``parts``, ``cycles``;
        :func:`eddi.diagnosis.lookalike.compare`; ``z`` > 0: this one fits the cycle better).
    contradicted : str
        A physical check the records fail for this mechanism, in words (empty when none):
        such a candidate is never named (``sensor_highpass``: damping that grows with the
        amplitude, :func:`eddi.diagnosis.highpass.damping_slope`).
    """

    name: str
    nrmse: float
    fold_nrmse: tuple[float, ...]
    gain: float
    wins_every_part: bool
    consistent: bool
    params: dict[str, float]
    spread: dict[str, float]
    model: EquationOfMotion | ModalSumModel | None
    symptom: str = ""
    skipped: str = ""
    reference_nrmse: float = float("nan")
    reference: str = "baseline"
    form: str = ""
    nmte: float = float("nan")
    reference_nmte: float = float("nan")
    within_cycle: dict[str, dict[str, float]] = field(default_factory=dict)
    contradicted: str = ""


@dataclass(frozen=True)
class HeldOut:
    """Simulations of one held-out part (for figures).

    Attributes
    ----------
    part : Part
    t : ndarray, shape (k,), [s]
    x_measured, x_baseline, x_extended : ndarray, shape (k,)
        Measured coordinate and the simulations of the baseline and extended models
        fitted without this part.
    v_measured, v_baseline, v_extended : ndarray, shape (k,) or None
        The same for the rate.
    x_modes, v_modes : ndarray, shape (n_modes, k) or None
        Each mode's simulated coordinate and rate when the extended model is a modal sum.
    """

    part: Part
    t: np.ndarray
    x_measured: np.ndarray
    x_baseline: np.ndarray
    x_extended: np.ndarray
    v_measured: np.ndarray | None = None
    v_baseline: np.ndarray | None = None
    v_extended: np.ndarray | None = None
    x_modes: np.ndarray | None = None
    v_modes: np.ndarray | None = None


@dataclass(frozen=True)
class Diagnosis:
    """The verdict of :func:`diagnose`.

    Attributes
    ----------
    cause : str
        The winning mechanism, ``"none"`` (the baseline reproduces the held-out parts within
        the noise floor) or ``"unexplained"`` (above the floor and no mechanism earns its place).
    baseline, extended : Score
        The baseline and the extended model (same as the baseline when no mechanism is
        named). With a :class:`PipelineBaseline`, ``baseline`` is the pipeline's model and
        held-out error (``fold_nrmse``: the records it did not fit) and the per-fold fit the
        candidates are judged against is :attr:`judged`.
    gain : float
        Relative reduction of the mean held-out nrmse, ``1 - extended / judging`` (0 when
        no mechanism is named). The verdict itself uses each candidate's gain over its reference
        (:attr:`Candidate.gain`).
    candidates : tuple of Candidate
        Every mechanism, best first (skipped ones last).
    scheme : str
        ``"leave-one-record-out"`` or ``"amplitude-bands"``.
    parts : tuple of Part
    margin : float
        Relative margin the winner had to beat.
    verdict : str
        The verdict in one sentence.
    symptom : str
        What the baseline got wrong, in a test engineer's words.
    held_out : tuple of HeldOut
    baseline_spread : dict of str to float
        Spread of the baseline coefficients over the folds (fitted baselines only).
    notes : tuple of str
        What else was tried, for people (e.g. why the observed form of the second mode was
        not tried, or its held-out error when the hidden form was kept).
    noise_floor : NoiseFloor or None
        The held-out error the noise and the conditioning allow, measured from the records.
    symptoms : tuple of Symptom
        What the baseline's held-out simulations get wrong, and what the measurement chain
        shows (clipping, double hits, base motion, impulse versus mass), in numbers and words.
    partial : str
        Under ``"unexplained"``: the best partial explanation (a mechanism that lowers the
        held-out error on every part without earning the name), empty when none.
    judged : Score or None
        With a pipeline baseline: the same terms fitted per fold (:data:`JUDGED_WHAT`).
    pipeline : PipelineBaseline or None
    reference_fold : tuple of float
        Per part, the held-out nrmse of the fit the candidates extend and their cut is measured
        against: EDDI's per-fold baseline before the pipeline's refinement policy, or the judged
        baseline itself where that is the fold's equation-error contender (session 16); the same
        as the judged baseline's when nothing was refined.
    """

    cause: str
    baseline: Score
    extended: Score
    gain: float
    candidates: tuple[Candidate, ...]
    scheme: str
    parts: tuple[Part, ...]
    margin: float
    verdict: str
    symptom: str
    held_out: tuple[HeldOut, ...] = field(repr=False, default=())
    baseline_spread: dict[str, float] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    noise_floor: NoiseFloor | None = None
    symptoms: tuple[Symptom, ...] = ()
    partial: str = ""
    judged: Score | None = None
    pipeline: PipelineBaseline | None = None
    reference_fold: tuple[float, ...] = ()

    @property
    def judging(self) -> Score:
        """The per-fold baseline the candidates are judged against (:attr:`judged`, or the
        baseline itself when no pipeline baseline was given)."""
        return self.judged if self.judged is not None else self.baseline

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no arrays)."""
        def score(s: Score) -> dict[str, Any]:
            out = {"nrmse": s.nrmse if np.isfinite(s.nrmse) else None,
                   "fold_nrmse": [v if np.isfinite(v) else None for v in s.fold_nrmse], "nmte": s.nmte,
                   "model": s.model.to_dict(), "equation": s.model.equation_text()}
            if not np.isfinite(s.nrmse):  # never a null without the reason
                out["nrmse_reason"] = (
                    "the model's simulation diverged (grew without bound) on a held-out record"
                    if s.nrmse == np.inf or any(v == np.inf for v in s.fold_nrmse) else
                    "no held-out record could be simulated with this model")
            return out
        return {
            "cause": self.cause,
            "verdict": self.verdict,
            "symptom": self.symptom,
            "gain": self.gain,
            "margin": self.margin,
            "scheme": self.scheme,
            "partial": self.partial,
            "noise_floor": self.noise_floor.to_dict() if self.noise_floor is not None else None,
            "symptoms": [{"kind": y.kind, "text": y.text, "values": dict(y.values)}
                         for y in self.symptoms],
            "notes": list(self.notes),
            "parts": [{"record": p.record, "start": p.start, "stop": p.stop,
                       "from_rest": p.from_rest, "label": p.label} for p in self.parts],
            "baseline": {**score(self.baseline),
                         **({"spread": self.baseline_spread} if self.judged is None else
                            {"source": "pipeline", "fit_record": self.pipeline.fit_record,  # type: ignore[union-attr]
                             "held_out": {str(k): v for k, v in self.pipeline.held_out.items()},  # type: ignore[union-attr]
                             "pipeline": dict(self.pipeline.choices)})},  # type: ignore[union-attr]
            "judged_baseline": ({**score(self.judged), "spread": self.baseline_spread,
                                 "what": JUDGED_WHAT,
                                 "unrefined_fold_nrmse": list(self.reference_fold),
                                 "refined": list(self.reference_fold) != list(self.judged.fold_nrmse)}
                                if self.judged is not None else None),
            "extended": score(self.extended),
            "candidates": [{
                "name": c.name, "nrmse": c.nrmse, "fold_nrmse": list(c.fold_nrmse),
                "gain": c.gain, "wins_every_part": c.wins_every_part,
                "consistent": c.consistent, "params": c.params,
                "reference_nrmse": c.reference_nrmse, "reference": c.reference,
                "spread": c.spread, "skipped": c.skipped, "form": c.form, "nmte": c.nmte,
                "reference_nmte": c.reference_nmte, "within_cycle": c.within_cycle,
                "contradicted": c.contradicted,
            } for c in self.candidates],
        }
