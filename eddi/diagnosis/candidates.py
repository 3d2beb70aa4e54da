"""Candidates: the fold results of each mechanism as a ranked row (gain over its reference,
win on every held-out part, strength agreeing over the folds). Split out of
:mod:`eddi.diagnosis.name` (session 9).
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np

from eddi.diagnosis.catalogue import Mechanism
from eddi.diagnosis.extend import Fit
from eddi.diagnosis.fitter import FoldFitter
from eddi.diagnosis.folds import FoldResults
from eddi.diagnosis.observed import Observed
from eddi.diagnosis.results import Candidate

#: A candidate's reference when the judged baseline was refined (the pipeline's policy): the
#: same EDDI fit it extends, so a gain comes from the mechanism, not from refined vs not.
UNREFINED = "unrefined baseline"


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
