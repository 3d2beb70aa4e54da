"""The chain's corrections of a lagging response in the verdict: ``response_lag`` (the force
aligned, :mod:`eddi.diagnosis.align`) and ``sensor_lowpass`` (the force through the channel's
fitted low-pass, :mod:`eddi.diagnosis.lowpass`).

Both are tried only when the chain claims a lag (:func:`eddi.diagnosis.chain.inspect`). A
claimed lag forbids ``none`` and a physical name (:mod:`eddi.diagnosis.earn`) unless

* a correction is named (it passes :func:`eddi.diagnosis.decide.decide` like any cause; within
  the floor with the margin's cut: :func:`named`), or
* the lag is **immaterial** (:func:`immaterial`, session 15): the baseline and the aligned model
  (measured on every held-out part) are both within the floor of the data, and the alignment
  moves the held-out error by less than that floor. Then the lag
  is reported with the verdict, with its figures, and ``none`` stands. A lab reports a channel
  delay it measured (an anti-alias filter's group delay is in every DAQ's data sheet) and
  corrects for it when it bears on the result; a model that reproduces the held-out records
  within the noise with and without the correction is complete for these records, and calling
  it ``unexplained`` would send the user looking for a mechanism that is not there (session 14,
  own lagged sets: 0.0058 -> 0.0060, 0.00067 -> 0.00066 read ``unexplained``). Session 13's rule
  stands where it was meant: a lag that is not corrected (not measured, a one-sample blow,
  a refit that failed) or whose correction changes the error beyond the floor still forbids
  ``none``.
"""

from __future__ import annotations

import math
from typing import Sequence

from eddi.diagnosis.align import NAME as LAG_NAME, correction_note as lag_note, lag_candidate
from eddi.diagnosis.decide import Decision, decide
from eddi.diagnosis.lowpass import NAME as LOWPASS_NAME, correction_note as lowpass_note, lowpass_candidate, over_delay
from eddi.diagnosis.results import Candidate, Symptom

#: The corrections of a lagging response (a named one lifts the lag's veto).
NAMES = (LOWPASS_NAME, LAG_NAME)


def candidates(records, setup, parts, fold_masks, res, f1: float, consistency: float, floor_nrmse: float,
               refine: bool = False, mapper=None) -> list[Candidate]:
    """The lag's corrections (their held-out simulations go to ``res.cand_sims``); the low-pass
    contradicted when it earns nothing over the alignment beyond ``floor_nrmse``."""
    out: list[Candidate] = []
    got = lag_candidate(records, setup, parts, fold_masks, res.base_fold, f1, consistency, refine, mapper)
    lag = None
    if got is not None:
        lag, sims = got
        if sims:
            res.cand_sims[LAG_NAME] = sims
        out.append(lag)
    low = lowpass_candidate(records, setup, parts, fold_masks, res.base_fold, f1, refine, mapper)
    if low is not None:
        cand, sims = low
        if sims:
            res.cand_sims[LOWPASS_NAME] = sims
        out.append(over_delay(cand, lag, floor_nrmse))
    return out


def notes(cands: Sequence[Candidate]) -> list[str]:
    return [lag_note(c) if c.name == LAG_NAME else lowpass_note(c) for c in cands if c.name in NAMES]


def named(dec: Decision, cands: Sequence[Candidate], base_fold, floor, rules, eddi_fold) -> Decision:
    """``dec``, or a correction named when the baseline is within the floor (``none``, which the
    measured lag forbids) and it passes every test of :func:`decide` with the margin's cut (the
    lag is measured directly, over the blow; the held-out cut confirms that it is what the
    simulation misses). The low-pass first (it is contradicted when it earns nothing over the
    alignment)."""
    if dec.cause != "none":
        return dec
    margin, none_factor, named_factor, strong_margin = rules
    tried = [c for c in cands if c.name in NAMES and not c.skipped and c.model is not None]
    tried.sort(key=lambda c: NAMES.index(c.name))
    for c in tried:
        again = decide([c], base_fold, floor, margin, none_factor, named_factor,
                       strong_margin=margin if strong_margin is None else min(margin, strong_margin),
                       eddi_fold=eddi_fold)
        if again.winner is c:
            return again
    return dec


