"""Name: every mechanism refitted on the training parts and judged on the held-out ones.

:func:`judge_baseline` and :func:`judge_candidates` run the folds (the baseline and every
candidate, fitted without the held-out part and simulated over it; :class:`FoldFitter` shares
what a fold's fits have in common); :func:`build_candidates` turns the fold results into ranked
:class:`~eddi.diagnosis.results.Candidate` rows (gain over its reference, win on every part,
strength agreeing over folds); :func:`decide` gives the verdict against the noise floor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from eddi.diagnosis.catalogue import Mechanism
from eddi.diagnosis.extend import EddiFold, Fit, Setup, fit_ee, fit_eddi
from eddi.diagnosis.mapping import Mapper, serial_map
from eddi.diagnosis.observed import Observed
from eddi.diagnosis.records import Part, Record
from eddi.diagnosis.results import Candidate, NoiseFloor
from eddi.diagnosis.settings import FULL_REFERENCE_MARGIN, NRMSE_CAP, REFERENCE_MARGIN, REFINE_FOLDS
from eddi.diagnosis.show import nmte, nrmse, simulate_part, simulate_part_xv
from eddi.errors import IdentificationError, ModelError, SignalError
from eddi.model import EquationOfMotion



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
        self.records = list(records)
        self.refine = bool(refine) and bool(self.records) and setup.base is None
        self.map: Mapper = mapper or serial_map

    def __call__(self, masks: Sequence[np.ndarray]) -> "FoldFitter":
        return FoldFitter(self, masks)


class FoldFitter:
    """The fits of one fold (training masks); the equation-error baseline is fitted once."""

    def __init__(self, fitter: Fitter, masks: Sequence[np.ndarray]) -> None:
        self.sigs, self.setup, self.masks = fitter.sigs, fitter.setup, masks
        self.records, self.refine = fitter.records, fitter.refine
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
        refines when the pipeline kept its refinement, else ``fit`` itself."""
        if fit is None or not self.refine:
            return fit
        return refined_baseline(fit, self.records, self.masks, self.setup)

    def __call__(self, mech: Mechanism | None, base_fit: Fit | None = None) -> Fit | None:
        if self.fold is None:
            return fit_ee(self.sigs, self.masks, self.setup, mech, base_fit=base_fit)
        return fit_eddi(self.fold, self.sigs, self.masks, self.setup, mech, base_fit=base_fit,
                        ee_base=self.ee_base)


def refined_baseline(fit: Fit, records: Sequence[Record], masks: Sequence[np.ndarray], setup: Setup) -> Fit:
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

    from eddi.diagnosis.extend import runs

    train = [(i, max(runs(m), key=lambda ab: ab[1] - ab[0])) for i, m in enumerate(masks) if np.any(m)]
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
    judges = [(i, ab) for i, ab in train if i != k] or [(k, (a, b))]

    def error(model) -> float:
        errs = []
        for i, (s0, s1) in judges:
            r = records[i]
            part = Part(i, s0, s1, r.force is not None and r.free_start > 0 and s0 == r.free_start, r.label)
            errs.append(nrmse(simulate_part(model, r, part), r.x[s0:s1]))
        return float(np.mean(errs))

    return Fit(eom=eom, mech=None, residual=fit.residual) if error(eom) < error(fit.eom) else fit


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


