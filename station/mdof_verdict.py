"""A multi-channel ``none`` above the noise floor that a richer model consistently improves is
``unexplained`` (issue 14 item 4, session 18).

The project's standard: a printed result is a claim, never ``none`` above the floor. Until session 18
a diagnosis whose baseline sat 1.6-2.3x its channels' floors held out while the coupled model was
better on most folds (gain short of the margin) read ``Cause: none (uncertain)`` (two blind
two-channel records, the lead's description only: coupled better on 2 and 3 of 3 folds, excess gain
about 40 % and 35 %, every mode improved). ``none`` says the model misses nothing the records show;
a model with more terms that removes a consistent share of the error above the floor is the
records saying otherwise.

**The rule** (:func:`short_of_margin`; every part must hold; the folds on which the baseline ran,
:func:`eddi.mdof.verdict.baseline_ran`):

- the cause is ``none`` and the delivered model's held-out error is above the floor on a channel;
- the coupled model is worse than the baseline on at most :data:`eddi.mdof.allowance.WORSE_FOLDS`
  fold(s) and on fewer than half of them (the within-allowance rule's fold cut: the fold holding
  out the largest blow extrapolates in amplitude);
- it removes at least :data:`SHORT_EXCESS` of the error above each fold's floor
  (:func:`eddi.mdof.verdict.excess_gain`, the within-allowance rule's figure; when a channel rule
  was met and the cause was turned ``none`` by a check on the model, the gain that met it);
- no mode is made worse by more than the margin (the per-mode excess gains of
  :mod:`eddi.mdof.modefloor`, when judged).

Then the cause is ``unexplained``, the delivered model is still the baseline, and the JSON
``short_coupling`` / a note / a symptom carry the evidence (gain, excess gain, folds, per-mode
figures, whether the folds' coupled models hold a nonlinear term between coordinates). Nothing is
named: the gain is short of the margin, or the model checks refused what it named.

**Why 0.2** (measured, ``docs/multi-dof.md`` "Session 18"): of the 67 linear nulls (``lin2``/``lin3``/
``nulln`` of ``bench_mdof_nulls.py``, ``lin2``/``lin3`` of ``bench_mdof_modes.py``) whose verdicts sessions
13-17 logged, 14 read ``none`` above their floor; none of them had the coupled model better on more than
half the folds, and their best excess gain was 0.11 (on 1 of 3 folds); the two blind records sit near
0.36-0.42. A grounded cubic spring (nonlinear, no coupling between masses) meets the rule on 6 of its 14
``none`` above the floor: ``unexplained`` there is the honest verdict (the baseline misses a
nonlinearity a richer model catches), not a false claim of coupling.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

#: Least excess gain (share of the baseline's error above the floor the coupled model removes,
#: held out) that makes a ``none`` above the floor ``unexplained``.
SHORT_EXCESS = 0.2


def _floors(obj: dict[str, Any]) -> tuple[dict[str, float], str]:
    """The floor the rule judges on: the prediction floor when the diagnosis has one
    (:mod:`eddi.mdof.predfloor`, session 19), else the noise floor; and its name."""
    return (obj["prediction_floor"], "prediction") if obj.get("prediction_floor") else (obj["noise_floor"], "noise")


def _ratios(obj: dict[str, Any], delivered: str) -> dict[str, float]:
    held, floors = obj[delivered]["channel_nrmse"], _floors(obj)[0]
    return {c: held[c] / floors[c] for c in held
            if c in floors and floors[c] > 0 and math.isfinite(held[c])}


def short_of_margin(obj: dict[str, Any], delivered: str = "baseline",
                    fold_terms: Sequence[bool] = ()) -> dict[str, Any] | None:
    """The evidence of the module's rule on a ``station diagnose`` object (None when it does not hold)."""
    from eddi.mdof.allowance import WORSE_FOLDS
    from eddi.mdof.verdict import baseline_ran

    if obj["cause"] != "none":
        return None
    ratios = _ratios(obj, delivered)
    if not ratios or max(ratios.values()) <= 1.0:
        return None
    base, cpl = obj["baseline"]["folds"], obj["coupled"]["folds"]
    ran = [k for k, ok in enumerate(baseline_ran(base)) if ok and k < len(cpl)]
    if not ran:
        return None
    worse = sum(not float(cpl[k]) < float(base[k]) for k in ran)
    allowance = obj.get("allowance")
    excess = float(allowance["excess_gain"]) if allowance else float(obj["gain"])
    modes = obj.get("modes") or {}
    mode_ex = [float(x) for x in modes.get("excess_gain", [])]
    if (worse > WORSE_FOLDS or 2 * worse >= len(ran) or not math.isfinite(excess) or excess < SHORT_EXCESS
            or any(not math.isfinite(x) or x < -obj["margin"] for x in mode_ex)):
        return None
    worst = max(ratios, key=ratios.__getitem__)
    return {"excess_gain": excess, "raw_gain": float(obj["raw_gain"]), "margin": float(obj["margin"]),
            "better_folds": len(ran) - worse, "folds": len(ran), "channel": worst, "ratio": ratios[worst],
            "mode_excess_gain": mode_ex, "mode_better_folds": [int(x) for x in modes.get("better_folds", [])],
            "coupling_terms_folds": int(sum(bool(t) for t in fold_terms)), "least_excess": SHORT_EXCESS}


