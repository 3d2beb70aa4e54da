"""Mains interference corrected, and the cause ``mains_interference`` earned held out.

The tones :mod:`eddi.diagnosis.mains` finds (:func:`eddi.diagnosis.chain.record_tones`) are
subtracted from each record's acceleration (frequency refined, amplitude and phase fitted on the
pre-trigger and the late tail, phase-continuous over the capture) and the record is conditioned
again (:func:`cleaned`). The diagnosis is run on the corrected records and judged, like the other
chain causes (``sensor_highpass``: the corrected model seen through the chain, on the records as
measured), per held-out part: the corrected model's held-out simulation plus the tone's share of
the displacement (the difference of the record's two conditionings) against the record as
measured (:func:`judged`). ``mains_interference`` is named when

* the corrected diagnosis finds the baseline complete (``none`` within its floor), and
* the corrected model reproduces every held-out part as measured better than the baseline
  fitted to the records with the tone (the tone is what that baseline was missing).

The named diagnosis keeps the first one's baseline, candidates and symptoms (judged on the records
as measured); its extended model is the corrected baseline, its held-out views and noise floor
the corrected records' (figures show the records with the tone removed).

When the corrected diagnosis names a physical mechanism, that name stands (said to be found with
the tone removed); when it is ``unexplained`` the first diagnosis stands with a note. When the
first diagnosis is ``none``, the tone is reported (a ``line_tone`` symptom) and nothing is re-run.
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np

from eddi.diagnosis.records import Record
from eddi.diagnosis.results import Diagnosis
from eddi.diagnosis.show import nrmse
from eddi.errors import EddiError

NAME = "mains_interference"


def cleaned(records: Sequence[Record], tones: Sequence[Sequence] | None = None
            ) -> tuple[list[Record], list[list]] | None:
    """The records with their line tones removed and conditioned again, and the tones per
    record; None when no record holds a tone or a record cannot be conditioned again.
    ``tones``: per record :func:`eddi.diagnosis.chain.record_tones` when already found (the
    diagnosis found them for its symptoms; None: searched here)."""
    from eddi.conditioning import condition
    from eddi.diagnosis.chain import record_tones
    from eddi.diagnosis.mains import remove_tones

    tones = [list(tn) for tn in tones] if tones is not None else [record_tones(r) for r in records]
    if not any(tones):
        return None
    out = []
    for r, tn in zip(records, tones):
        if not tn:
            out.append(r)
            continue
        a = remove_tones(r.t, r.a, tn)
        try:
            c = condition(r.t, acc=a, force=r.force, pretrigger_samples=r.pretrigger_samples)
        except EddiError:
            return None
        new = Record.from_conditioned(c, r.label, pretrigger_samples=r.pretrigger_samples)
        out.append(new.replace(free_start=r.free_start, free_stop=r.free_stop, response="acc"))
    return out, tones


def judged(d0: Diagnosis, d1: Diagnosis) -> tuple[list[float], list[float]] | None:
    """Per held-out part: the first diagnosis' baseline and the corrected diagnosis' delivered
    model, both against the records as measured (the corrected one's simulation plus the tone's
    displacement), over the samples both judge; None when the two diagnoses' parts differ in
    record or end."""
    if len(d0.held_out) != len(d1.held_out):
        return None
    e0, e1 = [], []
    for h0, h1 in zip(d0.held_out, d1.held_out):
        p0, p1 = h0.part, h1.part
        if (p0.record, p0.stop) != (p1.record, p1.stop):
            return None
        # a capture beyond the others' amplitude is judged from where it enters their range, which
        # moves a little with the tone removed: the samples both judge
        s = max(p0.start, p1.start)
        a0, a1 = s - p0.start, s - p1.start
        x1 = h1.x_extended if d1.cause not in ("none", "unexplained") else h1.x_baseline
        meas = h0.x_measured[a0:]
        tone = meas - h1.x_measured[a1:]
        e0.append(nrmse(h0.x_baseline[a0:], meas))
        e1.append(nrmse(x1[a1:] + tone, meas))
    return e0, e1


def _tone_words(d0: Diagnosis) -> str:
    return "; ".join(s.text for s in d0.symptoms if s.kind == "line_tone")


def verdict(d0: Diagnosis, d1: Diagnosis | None) -> Diagnosis:
    """The diagnosis once the line tones were removed (module notes); ``d1``: on the corrected
    records (None: could not be made)."""
    if d1 is None:
        return d0
    errs = judged(d0, d1)
    words = _tone_words(d0)
    if d1.cause not in ("none", "unexplained"):
        return dataclasses.replace(
            d1, verdict=f"With the line tone removed ({words}): {d1.verdict}",
            symptoms=tuple(d1.symptoms) + tuple(s for s in d0.symptoms if s.kind == "line_tone"),
            notes=tuple(d1.notes) + (f"found on the records with the mains tone removed (first verdict: "
                                     f"{d0.cause})",))
    if d1.cause == "none" and errs is not None and all(b < a for a, b in zip(*errs)):
        e0, e1 = float(np.mean(errs[0])), float(np.mean(errs[1]))
        text = (f"{NAME}: {words}. With the tone removed the baseline is complete ({d1.verdict.rstrip('.')}); "
                f"seen through the tone it reproduces every held-out part as measured better than the baseline "
                f"fitted with the tone in the records (mean held-out nrmse {e0:.3g} -> {e1:.3g}): the first "
                f"verdict ({d0.cause}) was the tone's")
        ext = dataclasses.replace(d1.baseline, nrmse=e1, fold_nrmse=tuple(errs[1]))
        return dataclasses.replace(d1, cause=NAME, verdict=text, extended=ext,
                                   gain=float(1.0 - e1 / e0) if e0 > 0 else 0.0,
                                   baseline=d0.baseline, candidates=tuple(d0.candidates),
                                   symptoms=tuple(d0.symptoms),
                                   notes=tuple(d0.notes) + ("the delivered model is the baseline fitted on the "
                                                            "records with the mains tone removed",))
    why = ("the corrected records' verdict is unexplained too" if d1.cause == "unexplained" else
           "the corrected model does not reproduce every held-out part better")
    return dataclasses.replace(d0, notes=tuple(d0.notes) + (f"a line tone was removed and the diagnosis re-run: "
                                                            f"{why} ({d1.cause}): not named {NAME}",))