@dataclass
class FoldResults:
    """What the folds measured (one entry per held-out part in every list)."""

    base_fold: list[float] = field(default_factory=list)
    ref_fold: list[float] = field(default_factory=list)  # EDDI's baseline (unrefined) per fold
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
        res.ref_fold.append(res.base_fold[-1] if xe is None else nrmse(xe, rec.x[part.start:part.stop]))
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
                     extra: Sequence[Callable[[], Any]] = ()) -> tuple[dict[str, Fit | None], list]:
    """Per fold: every mechanism added to the fold's baseline, fitted on the training parts
    and simulated on the held-out one (filled into ``res``).

    The folds, every mechanism's fit on all the data (``final``: the all-data fitter and
    baseline fit; for :func:`build_candidates`, see :func:`final_fits`) and the ``extra``
    calls (independent work of the caller's) run through ``fitter.map``. Returns the final
    fits by mechanism name (empty without ``final``) and the ``extra`` calls' results.
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
        for mech in tried:
            fit = fit_fold(mech, bfit)
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
        return extra[k - n - (final is not None)]()

    # all independent: through ``fitter.map`` (other processes when the caller has cores); the
    # caller's extra work first, then the final fits, then the folds: a mapper that hands out
    # items as processes free up then starts the longest (the observed second mode's fold
    # fits, ~3x a fold on the double beam) first instead of last
    total = n + (final is not None) + len(extra)
    order = list(range(n, total)) + list(range(n))
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
    docs/diagnosis.md). A candidate that does not help the unrefined fit is not refined (cost).
    """
    chosen = []
    for mech in cat:
        fits = res.cand_fits.get(mech.name) or []
        folds = res.cand_fold.get(mech.name) or []
        if (not mech.native or len(fits) != len(parts) or len(folds) != len(parts)
                or not all(c < r for c, r in zip(folds, res.ref_fold))):
            continue
        chosen.append(mech)
    work = [(mech, k) for mech in chosen for k in range(len(parts))]

    def one(item: tuple[Mechanism, int]) -> np.ndarray | None:
        mech, k = item
        part, masks, fit = parts[k], fold_masks[k], res.cand_fits[mech.name][k]
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


def within_floor(base_fold: Sequence[float], floor: NoiseFloor, none_factor: float) -> bool:
    """The baseline's mean held-out nrmse within ``none_factor`` of the floor, no part lost."""
    return float(np.mean(base_fold)) <= none_factor * floor.nrmse and max(base_fold) < NRMSE_CAP


def spread_of(plist: Sequence[dict[str, float]], keys: Sequence[str]) -> dict[str, float]:
    """Standard deviation of each parameter over the folds (NaN with fewer than two)."""
    return {k: float(np.std([p[k] for p in plist if k in p], ddof=1))
            if sum(k in p for p in plist) > 1 else float("nan") for k in keys}


def build_candidates(cat: Sequence[Mechanism], skipped: dict[str, str | None], res: FoldResults,
                     fit_all: FoldFitter | Callable[[Mechanism, Fit | None], Fit | None], bfit_all: Fit, n_parts: int, consistency: float,
                     k_terms: tuple[str, ...], observed: Observed | None
                     ) -> tuple[list[Candidate], dict[str, Fit], list[str]]:
    """One :class:`Candidate` per mechanism (the kept form of the second mode), and notes."""
    candidates: list[Candidate] = []
    finals: dict[str, Fit] = {}
    notes: list[str] = []
    obs_cand = observed_candidate(observed, n_parts, consistency)
    for mech in cat:
        if skipped[mech.name]:
            candidates.append(Candidate(mech.name, float("nan"), (), float("nan"), False, False, {},
                                        {}, None, "", skipped[mech.name]))
            continue
        folds = res.cand_fold[mech.name]
        ref_fold = res.ee_ref if (res.ee_ref and not mech.native) else (
            res.base_fold if res.cand_refined.get(mech.name) else res.ref_fold)
        ref_nrmse = float(np.mean(ref_fold))
        mean = float(np.mean(folds))
        fit = fit_all(mech, bfit_all)
        params: dict[str, float] = {}
        symptom, model = "", None
        if fit is not None and fit.mech is not None:
            finals[mech.name] = fit
            params = fit.mech.params
            symptom = mech.symptom(fit.mech)
            model = fit.eom
        plist = res.cand_params[mech.name]
        spread = spread_of(plist, list(params))
        key = mech.strength_key(k_terms)
        consistent = (len(plist) == n_parts and key in params
                      and bool(spread.get(key, math.inf) < consistency * abs(params[key])))
        cand = Candidate(mech.name, mean, tuple(folds), 1.0 - mean / ref_nrmse if ref_nrmse > 0 else 0.0,
                         all(c < b for c, b in zip(folds, ref_fold)), consistent, params, spread,
                         model, symptom, "", ref_nrmse,
                         ("baseline" if ref_fold is res.base_fold else
                          ("baseline" if res.ref_fold == res.base_fold else UNREFINED)
                          if ref_fold is res.ref_fold else "equation-error baseline"),
                         "hidden" if mech.name == "second_mode" else "")
        if obs_cand is not None and mech.name == "second_mode":
            kept, other = (obs_cand, cand) if obs_cand.nrmse < cand.nrmse else (cand, obs_cand)
            notes.append(f"second mode: the {kept.form} form is kept (held-out nrmse {kept.nrmse:.3g}, "
                         f"gain {100 * kept.gain:.0f} % over the {kept.reference}); the {other.form} "
                         f"form had {other.nrmse:.3g} (gain {100 * other.gain:.0f} % over the "
                         f"{other.reference})")
            cand = kept
        candidates.append(cand)
    if observed is not None and observed.skipped:
        notes.insert(0, f"second mode, observed form (a modal sum) not tried: {observed.skipped}")
    return candidates, finals, notes


