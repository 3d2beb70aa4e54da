"""Fitting per fold: the baseline and a mechanism fitted on a fold's training samples.

:class:`Fitter` holds what every fold shares (the records' signals, the setup, the energy
cache); ``Fitter(...)(masks)`` is a :class:`FoldFitter`, the fits of one fold. When the
pipeline kept its output-error refinement, a fold's baseline is refined the same way
(:func:`refined_baseline`). Split out of :mod:`eddi.diagnosis.name` (session 9).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Sequence

import numpy as np

from eddi.diagnosis.catalogue import Mechanism
from eddi.diagnosis.extend import EddiFold, Fit, Setup, fit_ee, fit_eddi
from eddi.diagnosis.mapping import Mapper, serial_map
from eddi.diagnosis.records import Part, Record
from eddi.diagnosis.settings import REFINE_FOLDS
from eddi.diagnosis.show import nrmse, simulate_part
from eddi.equation_error import fit_coefficients, window_rows
from eddi.errors import IdentificationError, ModelError, SignalError
from eddi.model import EquationOfMotion
from eddi.terms import parse_terms


class Fitter:
    """Fitting functions for given training masks, sharing the segments' energy cache.

    ``Fitter(sigs, setup)(masks)`` returns a :class:`FoldFitter`: ``fit(mech, base_fit)``
    fits the baseline (``mech`` None) or the baseline plus ``mech`` on the samples ``masks``.
    With ``records`` and ``refine`` (the pipeline kept its refinement), the baseline a fold
    judges with is refined as the pipeline refines (:func:`refined_baseline`). ``mapper``
    runs the independent per-fold work (:mod:`eddi.diagnosis.mapping`; default: here, in turn).
    """

    def __init__(self, sigs: Sequence, setup: Setup, records: Sequence[Record] = (),
                 refine: bool = False, mapper: Mapper | None = None) -> None:
        self.sigs = list(sigs)
        self.setup = setup
        self.cache: dict = {}
        self.columns: dict = {}  # mechanisms' regressors by record, shape and rows (extend._extra)
        self.records = list(records)
        self.refine = bool(refine) and bool(self.records) and setup.base is None
        self.map: Mapper = mapper or serial_map
        # the folds' equation-error contenders (FoldFitter.ee_fit_record): the fit by its fit
        # record and that record's training samples, and its error per judging record and run
        # (folds that share a fit record share the fit: 2 distinct of the beam's 9)
        self.ee_fits: dict = {}
        self.ee_errors: dict = {}

    def __call__(self, masks: Sequence[np.ndarray]) -> "FoldFitter":
        return FoldFitter(self, masks)


class FoldFitter:
    """The fits of one fold (training masks); the equation-error baseline is fitted once."""

    def __init__(self, fitter: Fitter, masks: Sequence[np.ndarray]) -> None:
        self.sigs, self.setup, self.masks, self.columns = fitter.sigs, fitter.setup, masks, fitter.columns
        self.records, self.refine = fitter.records, fitter.refine
        self._fitter = fitter
        self.fold = EddiFold(self.sigs, masks, self.setup, fitter.cache) if self.setup.fit == "eddi" else None
        self._ee: list[Fit | None] = []

    def ee_base(self) -> Fit | None:
        """The baseline refitted by equation error (the reference of non-native mechanisms)."""
        if not self._ee:
            st = self.setup
            ee = Setup(mass=st.mass, damping=st.damping, stiffness=st.stiffness, base=st.base,
                       coordinate=st.coordinate, fit="equation-error")
            self._ee.append(fit_ee(self.sigs, self.masks, ee, None))
        return self._ee[0]

    def judged_baseline(self) -> tuple[Fit | None, Fit | None]:
        """EDDI's fit of the baseline (what the candidates extend and are measured against)
        and the baseline the fold is judged with: the same, refined as the pipeline refines
        when the pipeline kept its refinement (:func:`refined_baseline`)."""
        fit = self(None, None)
        return fit, self.refined(fit)

    def refined(self, fit: Fit | None) -> Fit | None:
        """``fit`` (EDDI's fit of the baseline) as the fold judges it: refined as the pipeline
        refines when the pipeline kept its refinement, else ``fit`` itself; with
        ``setup.ee_contender`` the fold's equation-error fit of the same terms replaces it when it
        predicts the fold's other training records better, as the pipeline judges its own
        (:func:`eddi.refinement_choice.judge_refinement`)."""
        if fit is None:
            return fit
        err = TrainingError(self.records, self.masks, self._fitter.ee_errors)
        out = refined_baseline(fit, self.records, self.masks, self.setup, err) if self.refine else fit
        if not (self.setup.ee_contender and self.setup.fit == "eddi" and self.setup.base is None and self.records):
            return out
        key = self._ee_key()
        ee = self.ee_fit_record()
        if ee is None:
            return out
        # err(ee) < err(out), its simulations stopped once they hold ee's mean at or above out's
        return replace(ee, residual=fit.residual) if err.below(ee.eom, err(out.eom), key) else out

    def _ee_key(self) -> tuple | None:
        """What the fold's equation-error contender depends on: its fit record and that record's
        training samples (the fitter's signals and setup being the same)."""
        k = fit_record_of(self.records, self.masks)
        return None if k < 0 else (k, self.masks[k].tobytes())

    def ee_fit_record(self) -> Fit | None:
        """The equation-error fit of the baseline's terms on the fold's fit record alone (the
        training record of the median peak force, :func:`fit_record_of`), as the pipeline fits
        its own on its fit record: the same rows and solve
        (:func:`eddi.equation_error.fit_coefficients`, the rows :func:`contender_rows`); the
        other training records then judge it out of sample, as they judge the refinement."""
        key = self._ee_key()
        if key is None:
            return None
        if key not in self._fitter.ee_fits:  # the same fit for every fold with this fit record's samples
            self._fitter.ee_fits[key] = self._ee_fit()
        return self._fitter.ee_fits[key]

    def _ee_fit(self) -> Fit | None:
        rows = contender_rows(self.records, self.masks)
        if rows is None:
            return None
        k, m = rows
        s, st = self.sigs[k], self.setup
        try:
            coef = fit_coefficients(parse_terms(list(st.damping) + list(st.stiffness)), s.x[m], s.v[m], s.a[m],
                                    s.force[m], st.mass)
        except (ValueError, np.linalg.LinAlgError):
            return None
        if coef is None:
            return None
        nd = len(st.damping)
        try:
            eom = EquationOfMotion.create(
                mass=st.mass, damping={t: float(c) for t, c in zip(st.damping, coef[:nd])},
                stiffness={t: float(c) for t, c in zip(st.stiffness, coef[nd:])}, coordinate=st.coordinate,
                notes="fitted by eddi.diagnose (least squares on the equation of motion)")
        except ModelError:
            return None
        return Fit(eom=eom, mech=None, residual=(), contender=True)

    def extend_contender(self, mech: Mechanism, judged: Fit) -> Fit | None:
        """``mech`` added to the fold's equation-error contender (``judged``, which the fold judges
        with): the baseline's terms and the mechanism fitted by equation error on the contender's
        own rows (:func:`contender_rows`), the shape grid drawn from every training record. A
        candidate then extends the baseline the fold is judged with, so its gain is the
        mechanism's over the best baseline, not the fitter's (session 16)."""
        rows = contender_rows(self.records, self.masks)
        if rows is None:
            return None
        k, m = rows
        masks = [m if i == k else np.zeros_like(x) for i, x in enumerate(self.masks)]
        st = self.setup
        ee = Setup(mass=st.mass, damping=st.damping, stiffness=st.stiffness, base=st.base,
                   coordinate=st.coordinate, fit="equation-error")
        try:
            fit = fit_ee(self.sigs, masks, ee, mech, base_fit=judged, columns=self.columns,
                         context_masks=self.masks, thin=False)
        except (IdentificationError, SignalError, ModelError, ValueError, np.linalg.LinAlgError):
            return None
        return replace(fit, contender=True) if fit is not None else None

    def procedure(self, mech: Mechanism, judged: Fit, efit: Fit | None) -> Fit | None:
        """``mech`` fitted by the fold's own procedure, where the fold is judged with its
        equation-error contender (``judged``): EDDI's fit with the mechanism (``efit``), refined as
        the fold refines (:func:`refined_baseline`), against the contender with the mechanism
        (:meth:`extend_contender`), the one the fold's other training records reproduce better, as
        the fold's baseline was chosen (session 17). Marked ``contender``: judged as it is."""
        err = TrainingError(self.records, self.masks, self._fitter.ee_errors)
        best = efit
        if efit is not None and efit.mech is not None and self.refine:
            best = refined_baseline(efit, self.records, self.masks, self.setup, err)
            best = replace(best, mech=efit.mech) if best.mech is None else best
        cfit = self.extend_contender(mech, judged)
        if cfit is None or cfit.mech is None:
            return replace(best, contender=True) if best is not None else None
        if best is None or best.mech is None:
            return cfit
        return cfit if err.below(cfit.eom, err(best.eom)) else replace(best, contender=True)

    def __call__(self, mech: Mechanism | None, base_fit: Fit | None = None) -> Fit | None:
        if self.fold is None:
            return fit_ee(self.sigs, self.masks, self.setup, mech, base_fit=base_fit, columns=self.columns)
        return fit_eddi(self.fold, self.sigs, self.masks, self.setup, mech, base_fit=base_fit,
                        ee_base=self.ee_base, columns=self.columns)


def refined_baseline(fit: Fit, records: Sequence[Record], masks: Sequence[np.ndarray], setup: Setup,
                     error=None) -> Fit:
    """The pipeline's refinement policy on a fold's training records.

    :class:`eddi.fit_record.Pipeline` refines EDDI's model by output error on its fit record
    (the median blow) and keeps the refinement only when it lowers the displacement nrmse of
    the records it did not fit. Here: the training record of the median peak force (the
    largest training run of a record split into bands) is the fit record, the other training
    records judge (the fit record itself, simulated over its training run, when it is the
    only one); the refined model is kept only when it lowers that error.
    """
    from eddi.fit_record import REFINE_CHANNEL
    from eddi.refine import refine_output_error

    train = _training_runs(records, masks)
    if not train:
        return fit
    forces = [float(np.max(np.abs(records[i].force))) if records[i].force is not None else 0.0 for i, _ in train]
    order = sorted(range(len(train)), key=lambda j: forces[j])
    k, (a, b) = train[order[(len(order) - 1) // 2]]
    rec = records[k]
    try:
        eom, _ = refine_output_error(refine_start(fit.eom, records, masks, setup), rec.t[a:b], rec.x[a:b],
                                     rec.v[a:b], rec.a[a:b], channel=REFINE_CHANNEL.get(rec.response, "x"),
                                     min_gain=REFINE_FOLDS["min_gain"])
    except (IdentificationError, SignalError, ModelError, ValueError):
        return fit
    error = error or training_error(records, masks)
    return Fit(eom=eom, mech=None, residual=fit.residual) if error.below(eom, error(fit.eom)) else fit


def _training_runs(records: Sequence[Record], masks: Sequence[np.ndarray]) -> list[tuple[int, tuple[int, int]]]:
    """Per record with training samples, its longest training run ``(record, (start, stop))``."""
    from eddi.diagnosis.extend import runs

    return [(i, max(runs(m), key=lambda ab: ab[1] - ab[0])) for i, m in enumerate(masks) if np.any(m)]


def fit_record_of(records: Sequence[Record], masks: Sequence[np.ndarray]) -> int:
    """The fold's fit record: the training record of the median peak force (lower middle); -1: none."""
    train = _training_runs(records, masks)
    if not train:
        return -1
    forces = [float(np.max(np.abs(records[i].force))) if records[i].force is not None else 0.0 for i, _ in train]
    order = sorted(range(len(train)), key=lambda j: forces[j])
    return train[order[(len(order) - 1) // 2]][0]


def contender_rows(records: Sequence[Record], masks: Sequence[np.ndarray]) -> tuple[int, np.ndarray] | None:
    """The rows of the fold's equation-error contender: its fit record (:func:`fit_record_of`) and
    that record's training samples, every k-th as the pipeline thins its fit record's window
    (:func:`eddi.equation_error.window_rows`); None without a fit record."""
    k = fit_record_of(records, masks)
    if k < 0:
        return None
    idx = np.flatnonzero(masks[k])
    m = np.zeros_like(masks[k])
    m[idx[window_rows(0, idx.size)]] = True
    return k, m


def training_error(records: Sequence[Record], masks: Sequence[np.ndarray]) -> "TrainingError":
    """``error(model)``: the mean displacement nrmse of ``model`` simulated over the fold's
    training records other than the refinement's fit record (the median peak force; that record
    itself when it is the only one), as the pipeline judges a model on the records it did not fit
    (:class:`TrainingError`)."""
    return TrainingError(records, masks)


class TrainingError:
    """A fold's training error of models (:func:`training_error`), each model simulated once per
    judging record.

    ``error(model)``: the mean over the judges. ``error.below(model, limit)``: ``error(model) <
    limit``, decided without simulating the judges left once those simulated hold the mean at or
    above ``limit``: every nrmse is >= 0, so the mean of all is at least the sum so far over the
    number of judges (decided there only beyond a relative 1e-9, far above the sum's rounding;
    the same answer as the whole mean's, docs/speed.md). The judges already simulated count
    first. ``shared``: per-judge errors of models named by ``key`` (a model the folds share:
    the equation-error contender of the folds with the same fit record), kept across folds.
    """

    #: the sum so far decides only beyond this relative margin (the mean's rounding is ~1e-16)
    MARGIN = 1e-9

    def __init__(self, records: Sequence[Record], masks: Sequence[np.ndarray], shared: dict | None = None) -> None:
        train = _training_runs(records, masks)
        k = fit_record_of(records, masks)
        self.records = records
        self.judges = [(i, ab) for i, ab in train if i != k] or train
        self._shared = {} if shared is None else shared
        self._own: dict = {}  # (id(model), judge) -> nrmse
        self._models: list = []  # the models simulated here, kept alive: their ids stay their own

    def _one(self, model: EquationOfMotion, j: int, key: object = None) -> float:
        i, (s0, s1) = self.judges[j]
        if key is None:
            store, name = self._own, (id(model), i, s0, s1)
            if not any(m is model for m in self._models):
                self._models.append(model)
        else:
            store, name = self._shared, (key, i, s0, s1)
        if name not in store:
            r = self.records[i]
            part = Part(i, s0, s1, r.force is not None and r.free_start > 0 and s0 == r.free_start, r.label)
            store[name] = nrmse(simulate_part(model, r, part), r.x[s0:s1])
        return store[name]

    def _known(self, model: EquationOfMotion, j: int, key: object) -> bool:
        i, (s0, s1) = self.judges[j]
        return (key, i, s0, s1) in self._shared if key is not None else (id(model), i, s0, s1) in self._own

    def __call__(self, model: EquationOfMotion, key: object = None) -> float:
        errs = [self._one(model, j, key) for j in range(len(self.judges))]
        return float(np.mean(errs)) if errs else float("inf")

    def below(self, model: EquationOfMotion, limit: float, key: object = None) -> bool:
        """``self(model, key) < limit``, simulating only the judges it takes to decide."""
        n = len(self.judges)
        if n and limit > 0 and math.isfinite(limit):
            order = sorted(range(n), key=lambda j: not self._known(model, j, key))  # known first
            total = 0.0
            for j in order:
                total += self._one(model, j, key)
                if total >= n * limit * (1.0 + self.MARGIN):
                    return False  # the mean is >= limit whatever the judges left give
        elif n and not limit > 0:
            return False  # a mean of errors >= 0 is never below 0 (nor below NaN)
        return self(model, key) < limit


def refine_start(eom: EquationOfMotion, records: Sequence[Record], masks: Sequence[np.ndarray],
                 setup: Setup) -> EquationOfMotion:
    """Where a fold's refinement of ``eom`` starts (settings.REFINE_FOLDS): ``eom`` with the
    coefficients of the pipeline's refined model (``setup.refine_start``) for the terms both
    have, when the pipeline's fit record is wholly in the fold's training masks; else ``eom``."""
    warm, k = setup.refine_start, setup.refine_start_record
    if warm is None or not REFINE_FOLDS["warm"] or not 0 <= k < len(records):
        return eom
    r = records[k]
    if not (r.free_stop > r.free_start and np.all(masks[k][r.free_start:r.free_stop])):
        return eom  # the pipeline's model saw (part of) this fold's held-out data
    return eom.model_copy(update={"damping": {t: warm.damping.get(t, c) for t, c in eom.damping.items()},
                                  "stiffness": {t: warm.stiffness.get(t, c) for t, c in eom.stiffness.items()}})


def all_masks(records: Sequence[Record]) -> list[np.ndarray]:
    """The free response of every record (the training samples of the final fit)."""
    out = []
    for r in records:
        m = np.zeros(r.t.size, bool)
        m[r.free_start:r.free_stop] = True
        out.append(m)
    return out
