"""The folds: the baseline and every candidate fitted without a held-out part, simulated over it.

:func:`judge_baseline` judges the baseline fold by fold, :func:`judge_candidates` every
mechanism added to each fold's baseline (the fits on all the data and the caller's extra work
in the same map), :func:`refine_candidates` judges candidates refined as the baseline is;
:class:`FoldResults` holds what they measured. Split out of :mod:`eddi.diagnosis.name`
(session 9).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from eddi.diagnosis.catalogue import Mechanism
from eddi.diagnosis.extend import Fit, Setup
from eddi.diagnosis.fitter import Fitter, FoldFitter, refined_baseline
from eddi.diagnosis.mapping import Mapper, serial_map
from eddi.diagnosis.records import Part, Record
from eddi.diagnosis.settings import EXTEND_JUDGED, NRMSE_CAP, REFINE_DEPARTED
from eddi.diagnosis.show import nmte, nrmse, simulate_part, simulate_part_xv
from eddi.errors import IdentificationError, ModelError, SignalError
from eddi.model import EquationOfMotion


@dataclass
class FoldResults:
    """What the folds measured (one entry per held-out part in every list)."""

    base_fold: list[float] = field(default_factory=list)
    #: per fold, the native candidates' reference: EDDI's fit (unrefined), or the judged baseline
    #: itself where that is the fold's equation-error contender (there the candidates are fitted by
    #: the fold's procedure, FoldFitter.procedure; settings.EXTEND_JUDGED)
    ref_fold: list[float] = field(default_factory=list)
    eddi_fold: list[float] = field(default_factory=list)  # EDDI's baseline (unrefined) per fold
    #: per fold, the judged baseline when it is the equation-error contender (else None)
    contenders: list[Fit | None] = field(default_factory=list)
    base_nmte: list[float] = field(default_factory=list)
    base_sims: list[np.ndarray] = field(default_factory=list)
    base_vsims: list[np.ndarray] = field(default_factory=list)
    base_coefs: list[dict[str, float]] = field(default_factory=list)
    base_models: list[EquationOfMotion] = field(default_factory=list)  # the judged fold models
    ee_ref: list[float] = field(default_factory=list)
    cand_fold: dict[str, list[float]] = field(default_factory=dict)
    cand_params: dict[str, list[dict[str, float]]] = field(default_factory=dict)
    cand_sims: dict[str, list[np.ndarray]] = field(default_factory=dict)
    cand_fits: dict[str, list[Fit | None]] = field(default_factory=dict)  # per fold (native ones)
    cand_refined: dict[str, bool] = field(default_factory=dict)  # judged refined, as the baseline


def judge_baseline(records: Sequence[Record], setup: Setup, parts: Sequence[Part],
                   fold_masks: Sequence[Sequence[np.ndarray]], fitter: Fitter
                   ) -> tuple[FoldResults, list[tuple[FoldFitter, Fit]]]:
    """Per fold: the baseline fitted on the training parts, simulated on the held-out one.

    EDDI's fits run here, in turn; their refinements and simulations (independent per fold)
    through ``fitter.map``. Returns the results and, per fold, the fitting function and the
    baseline fit (reused by :func:`judge_candidates`)."""
    res = FoldResults()
    fits = []
    for part, masks in zip(parts, fold_masks):
        try:
            fit_fold = fitter(masks)
            efit = fit_fold(None, None)
        except IdentificationError as exc:
            raise _untrainable(part, exc) from None
        if efit is None:
            raise ModelError("the baseline could not be fitted on the training parts")
        fits.append((fit_fold, efit))

    def judged(k: int) -> tuple | IdentificationError:
        (fit_fold, efit), part = fits[k], parts[k]
        rec = records[part.record]
        try:
            bfit = fit_fold.refined(efit)
        except IdentificationError as exc:
            return exc
        if bfit is None:
            return None, None, None, None
        xb, vb = simulate_part_xv(bfit.eom, rec, part)
        xe = None if efit is bfit else simulate_part(efit.eom, rec, part)
        return bfit, xb, vb, xe

    for i, out in enumerate(fitter.map(judged, range(len(fits)))):
        part = parts[i]
        if isinstance(out, IdentificationError):
            raise _untrainable(part, out) from None
        bfit, xb, vb, xe = out
        if bfit is None:
            raise ModelError("the baseline could not be fitted on the training parts")
        rec = records[part.record]
        res.base_fold.append(nrmse(xb, rec.x[part.start:part.stop]))
        res.eddi_fold.append(res.base_fold[-1] if xe is None else nrmse(xe, rec.x[part.start:part.stop]))
        extends = bfit.contender and EXTEND_JUDGED["on"]
        res.contenders.append(bfit if extends else None)
        res.ref_fold.append(res.base_fold[-1] if extends else res.eddi_fold[-1])
        res.base_nmte.append(nmte(vb, rec.v[part.start:part.stop]))
        res.base_sims.append(xb)
        res.base_vsims.append(vb)
        res.base_models.append(bfit.eom)
        res.base_coefs.append({**{f"b[{k}]": v for k, v in bfit.eom.damping.items()},
                               **{f"k[{k}]": v for k, v in bfit.eom.stiffness.items()}})
    return res, fits


def _untrainable(part: Part, exc: IdentificationError) -> SignalError:
    return SignalError(f"held out {part.label}, the other records hold too little to fit the baseline "
                       f"({exc}): give fewer terms (e.g. --damping v --stiffness x,x^3) or longer "
                       "records")


def judge_candidates(res: FoldResults, fits: Sequence[tuple[FoldFitter, Fit]], records: Sequence[Record],
                     setup: Setup, cat: Sequence[Mechanism], skipped: dict[str, str | None],
                     parts: Sequence[Part], fold_masks: Sequence[Sequence[np.ndarray]],
                     fitter: Fitter, final: tuple[FoldFitter, Fit] | None = None,
                     extra: Sequence[Callable[[], Any]] = (), tail: Sequence[Callable[[], Any]] = ()
                     ) -> tuple[dict[str, Fit | None], list]:
    """Per fold: every mechanism added to the fold's baseline, fitted on the training parts
    and simulated on the held-out one (filled into ``res``).

    The folds, every mechanism's fit on all the data (``final``: the all-data fitter and
    baseline fit; for :func:`build_candidates`, see :func:`final_fits`) and the ``extra``
    calls (independent work of the caller's) run through ``fitter.map``; ``tail``: more such
    calls, short ones, handed out last (they fill the processes' ends). Returns the final
    fits by mechanism name (empty without ``final``) and the ``extra`` then ``tail`` calls' results.
    """
    res.cand_fold = {m.name: [] for m in cat}
    res.cand_params = {m.name: [] for m in cat}
    res.cand_sims = {m.name: [] for m in cat}
    res.cand_fits = {m.name: [] for m in cat}
    tried = [m for m in cat if not skipped[m.name]]
    need_ee = setup.fit == "eddi" and any(not m.native for m in tried)

    def fold(k: int) -> tuple[float | None, list[tuple[str, float, np.ndarray, dict[str, float] | None,
                                                      Fit | None]]]:
        part, (fit_fold, bfit) = parts[k], fits[k]
        rec = records[part.record]
        xm = rec.x[part.start:part.stop]
        ee_ref = None
        if need_ee:
            # a mechanism refitted by equation error is judged against the baseline fitted
            # the same way, so it cannot win by its fitter rather than by its physics
            ee_fit = fit_fold.ee_base()
            ee_ref = nrmse(simulate_part(ee_fit.eom, rec, part), xm) if ee_fit else NRMSE_CAP
        out = []
        judged = res.contenders[k] if k < len(res.contenders) else None
        for mech in tried:
            # EDDI's fit + mechanism; by the fold's procedure where it judges its contender
            fit = fit_fold(mech, bfit)
            if judged is not None and mech.native:
                fit = fit_fold.procedure(mech, judged, fit)
            # (res.cand_fits, filled below): native ones are refined, look-alikes compared
            kept = fit if (mech.native or mech.lookalikes) else None
            if fit is None or fit.mech is None:
                out.append((mech.name, NRMSE_CAP, np.full_like(xm, np.nan), None, kept))
                continue
            xe = simulate_part(fit.eom, rec, part)
            out.append((mech.name, nrmse(xe, xm), xe, fit.mech.params, kept))
        return ee_ref, out

    n = len(fits)

    def item(k: int) -> Any:
        if k < n:
            return fold(k)
        if k == n and final is not None:
            return {m.name: final[0](m, final[1]) for m in tried}
        return calls[k - n - (final is not None)]()

    # all independent: through ``fitter.map`` (other processes when the caller has cores); the
    # caller's extra work first, then the final fits, then the folds: a mapper that hands out
    # items as processes free up then starts the longest (the observed second mode's fold
    # fits, ~3x a fold on the double beam) first instead of last; the short tail calls last
    head = n + (final is not None) + len(extra)
    total = head + len(tail)
    order = list(range(n, head)) + list(range(n)) + list(range(head, total))
    calls = [*extra, *tail]
    out_all: list[Any] = [None] * total
    for k, got in zip(order, fitter.map(item, order)):
        out_all[k] = got
    for ee_ref, out in out_all[:n]:
        if ee_ref is not None:
            res.ee_ref.append(ee_ref)
        for name, value, sim, params, kept in out:
            res.cand_fits[name].append(kept)
            res.cand_fold[name].append(value)
            res.cand_sims[name].append(sim)
            if params is not None:
                res.cand_params[name].append(params)
    return (out_all[n] if final is not None else {}), out_all[n + (final is not None):]


def final_fits(fits: dict[str, Fit | None], fit_all: FoldFitter) -> Callable[[Mechanism, Fit | None], Fit | None]:
    """``fit_all`` for :func:`build_candidates`, answering from ``fits`` (the fits
    :func:`judge_candidates` made on all the data) and fitting the others."""
    def fit(mech: Mechanism, base_fit: Fit | None) -> Fit | None:
        return fits[mech.name] if mech.name in fits else fit_all(mech, base_fit)
    return fit


def refine_candidates(res: FoldResults, records: Sequence[Record], setup: Setup, cat: Sequence[Mechanism],
                      parts: Sequence[Part], fold_masks: Sequence[Sequence[np.ndarray]],
                      mapper: Mapper | None = None) -> None:
    """Judge candidates refined as the baseline is (the pipeline kept its refinement).

    The judged baseline is refined by output error per fold (:func:`refined_baseline`); a
    weak mechanism that refinement absorbs is then compared with an unrefined extension and
    loses by the fitter. Every EDDI-fitted (native) candidate that beats EDDI's unrefined
    baseline on every held-out part is refined per fold by the same procedure (the fold's
    median-blow training record, kept only when it lowers the other training records'
    error) and judged again; its reference becomes the refined baseline. Candidates refitted
    by equation error (hidden second mode, hysteresis) keep their equation-error reference,
    ``sensor_highpass`` its unrefined one (refining it alone named it for a strong drag:
    docs/diagnosis.md). A candidate that does not help the unrefined fit is not refined (cost),
    unless that fit departs from the judged baseline (:func:`departed`): then every native one is.
    """
    chosen = []
    every = departed(res)
    for mech in cat:
        fits = res.cand_fits.get(mech.name) or []
        folds = res.cand_fold.get(mech.name) or []
        if (not mech.native or len(fits) != len(parts) or len(folds) != len(parts)
                or not (every or all(c < r for c, r in zip(folds, res.ref_fold)))):
            continue
        chosen.append(mech)
    work = [(mech, k) for mech in chosen for k in range(len(parts))]

    def one(item: tuple[Mechanism, int]) -> np.ndarray | None:
        mech, k = item
        part, masks, fit = parts[k], fold_masks[k], res.cand_fits[mech.name][k]
        if fit is not None and fit.contender:  # fitted by the fold's procedure (refined there): as judged
            return res.cand_sims[mech.name][k] if res.cand_fold[mech.name][k] < NRMSE_CAP else None
        rfit = refined_baseline(fit, records, masks, setup) if fit is not None else None
        return simulate_part(rfit.eom, records[part.record], part) if rfit is not None else None

    # the (candidate, fold) refinements are independent: through ``mapper``
    sims = (mapper or serial_map)(one, work)
    for j, mech in enumerate(chosen):
        new_fold, new_sims = [], []
        for k, part in enumerate(parts):
            xm = records[part.record].x[part.start:part.stop]
            xe = sims[j * len(parts) + k]
            if xe is None:
                new_fold.append(NRMSE_CAP)
                new_sims.append(np.full_like(xm, np.nan))
                continue
            new_fold.append(nrmse(xe, xm))
            new_sims.append(xe)
        res.cand_fold[mech.name] = new_fold
        res.cand_sims[mech.name] = new_sims
        res.cand_refined[mech.name] = True


def departed(res: FoldResults) -> bool:
    """True when the native candidates' unrefined reference (``res.ref_fold``: EDDI's per-fold fit,
    or the judged contender) is more than ``REFINE_DEPARTED["factor"]`` times the judged baseline's
    mean held-out nrmse: a cut measured from it, or a loss to it, is then the fit the folds rejected,
    not the mechanism (settings.REFINE_DEPARTED)."""
    factor = REFINE_DEPARTED["factor"]
    if factor is None or not res.ref_fold or len(res.ref_fold) != len(res.base_fold):
        return False
    return bool(float(np.mean(res.ref_fold)) > factor * float(np.mean(res.base_fold)))


def check_trainable(records: Sequence[Record]) -> None:
    """At least one record must hold a segment EDDI can train on (3 zero crossings)."""
    from eddi.energy import zero_crossings

    for r in records:
        s, e = r.free_start, r.free_stop
        if e - s > 3 and zero_crossings(r.t[s:e], r.x[s:e], r.v[s:e]).size >= 3:
            return
    raise SignalError("no record holds 3 zero crossings in its free response: nothing to fit")