def observed_candidate(o: Observed | None, n_parts: int, consistency: float) -> Candidate | None:
    """The observed second mode as a candidate (None when not tried)."""
    if o is None or o.skipped or o.model is None:
        return None
    ref = float(np.mean(o.ref_fold_nrmse))
    key = "mode_2_damping_ratio"
    spread = spread_of(o.fold_params, list(o.params))
    mean = float(np.mean(o.fold_nrmse))
    return Candidate(
        "second_mode", mean, o.fold_nrmse, 1.0 - mean / ref if ref > 0 else 0.0,
        all(c < b for c, b in zip(o.fold_nrmse, o.ref_fold_nrmse)),
        (len(o.fold_params) == n_parts and bool(spread.get(key, math.inf) < consistency * abs(o.params[key]))),
        dict(o.params), spread, o.model, o.symptom, "", ref, "main-mode modal baseline",
        "observed", float(np.mean(o.fold_nmte)), float(np.mean(o.ref_fold_nmte)))


def rank(candidates: Sequence[Candidate]) -> list[Candidate]:
    """Best first by gain over its reference; skipped ones last."""
    return sorted(candidates, key=lambda c: (bool(c.skipped), -c.gain if math.isfinite(c.gain) else math.inf))


#: A candidate's reference when the judged baseline was refined (the pipeline's policy): the
#: same EDDI fit it extends, so a gain comes from the mechanism, not from refined vs not.
UNREFINED = "unrefined baseline"


@dataclass(frozen=True)
class Decision:
    """The verdict: ``cause``, the winner (if named) and the best partial explanation."""

    cause: str
    winner: Candidate | None
    partial: Candidate | None
    within_floor: bool
    reason: str


