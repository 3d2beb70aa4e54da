"""A baseline the records do not determine: its refit swings with the noise in every held-out part (session 20).

Between the floor of the data and the ``none`` limit (:data:`eddi.diagnosis.settings.NONE_LIMIT`) the
held-out ratio cannot tell a null from a small departure (nulls reach 1.8x, session 18). The noise floor
measures, per held-out part, two things (:mod:`eddi.diagnosis.measure`): ``d_cond``, how far one more
draw of the noise moves the conditioned record, and ``d_pred``, how far the baseline *refitted* on that
draw moves its held-out prediction. When the model class holds the records, an identification from
hundreds of cycles averages the noise: the refit moves its prediction a small fraction of what the
noise moves the record itself (on 52 null sets of session 19, the least part's ``d_pred`` was at most
0.27 of the records' own share ``sqrt(d_cond^2 + d_chain^2)``; median 0.06). When the records hold
something the library lacks, the fit trades its terms along directions the data barely fix to mimic
it, the noise picks among them, and the refit's prediction of another record moves as much as the
record's noise or more (one-DOF sets with a hidden dry or Stribeck-like friction at 1.02-1.22x the
floor: 0.6-2.7 in every part, s19small's held-out coulomb 100 / 101). The floor of the data already
refuses that swing as an excuse for the baseline's error (``d_pred`` counted at most ``PRED_CAP`` times
the records' share, session 12); this symptom says it when the baseline is above that floor.

**Every** held-out part must swing by at least :data:`SWING` of its records' share (a missing mechanism
is in every record; one ill-fixed part, e.g. a short weak blow, is not the model), and there must be at
least :data:`MIN_PARTS` of them. Then, above the floor of the data, the verdict is ``unexplained`` with
this symptom (:func:`eddi.diagnosis.earn.earn`), never ``none (uncertain)``. It names no cause: a
mechanism outside the model, or records too few, short or noisy to fix the model's terms, both of which
mean the baseline is not shown complete.
"""

from __future__ import annotations

import math
from typing import Sequence

from eddi.diagnosis.results import NoiseFloor, Symptom

#: Each held-out part's ``d_pred`` must be at least this share of its records' own ``sqrt(d_cond^2 +
#: d_chain^2)`` (module notes; nulls at most 0.27, session 20 measures in docs/diagnosis.md).
SWING = 0.5
#: At least this many held-out parts with both figures.
MIN_PARTS = 2
#: The symptom's kind.
KIND = "refit_swing"


def refit_swing(floor: NoiseFloor) -> Symptom | None:
    """The ``refit_swing`` symptom when every held-out part's ``d_pred`` is at least :data:`SWING` of its
    records' share (module notes), else None."""
    pred, cond = list(floor.prediction_nrmse), list(floor.part_conditioning_nrmse)
    chain = list(floor.chain_nrmse) if len(floor.chain_nrmse) == len(pred) else [0.0] * len(pred)
    if len(pred) < MIN_PARTS or len(cond) != len(pred):
        return None
    share = [p / math.hypot(c, h) if math.isfinite(p) and math.isfinite(c) and math.hypot(c, h) > 0 else math.nan
             for p, c, h in zip(pred, cond, chain)]
    if not all(math.isfinite(s) for s in share) or min(share) < SWING:
        return None
    lo, hi = min(share), max(share)
    return Symptom(KIND, (f"in every held-out part another draw of the noise moves the baseline's refitted "
                          f"prediction by {lo:.2g}-{hi:.2g} times what it moves the records themselves (d_pred "
                          f"{min(pred):.3g}-{max(pred):.3g}; nulls at most 0.27): the records do not determine "
                          "the baseline, whose terms trade against each other for something the model does not "
                          "hold (a mechanism outside it, or records too few or too noisy to fix its terms)"),
                   {"min_share": lo, "max_share": hi, "parts": float(len(share)), "min_pred": min(pred),
                    "max_pred": max(pred)})


def swing_of(symptoms: Sequence[Symptom]) -> Symptom | None:
    """The ``refit_swing`` symptom among ``symptoms``, if any."""
    return next((s for s in symptoms if s.kind == KIND), None)