def coupling_short(obj: dict[str, Any], delivered: str = "baseline", fold_terms: Sequence[bool] = ()) -> bool:
    """Apply the rule in place: ``cause`` ``unexplained``, JSON ``short_coupling`` (the evidence, else
    None), a note and a symptom. True when it changed the cause."""
    ev = short_of_margin(obj, delivered, fold_terms)
    obj["short_coupling"] = ev
    if ev is None:
        return False
    modes = "".join(f"; q{m + 1} excess gain {100 * x:.0f} %" + (
        f", better on {ev['mode_better_folds'][m]} of {ev['folds']} folds" if m < len(ev["mode_better_folds"]) else "")
        for m, x in enumerate(ev["mode_excess_gain"]))
    terms = (f"; the folds' coupled models hold a nonlinear term between coordinates on {ev['coupling_terms_folds']} "
             f"of {len(fold_terms)} folds" if fold_terms else "")
    text = (f"the delivered model's held-out error is {ev['ratio']:.1f}x the {_floors(obj)[1]} floor on channel "
            f"{ev['channel']}, "
            f"and the coupled model removes {100 * ev['excess_gain']:.0f} % of the error above the floor held out "
            f"(better on {ev['better_folds']} of {ev['folds']} folds; raw gain {100 * ev['raw_gain']:.0f} %, margin "
            f"{100 * ev['margin']:.0f} %{modes}{terms})")
    obj["cause"] = "unexplained"
    obj["notes"].append(f"unexplained, not none: {text}: the records hold something the baseline misses and a model "
                        "with nonlinear terms catches in part, short of what names a coupling (more or larger blows "
                        "decide it)")
    obj["symptoms"].append({"kind": "coupled_gain_short", "text": "coupled model better above the floor: " + text,
                            **{k: v for k, v in ev.items() if k != "mode_better_folds"}})
    return True


def refit_floor(obj: dict[str, Any], delivered: str, fits: Sequence[dict], records: Sequence[Any],
                floors: Any, dp: str, mapper: Any = None) -> None:
    """A ``none`` above the prediction floor judged again with the identification's scatter from the
    noise counted (:mod:`eddi.mdof.refitspread`, session 20): each fold's delivered model identified
    again on noisier copies of its training captures; the change of its held-out prediction is a part
    of the floor (``floor_parts.refit``). Only where the cause is ``none`` and a channel is above the
    floor (the refits cost ``REFIT_DRAWS`` identifications per fold); ``prediction_floor`` and
    ``floor_parts`` are replaced in place (``prediction_floor_before_refit`` kept), ``refit_checked`` says it ran. Nothing else is re-judged:
    a ``none`` can lose its ``(uncertain)``, never become a name or leave ``unexplained``."""
    import numpy as np

    from eddi.mdof.predfloor import FoldFloors
    from eddi.mdof.refitspread import refit_spread
    from eddi.mdof.verdict import MDOF_MIN_FLOOR

    obj["refit_checked"] = False
    ratios = _ratios(obj, delivered)
    if obj["cause"] != "none" or not ratios or max(ratios.values()) <= 1.0 or not obj.get("prediction_floor"):
        return
    names = list(obj["channels"])
    mapper = mapper if mapper is not None else (lambda fn, items: [fn(x) for x in items])
    got = mapper(lambda k: refit_spread(fits[k][delivered][1], fits[k][delivered][2], records[k], names, dp, seed=k),
                 list(range(len(fits))))
    new = FoldFloors(floors.noise, floors.impulse, floors.ident, floors.realized, floors.noise_sd, np.array(got))
    obj["prediction_floor_before_refit"] = dict(obj["prediction_floor"])
    obj["prediction_floor"] = new.channel_floors(names, MDOF_MIN_FLOOR)
    obj["floor_parts"] = new.parts(names)
    obj["refit_checked"] = True