def decide(candidates: Sequence[Candidate], base_fold: Sequence[float], floor: NoiseFloor,
           margin: float, none_factor: float, named_factor: float,
           reference_margin: float = REFERENCE_MARGIN, strong_margin: float | None = None,
           eddi_fold: Sequence[float] | None = None, departs: str = "") -> Decision:
    """``none`` when the baseline's mean held-out nrmse is within ``none_factor`` of the
    floor's (the mean: one noise realisation per part makes a per-part floor noisy); a mechanism when it beats its reference on every part by more than ``margin``
    (halves the error at 0.5), its strength agrees over folds, and its held-out nrmse is
    within ``named_factor`` of the floor; otherwise ``unexplained`` with the best partial
    explanation. A candidate judged against another reference than the baseline (refitted by
    equation error, a modal sum) must also beat that reference by ``reference_margin``, so it
    cannot win by its fitter. A baseline lost on any part (nrmse at the cap) is never
    ``none``; nor is one within the factor when a candidate passes every test with the strong
    cut except being told apart from its look-alikes (:func:`lookalike_fails`): that is
    ``unexplained`` with it as the partial explanation. With ``strong_margin``, a candidate passing every test with a cut of at least
    that much is named even within ``none_factor`` (``none`` otherwise there).

    ``base_fold`` is the baseline judged as the pipeline fits it (refined when the pipeline
    kept its refinement); ``eddi_fold`` the EDDI fit the candidates extend (default: the
    same). The cut is measured against the latter (same fitter), and a named mechanism must
    also beat the former. ``departs``: why the pipeline's own model is not within the factor
    ('' when it is); then the baseline is not within the floor either (``none`` impossible,
    the ordinary margin applies), and it is the reason of an ``unexplained``."""
    base = float(np.mean(base_fold))
    eddi = float(np.mean(eddi_fold)) if eddi_fold is not None and len(eddi_fold) else base
    within = within_floor(base_fold, floor, none_factor) and not departs
    tried = [c for c in candidates if not c.skipped and c.model is not None]
    helpful = [c for c in tried if c.wins_every_part and c.gain > 0 and not c.contradicted]
    partial = helpful[0] if helpful else None
    if within and strong_margin is None:
        return Decision("none", None, None, True, "within the noise floor")
    why = []
    need = strong_margin if within else margin  # within the floor only a strong cut names

    def held_out_fails(c: Candidate) -> list[str]:
        # the cut against the baseline as judged (the pipeline's procedure) and against the
        # EDDI fit the mechanism extends (same fitter): the gain is the mechanism's, and it
        # stands against the best baseline the pipeline gives
        fails = []
        cut = min(1.0 - c.nrmse / base if base > 0 else 0.0, 1.0 - c.nrmse / eddi if eddi > 0 else 0.0)
        if not cut >= need:
            fails.append(f"cuts the error by {100 * cut:.0f} % (needs {100 * need:.0f} %)")
        ref_need = max(margin, reference_margin) if c.name in FULL_REFERENCE_MARGIN else reference_margin
        if c.reference not in ("baseline", UNREFINED) and not c.gain >= ref_need:
            fails.append(f"beats its {c.reference} by {100 * c.gain:.0f} % (needs {100 * ref_need:.0f} %)")
        if not c.wins_every_part:
            fails.append("does not win on every held-out part")
        if c.contradicted:  # the records rule it out physically: not named, nor a rival
            fails.append(c.contradicted)
        return fails

    # look-alikes that would pass the held-out tests themselves: a name must be told apart from them
    rivals = {c.name: c for c in tried if not held_out_fails(c)}
    # candidates no better than the judged baseline on any held-out part: each holds the
    # baseline (its mechanism at zero strength), so its fit failed (the mechanism traded against
    # near-collinear library terms), which is no evidence against the mechanism
    unfitted = {c.name: c for c in tried if len(c.fold_nrmse) == len(base_fold)
                and all(m >= b for m, b in zip(c.fold_nrmse, base_fold))}
    ambiguous, ambiguous_fails = None, []  # the first candidate that fails only for its look-alikes
    for c in tried:
        fails = held_out_fails(c)
        if not c.consistent:
            fails.append("its strength changes from fold to fold")
        if not c.nrmse <= named_factor * floor.nrmse:
            fails.append(f"leaves nrmse {c.nrmse:.3g}, over {named_factor:g}x the floor {floor.nrmse:.3g}")
        if not fails:
            fails += lookalike_fails(c, rivals, unfitted)
            if fails and ambiguous is None:
                ambiguous, ambiguous_fails = c, list(fails)
        if not fails:
            return Decision(c.name, c, None, within, "")
        why.append(f"{c.name}: " + ", ".join(fails))
    if within and ambiguous is not None:
        # a mechanism earns its cut on every test but cannot be told from a look-alike: the
        # model lacks something of that family, so the verdict is not `none`
        return Decision("unexplained", None, ambiguous, True,
                        f"within {none_factor:g}x the floor, but {ambiguous.name} cuts the error by the strong "
                        f"margin and passes every test except: " + "; ".join(ambiguous_fails))
    if within:
        return Decision("none", None, None, True, "within the noise floor")
    return Decision("unexplained", None, partial, False, departs or "; ".join(why[:2]))


