"""Keep the output-error refinement or EDDI's estimate (the pipeline's judge of the refinement).

:func:`judge_refinement`: with held-out records, the model of lower mean displacement nrmse
on them; with none, the refined model unless it fits the signal the fit record's sensor
measured measurably worse (:func:`eddi.judge.judge_fit_record`). See :mod:`eddi.fit_record`.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Sequence

import numpy as np

from eddi.conditioning import ConditionedSignal
from eddi.driven_validation import validate_conditioned
from eddi.identify import IdentifiedModel
from eddi.model import EquationOfMotion
from eddi.pipeline_result import REFINE_CHANNEL, SIGNAL_NAME
from eddi.validate import Validation


def judge_refinement(model: IdentifiedModel, cond: ConditionedSignal, held_out: Sequence[ConditionedSignal],
                      val: Validation, held: tuple[Validation, ...], judged_on: str,
                      eddi_vals: tuple[Validation, tuple[Validation, ...]] | None = None,
                      off_reason: str = "",
                      ee_vals: tuple[EquationOfMotion, Validation, tuple[Validation, ...]] | None = None) -> tuple:
    """Keep the refined model or EDDI's (see the module notes); returns what :meth:`Pipeline.fit` needs.

    ``eddi_vals``: EDDI's model validated on ``cond`` and on ``held_out`` (computed here when None).
    ``off_reason``: why an unrefined model was not refined (default: not asked for).
    ``ee_vals``: the equation-error fit of the same terms (:mod:`eddi.equation_error`) validated on
    ``cond`` and on ``held_out``: with held-out records it is kept instead when it predicts them
    better than the model chosen above (refinement ``"rejected"``, the reason says so).

    Returns
    -------
    model, val, held, eddi_held, refinement, reason, n_eddi, n_ref
        The chosen model with its validations, EDDI's held-out validations, ``"kept"`` /
        ``"rejected"`` / ``"off"``, the one-line reason and the compared errors.
    """
    eddi_held: tuple[Validation, ...] = ()
    if model.unrefined is None:
        refinement, reason, n_eddi, n_ref = "off", off_reason or "refinement not asked for (--no-refine)", None, None
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
            if eddi_val.every > 1:  # the judge's samples alone (Pipeline.fit): the delivered one compares all
                eddi_val = validate_conditioned(model.eom, cond)[0]
            val, held = eddi_val, eddi_held
    if ee_vals is not None and held:
        ee, ee_val, ee_held = ee_vals
        n_ee, n_kept = _mean_nrmse(ee_held), _mean_nrmse(held)
        if not (ee_val.diverged or any(h.diverged for h in ee_held)) and n_ee < n_kept:
            kept = {"kept": "refined", "rejected": "EDDI", "off": "EDDI"}[refinement]
            reason = (f"{reason}; the equation-error fit of the same terms predicts the {judged_on} better "
                      f"(displacement nrmse {n_kept:.4g} ({kept}) -> {n_ee:.4g}): equation-error fit kept")
            refinement = "rejected" if refinement == "kept" else refinement
            model = replace(model, eom=ee)
            val, held = ee_val, ee_held
    return model, val, held, eddi_held, refinement, reason, n_eddi, n_ref


def _mean_nrmse(vals: Sequence[Validation]) -> float:
    x = [v.nrmse for v in vals]
    return float(np.mean(x)) if x and all(math.isfinite(e) for e in x) else math.inf

