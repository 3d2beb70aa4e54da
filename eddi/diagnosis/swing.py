"""A baseline the records do not determine: its refit swings with the noise in every held-out part (session 20).

A symptom, reported with the others (in the ``none (uncertain)`` text's symptom list, the JSON), that
**never changes the verdict**. The noise floor measures per held-out part (:mod:`eddi.diagnosis.measure`)
``d_cond``, how far one more draw of the noise moves the conditioned record, and ``d_pred``, how far the
baseline *refitted* on that draw moves its held-out prediction. When the fit is well determined it
averages the noise, and ``d_pred`` is a small fraction of the records' own share ``sqrt(d_cond^2 +
d_chain^2)`` (on the null sets of the station's path measured in session 20, docs/diagnosis.md: the least part's
ratio at most 0.32, median 0.06). On one-DOF sets with a hidden dry or Stribeck-like friction between the floor and
the ``none`` limit the fit trades its terms for what it lacks and swings 0.6-2.7 in every part
(s19small's held-out coulomb 100 / 101 at 1.02 / 1.22x); that is why their ratio sits near 1: the floor of
the data counts ``d_pred`` up to twice the records' share.

Session 20 (s20onedof) first made it turn ``none (uncertain)`` into ``unexplained`` above the floor of the
data. It is not null-safe: the 0.3 kg, 9 Hz, 2 kHz, 38 dB null of ``tests/eddi/test_diagnose_earned.py``
(the library call with a restricted catalogue, no pipeline baseline) is 2.4x the floor with every part
swinging 1.8-7.4x: a rich library over 22 cycles is ill-determined with nothing missing. So the swing says
the records do not determine the baseline, which holds for a missing mechanism and for too few or too
noisy records alike; it is said, in numbers, and the verdict stays what the held-out comparison gives.
**Every** held-out part must swing by at least :data:`SWING` (and at least :data:`MIN_PARTS` parts).
"""

from __future__ import annotations

import math
from typing import Sequence

from eddi.diagnosis.results import NoiseFloor, Symptom

#: Each held-out part's ``d_pred`` must be at least this share of its records' own ``sqrt(d_cond^2 +
#: d_chain^2)`` to be said (module notes; station-path nulls at most 0.32, docs/diagnosis.md "Session 20").
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
                          f"{min(pred):.3g}-{max(pred):.3g}; on nulls of the station's path mostly under 0.3): the "
                          "records do not determine the baseline (its terms trade against each other: a mechanism "
                          "the model lacks, or records too few or too noisy to fix its terms)"),
                   {"min_share": lo, "max_share": hi, "parts": float(len(share)), "min_pred": min(pred),
                    "max_pred": max(pred)})


def swing_of(symptoms: Sequence[Symptom]) -> Symptom | None:
    """The ``refit_swing`` symptom among ``symptoms``, if any."""
    return next((s for s in symptoms if s.kind == KIND), None)