def lookalike_fails(c: Candidate, rivals: dict[str, Candidate],
                    unfitted: dict[str, Candidate] | None = None) -> list[str]:
    """Why ``c`` is not told apart from its look-alikes among ``rivals`` (candidates that pass
    the held-out tests themselves), or is beaten by one of them on every held-out part (then
    it is not the best explanation, look-alike or not), or has a look-alike fitted the same way
    in ``unfitted`` (no better than the judged baseline on any held-out part: a model that holds the baseline
    and does worse everywhere is a failed fit, not a mechanism ruled out; session 8, tuning
    ladder: hidden ``v |v|`` 0.06 k1 A, seed 2, its candidate traded the term against the
    library's ``x^2 v`` and ``v^3`` and did worse than the baseline on all three parts, and
    ``|x| v`` was named; on every correct name of the session 8 calibration ladders the
    look-alike's held-out nrmse was below the baseline's). A look-alike fitted the same way must
    lose to it within the cycle
    (:func:`eddi.diagnosis.lookalike.told_apart`: the held-out displacement of two such models
    can differ by the fit, not by the physics: hidden drag in the tests was reproduced better
    on every part by ``|x| v``); one fitted another way must lose on every held-out part."""
    from eddi.diagnosis.lookalike import Z_SEPARATED, told_apart

    out = []
    for name, wc in c.within_cycle.items():
        other = (unfitted or {}).get(name)
        # fitted the same way (the EDDI fit extending the same baseline): nested, so worse on
        # every part is a failed fit; one fitted another way (hysteresis) can be genuinely worse
        if other is not None and other is not c and wc.get("same_fitter"):
            out.append(f"its look-alike {name} could not be fitted (no better than the baseline on any "
                       f"held-out part, {other.nrmse:.3g} held out), so it is not ruled out")
    for name, other in rivals.items():
        # any candidate that passes the held-out tests and reproduces every held-out part better:
        # c is not the best explanation, whatever kept that one from being named (a held-out
        # case: strong drag, not told from |x| v, then fell to sensor_highpass at 8x drag's error)
        if (other is not c and len(other.fold_nrmse) == len(c.fold_nrmse)
                and all(o < m for o, m in zip(other.fold_nrmse, c.fold_nrmse))):
            out.append(f"{name}, which passes the held-out tests too, reproduces every held-out part better "
                       f"({other.nrmse:.3g} against {c.nrmse:.3g})")
    for name, wc in c.within_cycle.items():
        other = rivals.get(name)
        if other is None or other is c:
            continue
        if wc.get("same_fitter"):
            if not told_apart(wc):
                out.append(f"not told apart from its look-alike {name} ({other.nrmse:.3g} held out; within the "
                           f"cycle z {wc['z']:.2g}, needs {Z_SEPARATED:g} and every part, won "
                           f"{wc['parts_won']:.0f} of {wc['parts']:.0f})")
        elif len(other.fold_nrmse) != len(c.fold_nrmse) or any(
                o <= m for o, m in zip(other.fold_nrmse, c.fold_nrmse)):
            out.append(f"its look-alike {name}, fitted another way, reproduces some held-out part as well or "
                       f"better ({other.nrmse:.3g} against {c.nrmse:.3g})")
    return out


def check_trainable(records: Sequence[Record]) -> None:
    """At least one record must hold a segment EDDI can train on (3 zero crossings)."""
    from eddi.energy import zero_crossings

    for r in records:
        s, e = r.free_start, r.free_stop
        if e - s > 3 and zero_crossings(r.t[s:e], r.x[s:e], r.v[s:e]).size >= 3:
            return
    raise SignalError("no record holds 3 zero crossings in its free response: nothing to fit")