def immaterial(dec: Decision, cands: Sequence[Candidate], floor, none_factor: float) -> Candidate | None:
    """The correction that shows a claimed lag immaterial (module notes), else None: ``dec`` is
    ``none``, the alignment was measured on every held-out part, and the baseline and the aligned
    model are both within the floor of the data itself (not only within ``none_factor`` of it: a
    baseline 1.4x the floor that the alignment cuts by 42 % is not a lag that changes nothing)
    and within that floor of each other."""
    if dec.cause != "none" or dec.winner is not None:
        return None
    lag = next((c for c in cands if c.name == LAG_NAME and not c.skipped and c.model is not None), None)
    if lag is None or not math.isfinite(lag.nrmse) or not lag.fold_nrmse:
        return None
    fl = floor.data_nrmse
    if not (max(lag.nrmse, lag.reference_nrmse) <= fl and abs(lag.reference_nrmse - lag.nrmse) < fl
            and all(math.isfinite(v) for v in lag.fold_nrmse)):
        return None
    return lag


def immaterial_text(lag: Candidate, symptoms: Sequence[Symptom], floor_nrmse: float) -> str:
    """The verdict's sentence on an immaterial lag."""
    said = "; ".join(s.text for s in symptoms if s.kind == "response_lag")
    return (f" The measurement chain delays the response ({said}); corrected, the held-out error moves "
            f"{lag.reference_nrmse:.3g} -> {lag.nrmse:.3g}, less than the floor of the data ({floor_nrmse:.3g}): "
            "the lag does not bear on the model, so it is reported and does not overturn the verdict (correct "
            "for it before comparing forced responses or phases).")


def text(dec: Decision, cands: Sequence[Candidate], symptoms: Sequence[Symptom] = ()) -> str:
    """A sentence for the verdict on each correction measured (the named one's fit too), and what a
    one-sample blow cannot tell (:data:`eddi.diagnosis.lag.ONE_SAMPLE_MIN_LAG`), else ''."""
    short = [s.text.split(":", 1)[0] for s in symptoms
             if s.kind == "response_lag" and s.values.get("one_sample", 0.0)]
    out = ""
    if short and any(c.name in NAMES for c in cands):
        out += (f" The blow lasts one sample on {', '.join(short)}: the lag is measured there to about a "
                "sample, and whether the channel delays the response or low-passes it cannot be told from "
                "such a blow (no low-pass is fitted on it); what the alignment leaves may be the filter's "
                "shape. A softer tip or a higher rate tells them apart.")
    for c in cands:
        if c.name in NAMES:
            head = ("Fitted" if dec.winner is c else
                    "Corrected for the lag" if c.name == LAG_NAME else "Corrected for a low-pass")
            out += f" {head}: " + notes([c])[0].split(": ", 1)[1] + "."
    return out


def lifts(dec: Decision, s: Symptom, lag_ok: bool) -> bool:
    """Whether the chain's lag finding ``s`` no longer overturns the verdict: a correction was
    named, or the lag is immaterial (``lag_ok``)."""
    return s.kind == "response_lag" and ((dec.winner is not None and dec.winner.name in NAMES) or lag_ok)


def impulse_through_lowpass(dec: Decision, records, mass: float | None, f1: float,
                            symptoms: list[Symptom]) -> list[Symptom]:
    """``symptoms`` with the impulse-mass finding made on the records with the force through the
    fitted low-pass when ``sensor_lowpass`` wins: the momentum the low-passed acceleration gives
    is spread past the window a delay widens (my tuning Butterworth set at 5 kHz, a 3.2-sample
    group delay on a 3.3-sample blow: a mass 9 % light with the window widened by the lag), so
    the finding as measured would forbid the very correction that explains it."""
    from eddi.diagnosis.chain import inspect
    from eddi.diagnosis.lowpass import _settle, ba_of, filtered

    if mass is None or dec.winner is None or dec.winner.name != LOWPASS_NAME:
        return symptoms
    p = dec.winner.params
    b, a = ba_of(p, records[0].rate_hz)
    late = _settle(b, a)
    fixed = [filtered(r, b, a, late) for r in records]
    # the impulse mass only: no line-tone search (~30 ms a record) for symptoms dropped
    again = [s for s in inspect(fixed, mass, f1, tones=[[] for _ in fixed]) if s.kind == "impulse_mass"]
    return [s for s in symptoms if s.kind != "impulse_mass"] + again
