"""The ``response_lag`` correction: the hammer force aligned with a response that lags it.

:mod:`eddi.diagnosis.lag` measures how far the measured acceleration comes after the force over
the blow (a filter on one channel: an anti-alias or conditioner low-pass, channels sampled
apart) and :func:`eddi.diagnosis.chain.inspect` names it. A held-out record is simulated from
rest driven by the measured force (:func:`eddi.diagnosis.show.simulate_part_xv`), so the
simulation runs ahead of the record by the lag: a phase slip of ``2 pi f1 lag`` over the whole
ring-down, and a momentum over the blow's window that the response has not yet shown.

The correction, when a lag is claimed on some record, is found and judged like the chain's other
correction (``sensor_highpass``, :mod:`eddi.diagnosis.highpass`): each record's force is moved
later by its measured lag (:func:`eddi.calculus.delay`: the project's interpolating spline, to a
fraction of a sample; a record whose blow is too short for a lag to be measured takes the
median of the others), the driven window widened by it; the baseline is refitted per fold on
the aligned records exactly as it was on the records as measured (:func:`judge_baseline`, the
same fitter and refinement policy) and judged on the held-out parts, which the alignment
leaves as measured (``x``, ``v``, ``a`` are the response's: only the force moves). The
candidate carries the held-out nrmse before and after and the hammer impulse over the
momentum before and after (:func:`eddi.diagnosis.chain.impulse_mass_ratio`: the window ending
with the force pulse, then widened by the measured lag); it is named when
it earns the name like any other (:func:`eddi.diagnosis.decide.decide`). Without a claimed lag
nothing is tried: a lag that is not measured is never corrected (nulls stay silent).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from eddi.calculus import delay
from eddi.diagnosis.chain import impulse_mass_ratio, response_lag
from eddi.diagnosis.extend import Setup
from eddi.diagnosis.records import Part, Record
from eddi.diagnosis.results import Candidate
from eddi.errors import EddiError

#: The candidate's name (a measurement-chain cause, found by :func:`eddi.diagnosis.chain.inspect`).
NAME = "response_lag"


def record_lags(records: Sequence[Record], f1: float) -> list[float] | None:
    """Per record, the lag [samples] its force is to be moved by; None when no record's lag is
    claimed (:class:`eddi.diagnosis.lag.ResponseLag`). A record whose lag cannot be measured
    (a blow under 5 samples, no measured acceleration) takes the median of the measured ones."""
    lags = [response_lag(r, f1) for r in records]
    if not any(g is not None and g.claimed for g in lags):
        return None
    measured = [g.samples for g in lags if g is not None]
    fill = float(np.median(measured))
    return [g.samples if g is not None else fill for g in lags]


def aligned(rec: Record, lag_samples: float) -> Record:
    """``rec`` with its force moved later by ``lag_samples`` (negative: earlier) and the impact
    window the simulation is driven over widened by it (module notes)."""
    if rec.force is None or lag_samples == 0.0:
        return rec
    force = delay(rec.force, lag_samples)
    if not rec.impact_end > rec.impact_start:
        return rec.replace(force=force)
    late, early = max(0, math.ceil(lag_samples)), max(0, math.ceil(-lag_samples))
    # the response's blow ends ``late`` samples after the force's: its free response starts there
    free = min(rec.free_stop - 1, rec.free_start + late)
    return rec.replace(force=force, impact_start=max(0, rec.impact_start - early),
                       impact_end=min(free, rec.impact_end + late), free_start=free)


def _trimmed(masks: Sequence[np.ndarray], records: Sequence[Record], al: Sequence[Record]) -> list[np.ndarray]:
    """A fold's training masks without the samples the aligned records no longer count as free
    response (the lagging response's blow: a 12-sample delay at 5 kHz on a 59 Hz structure left
    the fit 2.0 off held out with them in, the true model 0.018)."""
    out = []
    for m, r, a in zip(masks, records, al):
        m = m.copy()
        m[r.free_start:a.free_start] = False
        out.append(m)
    return out


def lag_candidate(records: Sequence[Record], setup: Setup, parts: Sequence[Part],
                  fold_masks: Sequence[Sequence[np.ndarray]], base_fold: Sequence[float], f1: float,
                  consistency: float, refine: bool = False, mapper=None
                  ) -> tuple[Candidate, list[np.ndarray]] | None:
    """The ``response_lag`` candidate (module notes) and its held-out simulations; None when no
    record's lag is claimed. ``base_fold``: the baseline's held-out nrmse per part as judged
    (refined when ``refine``, as the pipeline refines); ``f1`` [Hz] the measured resonance."""
    lags = record_lags(records, f1)
    if lags is None:
        return None
    al = [aligned(r, g) for r, g in zip(records, lags)]
    params: dict[str, float] = {"lag_samples": float(np.median(lags)),
                                "lag_s": float(np.median(lags)) / records[0].rate_hz}
    mass = setup.mass
    # the impulse over the momentum with the window ending with the force pulse (as if there were
    # no lag) and widened by the measured lag (the chain's own weighing since session 13): on the
    # aligned records a low-pass still smears the momentum past the pulse (my held-out Butterworth
    # set: 0.934 as measured, 1.038 aligned with the window ending with the moved pulse)
    before = impulse_mass_ratio(records, mass, f1, lag_window=False) if mass else None
    after = impulse_mass_ratio(records, mass, f1) if mass else None
    if before is not None and after is not None:
        params["impulse_ratio_before"], params["impulse_ratio_after"] = before[0], after[0]
    spread = {"lag_samples": float(np.std(lags, ddof=1)) if len(lags) > 1 else 0.0}
    consistent = bool(spread["lag_samples"] < consistency * abs(params["lag_samples"]))
    symptom = (f"is driven by a force {abs(params['lag_s']) * 1e3:.3g} ms ({abs(params['lag_samples']):.1f} "
               f"samples) {'ahead of' if params['lag_s'] > 0 else 'behind'} the measured response (a filter on "
               "one channel: anti-alias, conditioner, the accelerometer's mounting, or channels sampled apart): "
               "the force-driven simulation slips; the force aligned with the response fixes it")
    return refitted_candidate(NAME, records, al, setup, parts, fold_masks, base_fold, refine, mapper,
                              consistent, params, spread, symptom, "aligned records")


def refitted_candidate(name: str, records: Sequence[Record], al: Sequence[Record], setup: Setup,
                       parts: Sequence[Part], fold_masks: Sequence[Sequence[np.ndarray]],
                       base_fold: Sequence[float], refine: bool, mapper, consistent: bool,
                       params: dict[str, float], spread: dict[str, float], symptom: str, what: str,
                       contradicted: str = "") -> tuple[Candidate, list[np.ndarray]]:
    """A measurement-chain correction's candidate (``response_lag``, ``sensor_lowpass``): the
    baseline refitted on the corrected records ``al`` (:func:`refit`) and judged against
    ``base_fold`` on the held-out parts, with its held-out simulations; a failed refit is a skipped
    candidate saying why (``what``: the corrected records, for that line)."""
    try:
        res, fit_all = refit(records, al, setup, parts, fold_masks, refine, mapper)
    except EddiError as exc:
        return (Candidate(name, float("nan"), (), float("nan"), False, False, params, spread, None, "",
                          f"the baseline could not be refitted on the {what} ({exc})"), [])
    folds = [float(v) for v in res.base_fold]
    mean, ref = float(np.mean(folds)), float(np.mean(base_fold))
    return (Candidate(name, mean, tuple(folds), 1.0 - mean / ref if ref > 0 else 0.0,
                      _wins(folds, base_fold, parts), consistent, params, spread,
                      fit_all.eom if fit_all is not None else None, symptom, "", ref, "baseline",
                      contradicted=contradicted),
            list(res.base_sims))


def refit(records: Sequence[Record], al: Sequence[Record], setup: Setup, parts: Sequence[Part],
          fold_masks: Sequence[Sequence[np.ndarray]], refine: bool = False, mapper=None):
    """(fold results, all-data fit) of the baseline refitted per fold on ``al`` (``records`` with
    the force moved or filtered, the free response starting after the response's blow) exactly as
    it was on ``records`` (:func:`judge_baseline`), judged on the held-out parts; raises
    :class:`EddiError` when a fit fails."""
    from eddi.diagnosis.fitter import Fitter, all_masks
    from eddi.diagnosis.folds import judge_baseline

    fitter = Fitter([r.signal() for r in al], setup, al, refine, mapper)
    res, _fits = judge_baseline(al, setup, parts, [_trimmed(m, records, al) for m in fold_masks], fitter)
    return res, fitter(all_masks(al))(None, None)


#: On a held-out part the force does not drive (judged from its measured state) the aligned fit
#: must be within this fraction of the baseline: there the two simulations differ only by the
#: refit without the samples of the response's blow (:func:`_trimmed`).
TIE_SHARE = 0.01


def _wins(folds: Sequence[float], base_fold: Sequence[float], parts: Sequence[Part]) -> bool:
    """Better than the baseline on every part the force drives (simulated from rest through the
    blow) and no worse than :data:`TIE_SHARE` on the others: a part judged from its measured
    state (the largest capture's, where it decays into the training range) is the same
    simulation either way but for the refit (my 0.8 kg, 40 Hz case behind a 1 kHz Butterworth:
    0.0037 both ways there, 0.039 -> 0.007 on the driven parts); at least one driven part."""
    if len(folds) != len(base_fold) or not any(p.from_rest for p in parts):
        return False
    return all((a < b) if p.from_rest else (a <= (1.0 + TIE_SHARE) * b)
               for a, b, p in zip(folds, base_fold, parts))


def correction_note(c: Candidate) -> str:
    """The correction's figures in one sentence (for the diagnosis' notes)."""
    p = c.params
    if c.skipped or not math.isfinite(c.nrmse):
        return f"{NAME}: not measured ({c.skipped or 'no held-out part could be simulated'})"
    text = (f"{NAME}: the force aligned with the response by {p['lag_samples']:.2f} samples "
            f"({1e3 * p['lag_s']:.3g} ms, spread {c.spread.get('lag_samples', 0.0):.2f} over the records) and the "
            f"baseline refitted: held-out nrmse {c.reference_nrmse:.3g} -> {c.nrmse:.3g} "
            f"({abs(100 * c.gain):.0f} % {'less' if c.gain >= 0 else 'more'}), per part "
            + ", ".join(f"{v:.3g}" for v in c.fold_nrmse))
    if "impulse_ratio_before" in p:
        text += (f"; hammer impulse over momentum {p['impulse_ratio_before']:.4g} over the force pulse, "
                 f"{p['impulse_ratio_after']:.4g} over the window widened by the lag")
    return text
