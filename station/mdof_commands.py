"""``station validate`` and ``station diagnose`` on multi-channel captures (several sensors).

:func:`validate_mdof_object` scores an :class:`eddi.mdof.model.MdofModel` on every record:
per-channel nrmse and their mean as ``nrmse``. :func:`diagnose_mdof_object` identifies the
uncoupled baseline (each coordinate's own terms) and the coupled model (coupling terms found
from the energy exchanged between coordinates, :mod:`eddi.mdof.identify`), judges both on
held-out captures (each capture held out in turn) and names ``modal_coupling`` when the
coupled model wins by more than ``margin`` (also when the tail holds positive evidence of a
motion no linear mode describes and the coordinates are the physical channels: an energy sink's
purely cubic attachment is a nonlinear coupling between them), ``missing_mode`` when the tail
holds that evidence (:func:`eddi.mdof.identify.modal_evidence`) and no coupling between the
physical channels explains it held out, ``unexplained`` when the tail resolves fewer
modes than channels and no coupling wins (a mode the records cannot resolve is not named).
``modal_coupling`` needs a nonlinear term between coordinates in the model (a better fit of
linear springs is not a coupling). The verdict is then earned per channel against the
prediction floor of the held-out folds (:mod:`eddi.mdof.verdict`, :mod:`eddi.mdof.predfloor`), per
mode against the records' frequency and damping at every amplitude the ring-downs sweep
(:mod:`eddi.mdof.amplitude`), and says how far the captures' blow sizes tested extrapolation in
amplitude.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from eddi.errors import IdentificationError
from eddi.mdof.agreement import AGREEMENT_LEAST
from eddi.mdof.amplitude import backbone_json
from station.mdof_mains import line_tone_symptoms, split_amplitude, tone_note
from eddi.mdof.collocation import check_driving_point
from eddi.mdof.identify import identify_mdof
from eddi.mdof.model import MdofModel
from eddi.mdof.validate import validate_mdof
from eddi.mdof.verdict import MDOF_MIN_FLOOR, channel_floor, held_out_gain
from station.errors import InputFileError
from station.mdof_data import condition_all, driving_point_how, reduce_rate
from station.mdof_fitcheck import fit_warnings
from station.mdof_floor import add_floors, mode_lines, modes_judged
from station.mdof_folds import PROGRESS_S, _final_baseline, _held_out_folds, nonlinear_coupling_terms
from station.mdof_mechanism import add_mechanisms, mechanism_lines
from station.mdof_polish import polish_tag
from station.mdof_verdict import coupling_short, refit_floor
from station.output_safety import write_text_atomic


def _read(specs: Sequence[str]):
    from station.session import expand_specs, read_measurement

    return [read_measurement(s) for s in expand_specs(list(specs))]


def validate_mdof_object(model: MdofModel, model_path: str, specs: Sequence[str]) -> dict[str, Any]:
    """The ``--json`` object of ``station validate`` for an MDOF model."""
    records, names, _dp = condition_all(_read(specs), model.driving_point, order=model.channels)
    if tuple(names) != tuple(model.channels):
        raise InputFileError(f"the captures' response channels ({', '.join(names)}) are not the model's "
                             f"({', '.join(model.channels)})")
    out = []
    for r in records:
        v = validate_mdof(model, r)
        out.append({"source": r.label, "nrmse": v.nrmse, "channel_nrmse": v.channel_nrmse,
                    "mode_nrmse": [float(x) for x in v.mode_nrmse], "driven_by": v.driven_by,
                    "diverged": v.diverged, "nmte": None})
    per = {c: float(np.mean([o["channel_nrmse"][c] for o in out])) for c in model.channels}
    obj = {"model": model_path, "model_kind": "mdof", "compared": "displacement of every channel",
           "records": out, "channel_nrmse": per, "nrmse": float(np.mean([o["nrmse"] for o in out])),
           "nmte": None, "warnings": _driving_point_heard(records, names, model.driving_point)}
    add_floors(obj, model, records)  # each channel's prediction floor (station.mdof_floor)
    return obj


def _driving_point_heard(records: Sequence[Any], names: Sequence[str], dp: str) -> list[str]:
    """The model's driving point checked against the signs of the captures' residues
    (:mod:`eddi.mdof.collocation`; the tail's linear modes found here, ~0.1-5 s CPU)."""
    from eddi.mdof.identify import linear_modes

    if dp not in names or not all(r.force is not None for r in records):
        return []
    try:
        modes = linear_modes(records, driving_point=list(names).index(dp))
    except IdentificationError:
        return []
    return check_driving_point(modes, records, names, dp, "the model's")


def validate_mdof_text(obj: dict[str, Any]) -> str:
    lines = [f"{obj['model']} (mdof, {len(obj['channel_nrmse'])} channels), {obj['compared']} compared:"]
    for r in obj["records"]:
        chans = "  ".join(f"{c} {v:.4g}" for c, v in r["channel_nrmse"].items())
        lines.append(f"  {r['source']:<40} nrmse {r['nrmse']:.4g}  ({chans}; from rest, {r['driven_by']}"
                     + (", diverged" if r["diverged"] else "") + ")")
    chans = "  ".join(f"{c} {v:.4g} (floor {obj['channel_floor'][c]:.2g})" for c, v in obj["channel_nrmse"].items())
    lines.append(f"  mean over {len(obj['records'])} record(s): nrmse {obj['nrmse']:.4g}  ({chans})")
    lines += [f"WARNING: {w}" for w in obj.get("warnings", [])]
    return "\n".join(lines)


def diagnose_mdof_object(specs: Sequence[str], *, driving_point: str | None = None, margin: float = 0.1,
                         save_model: str | None = None, refine: bool = False) -> dict[str, Any]:
    """Baseline (uncoupled) vs coupled, held out; the cause named (module docstring)."""
    raw = _read(specs)
    meas, rate_note = reduce_rate(raw)  # the working rate (eddi.mdof.rate)
    records, names, dp = condition_all(meas, driving_point)
    if len(records) < 2:
        raise InputFileError("diagnose on multi-channel captures needs at least 2 captures (one is held out)")
    from station.forkmap import ForkMap, jobs_wanted

    # the folds are independent: in forked workers when cores are free (the same results)
    began = time.perf_counter()
    mapper = ForkMap(jobs_wanted())
    # with a second process, the coupled model on every capture (and its polish) is computed
    # beside the folds rather than after them (the longest item, first); it is the final model
    # whenever coupling earns its place, else discarded (spent CPU, not wall: only when forking)
    ahead = (lambda: _final_coupled(records, names, dp, refine, quiet=True)) if mapper.jobs > 1 else None
    folds, per_channel, per_mode, span = _held_out_folds(records, names, dp, refine=refine, margin=margin,
                                                         mapper=mapper, ahead=ahead)
    if time.perf_counter() - began > PROGRESS_S and ahead is None:  # a long diagnosis is not silent until its end
        print(f"station diagnose: {len(records)} held-out folds done in {time.perf_counter() - began:.0f} s; "
              f"the final model on every capture next" + (" (identified and polished)" if refine else ""),
              file=sys.stderr, flush=True)
    polished = folds.pop("polished")
    fold_terms = folds.pop("coupling_terms")
    agreement = folds.pop("agreement")
    fits = folds.pop("fits")
    mode_folds = folds.pop("modes")
    computed = folds.pop("ahead")
    fold_floors = folds.pop("floors")  # per kind, eddi.mdof.predfloor.FoldFloors
    base = float(np.mean(folds["baseline"]))
    cpl = float(np.mean(folds["coupled"]))
    raw_gain = held_out_gain(folds["baseline"], folds["coupled"])  # per fold (eddi.mdof.verdict)
    wins, gain, allowance = _coupling_earned(folds, per_channel, names, margin, fold_floors["baseline"])
    by_mode = modes_judged(mode_folds, folds["baseline"], folds["coupled"], margin)
    in_mode = bool(not wins and by_mode is not None and by_mode.earned)  # a coupling that lives in a weak mode
    if in_mode:
        wins, gain = True, by_mode.excess_gain[by_mode.mode]
    stalled = _baseline_stalled(folds["baseline"], records)
    if wins:
        final, model = computed if computed is not None else _final_coupled(records, names, dp, refine)
    else:  # no coupling earns its place: the baseline
        final = _final_baseline(records, names, dp)
        model = final.model
        if refine:
            from eddi.mdof.refine import refine_identified

            model, _b, _a = refine_identified(final, records)
    # (with ``refine`` the model is polished: the verdict judges the model delivered)
    notes = list(final.notes) + ([rate_note] if rate_note else []) + ([stalled] if stalled else [])
    if allowance is not None and allowance.earned:
        notes.append(allowance.note(raw_gain, margin))
    elif in_mode:
        notes.append(by_mode.note(raw_gain, margin))
    elif wins and raw_gain <= margin:
        notes.append(f"the coupled model removes {100 * gain:.0f} % of the baseline's error above the noise floor "
                     f"held out (better on every fold; raw gain {100 * raw_gain:.0f} %, margin {100 * margin:.0f} %), "
                     "and the baseline is not within its allowance")
    cause = _first_cause(final, gain, margin, len(names), notes, fold_terms,
                         _baseline_complete(per_channel["baseline"], fold_floors["baseline"], names), agreement)
    delivered = "coupled" if wins else "baseline"
    floors = fold_floors[delivered].channel_floors(names, MDOF_MIN_FLOOR)  # the floor every rule below judges on
    verdict, amp, modes, amp_span = _earned(cause, per_channel[delivered], records, names, model, dp, floors)
    # the measurement chain (clipping, double hit, base motion) is heard on the captures as recorded
    verdict = _chain_heard(verdict, raw, records if rate_note is None else condition_all(raw, dp)[0], names, dp,
                           model)
    # mains interference: a line tone in the tail is read as a mode ringing there (station.mdof_mains)
    tones = line_tone_symptoms(raw, names)
    amp, by_tone = split_amplitude(amp, tones)
    cause, symptoms = verdict.cause, list(verdict.symptoms) + amp + by_tone + tones
    if verdict.note:
        notes.append(verdict.note)
    if tones:
        notes.append(tone_note(tones, by_tone))
    cause = _amplitude_heard(cause, amp, amp_span, notes)
    obj: dict[str, Any] = {
        "captures": [r.label for r in records], "channels": list(names), "driving_point": dp,
        "scheme": f"leave-one-out over {len(records)} captures",
        "polished_folds": polished if refine else None,
        "baseline": {"nrmse": base, "folds": folds["baseline"],
                     "channel_nrmse": {c: float(np.mean(v)) for c, v in per_channel["baseline"].items()},
                     "mode_nrmse": fold_mean_per_mode(per_mode["baseline"])},
        "coupled": {"nrmse": cpl, "folds": folds["coupled"],
                    "channel_nrmse": {c: float(np.mean(v)) for c, v in per_channel["coupled"].items()},
                    "mode_nrmse": fold_mean_per_mode(per_mode["coupled"])},
        "gain": gain, "raw_gain": raw_gain, "margin": margin, "cause": cause, "coupling_agreement": agreement, "coordinates": final.coordinates,
        "allowance": allowance.as_dict() if allowance is not None else None,
        "modes": dict(by_mode.as_dict(), decided=in_mode) if by_mode is not None else None,
        "noise_floor": channel_floor(records, names), "prediction_floor": verdict.noise_floor,
        "floor_parts": fold_floors[delivered].parts(names), "symptoms": symptoms,
        "amplitude": {"span": amp_span.as_dict(), "backbones": backbone_json(modes)},
        "span_residual": final.span_residual,
        "linear_modes_hz": final.modes.frequencies_hz.tolist(),
        "natural_frequencies_hz": model.natural_frequencies_hz().tolist(),
        "coupling_terms": [sorted(t for t in s if len(_coords(t)) > 1 or _coords(t) != {i})
                           for i, s in enumerate(model.stiffness)],
        "coupling_coefficients": [
            {t: [c, (model.stiffness_ci95[i].get(t) if model.stiffness_ci95 else None)]
             for t, c in sorted(st.items()) if len(_coords(t)) > 1 or _coords(t) != {i}}
            for i, st in enumerate(model.stiffness)],
        "exchanged_fraction": [f.exchanged_fraction for f in final.equations],
        "model": model.equation_text(), "notes": notes,
    }
    _coupling_determined(obj)
    # a none above the floor that the coupled model consistently improves (station.mdof_verdict)
    coupling_short(obj, delivered, fold_terms)
    # a none above the floor: the identification's scatter from the noise measured and counted (session 20)
    refit_floor(obj, delivered, fits, records, fold_floors[delivered], dp, mapper)
    _uncertain_none(obj, delivered)
    add_mechanisms(obj, final)
    obj["warnings"] = _model_flags(model, folds["coupled" if wins else "baseline"])
    obj["unstable"] = bool(obj["warnings"])
    obj["warnings"] += fit_warnings(obj, model, records, names)  # the fit against its floor (station.mdof_fitcheck)
    # the declared driving point checked against the signs of every channel's residues (warned only)
    obj["warnings"] += check_driving_point(final.modes, records, names, dp,
                                           driving_point_how(raw[0], driving_point))
    if save_model:
        write_text_atomic(save_model, model.to_json() + "\n")
        obj["saved_model"] = save_model
    return obj


def _uncertain_none(obj: dict[str, Any], delivered: str) -> None:
    """A ``none`` whose delivered model sits above a channel's prediction floor held out
    (:mod:`eddi.mdof.predfloor`; within the ``NONE_FACTOR`` allowed) is said to be uncertain, as the
    one-coordinate loop says it (``Cause: none (uncertain)``): JSON ``uncertain`` true and a note with
    the worst channel and how the coupled model fared (better on how many folds, its gain against the
    margin). Never a plain ``none`` above the floor."""
    obj["uncertain"] = False
    if obj["cause"] != "none":
        return
    held, floors = obj[delivered]["channel_nrmse"], obj.get("prediction_floor") or obj["noise_floor"]
    ratios = {c: held[c] / floors[c] for c in held if c in floors and floors[c] > 0 and math.isfinite(held[c])}
    if not ratios or max(ratios.values()) <= 1.0:
        return
    worst = max(ratios, key=ratios.__getitem__)
    base, cpl = obj["baseline"]["folds"], obj["coupled"]["folds"]
    better = sum(float(c) < float(b) for b, c in zip(base, cpl))
    obj["uncertain"] = True
    obj["notes"].append(
        f"none (uncertain): the delivered model's held-out error is {ratios[worst]:.1f}x the "
        f"{'prediction' if obj.get('prediction_floor') else 'noise'} floor on channel "
        f"{worst} (nrmse {held[worst]:.3g}, floor {floors[worst]:.3g}): above the floor, within the allowance, and no "
        f"coupling earns its place (the coupled model is better on {better} of {len(base)} folds, gain "
        f"{100 * obj['gain']:.0f} % against a margin of {100 * obj['margin']:.0f} %)")


def _coupling_earned(folds: dict[str, list], per_channel: dict[str, dict[str, list]], names: tuple[str, ...],
                     margin: float, floors: Any) -> tuple[bool, float, Any]:
    """:func:`eddi.mdof.verdict.coupling_earned` on the folds (each fold's floor: the mean over the
    channels of its held-out capture's, at least the least floor), else the within-allowance rule
    (:func:`eddi.mdof.allowance.within_allowance`; its evidence, None when the first rule won).
    Only the folds on which the baseline ran count (:func:`eddi.mdof.verdict.baseline_ran`);
    none: not earned, gain 0."""
    from eddi.mdof.allowance import within_allowance
    from eddi.mdof.verdict import baseline_ran, coupling_earned

    # judged on the folds where the baseline ran (a diverged baseline is no measured error)
    ran = [k for k, ok in enumerate(baseline_ran(folds["baseline"])) if ok]
    if not ran:
        return False, 0.0, None
    fb, fc = ([folds[kind][k] for k in ran] for kind in ("baseline", "coupled"))
    kept = floors.take(ran)
    fold_floors = kept.fold_floors(MDOF_MIN_FLOOR)
    base_ch, cpl_ch = ({c: float(np.mean([v[k] for k in ran])) for c, v in per_channel[kind].items()}
                       for kind in ("baseline", "coupled"))
    chan = kept.channel_floors(names, MDOF_MIN_FLOOR)
    wins, gain = coupling_earned(fb, fc, fold_floors, base_ch, chan, margin)
    if wins:
        return wins, gain, None
    ev = within_allowance(fb, fc, fold_floors, base_ch, cpl_ch, chan, margin)
    return ev.earned, (ev.excess_gain if ev.earned else gain), ev


def _baseline_stalled(baseline: Sequence[float], records: Sequence[Any]) -> str | None:
    """The note when the baseline did not run on a held-out capture (diverged, or grew past
    :data:`eddi.mdof.verdict.BASELINE_RAN_NRMSE`): those folds are no evidence for a coupling."""
    from eddi.mdof.verdict import BASELINE_RAN_NRMSE, baseline_ran

    ran = baseline_ran(baseline)
    if np.all(ran):
        return None
    bad = [f"{records[k].label} ({baseline[k]:.3g})" for k in range(len(ran)) if not ran[k]]
    head = (f"baseline diverged: the model without nonlinear coupling did not run on {len(bad)} of {len(ran)} "
            f"held-out captures (held-out nrmse not finite or above {BASELINE_RAN_NRMSE:g}: {', '.join(bad)})")
    return head + ("; no gain is measured and no coupling is named on it" if not np.any(ran) else
                   "; those folds are not counted as evidence for a coupling (the gain is judged on the others)")


def fold_mean_per_mode(rows: Sequence[Sequence[float]]) -> list[float]:
    """Mean over the folds of each coordinate's held-out nrmse. The folds' models need not have the
    same number of coordinates (a fold whose tail resolves one mode fewer keeps fewer): coordinate
    ``k`` is averaged over the folds that have it (session 12: a 3-mass chain with 2 blows and a
    2-mass chain with 6 stopped on a ragged array, a traceback instead of a verdict)."""
    width = max((len(r) for r in rows), default=0)
    return [float(np.mean([float(r[k]) for r in rows if len(r) > k])) for k in range(width)]


def _final_coupled(records: Sequence[Any], names: tuple[str, ...], dp: str, refine: bool, quiet: bool = False
                   ) -> tuple[Any, MdofModel] | None:
    """The coupled identification on every capture and the model delivered (polished with ``refine``).
    ``quiet`` (computed ahead, before it is known to be needed): None instead of an identification
    error (the error is raised when the model is needed and computed again)."""
    if quiet:
        try:
            return _final_coupled(records, names, dp, refine)
        except (IdentificationError, ValueError, FloatingPointError, np.linalg.LinAlgError):
            return None
    final = identify_mdof(records, names, dp, coupling=True)
    if not refine:
        return final, final.model
    from eddi.mdof.refine import refine_identified

    return final, refine_identified(final, records)[0]


def _coupling_determined(obj: dict[str, Any]) -> None:
    """``modal_coupling`` becomes ``unexplained`` with the reason when no nonlinear coupling
    coefficient is determined (:func:`eddi.mdof.verdict.undetermined_coupling`; in place in ``obj``)."""
    from eddi.mdof.allowance import undetermined_weak
    from eddi.mdof.verdict import undetermined_coupling

    # named within the allowance, or in one mode: a stronger cut
    weak = (obj.get("allowance") or {}).get("earned") or _earned_in_mode(obj)
    why = None if obj["cause"] != "modal_coupling" else (
        undetermined_weak(obj["coupling_coefficients"], obj["gain"]) if weak
        else undetermined_coupling(obj["coupling_coefficients"], obj["gain"]))
    if why is not None:
        obj["cause"] = "unexplained"
        obj["notes"].append(why)


def _earned_in_mode(obj: dict[str, Any]) -> bool:
    """Whether the coupling was earned by the per-mode rule alone (:mod:`eddi.mdof.modefloor`)."""
    return bool((obj.get("modes") or {}).get("decided"))


def _model_flags(model: Any, folds: Sequence[float]) -> list[str]:
    """Why the delivered model cannot be trusted as a simulation: its linear part grows, or the
    variant it was chosen from diverged on a held-out capture (as ``station identify`` flags)."""
    from station.mdof_replay import growth_flag

    out = growth_flag(model)
    if any(not math.isfinite(float(f)) for f in folds):
        out.append("the model's simulation diverged on a held-out capture")
    return out


def _baseline_complete(per_channel: dict[str, list], fold_floors: Any, names: tuple[str, ...]) -> bool:
    """Whether the baseline's held-out error is within ``NONE_FACTOR`` x its prediction floor on every
    channel (the allowance a ``none`` needs, :mod:`eddi.mdof.verdict`)."""
    from eddi.diagnosis.settings import NONE_FACTOR

    floors = fold_floors.channel_floors(names, MDOF_MIN_FLOOR)
    held = {c: float(np.mean(v)) for c, v in per_channel.items()}
    return all(math.isfinite(held[c]) and held[c] <= NONE_FACTOR * floors[c] for c in names)


def _first_cause(final: Any, gain: float, margin: float, n_channels: int, notes: list[str],
                 fold_terms: Sequence[bool] = (), complete: bool = False, agreement: float = float("nan")) -> str:
    """The cause from the held-out gain and the tail's modal evidence (module docstring); the
    reason appended to ``notes``. ``fold_terms``: per held-out fold, whether its coupled model
    holds a nonlinear term between coordinates (the evidence must be of what is named).
    ``complete``: the baseline is within its allowance on every channel held out; a mode the tail
    does not resolve is then no reason for ``unexplained`` (session 14: a linear three-mass chain
    whose linear lumped baseline predicts every channel within its floor, tail resolving two modes).
    ``agreement``: the common share of the folds' coupling force (:mod:`eddi.mdof.agreement`); a coupling
    the folds do not agree on is not named (NaN: not judged)."""
    if not final.modal_basis and gain <= margin:
        cause = "missing_mode"
        notes.append("missing mode: the linear modes of the low-amplitude tail do not describe the motion - "
                     "a coordinate with no linear mode (e.g. an essentially nonlinear attachment)")
    elif not final.modal_basis:  # physical coordinates, and a nonlinear coupling between them explains it
        cause = "modal_coupling"
        notes.append("the linear modes of the low-amplitude tail do not describe the motion (a coordinate with "
                     "no linear mode of its own, e.g. an essentially nonlinear attachment): physical "
                     "coordinates, and the nonlinear coupling between them earns its place held out")
    elif final.unresolved and gain <= margin and not complete:
        cause = "unexplained"
        notes.append(f"unexplained: the tail resolves {final.modes.frequencies_hz.size} linear mode(s) for "
                     f"{n_channels} channels and no coupling earns its place held out; a mode these records "
                     "do not resolve is not evidence of a missing one (record quieter or longer ring-downs)")
    else:
        cause = "modal_coupling" if gain > margin else "none"
    if cause == "modal_coupling" and not nonlinear_coupling_terms(final.model):
        # the identification with coupling terms won held out, but what it kept couples the
        # coordinates linearly only (springs, dashpots, a rotated modal basis): a better model of
        # the same kind, not a nonlinear coupling; judged on that model as ``none``
        cause = "none"
        notes.append(f"no coupling named: the identification with coupling terms wins held out (gain "
                     f"{100 * gain:.0f} %) but its model holds no nonlinear term between coordinates")
    elif cause == "modal_coupling" and final.modal_basis and fold_terms and 2 * sum(fold_terms) <= len(fold_terms):
        # the held-out gain was earned by fold models most of which hold no nonlinear coupling (a
        # nonlinearity of one coordinate, e.g. a cubic spring to the ground): the coupling in the
        # final model is not what the folds measured (session 14, h7-ground of bench_mdof_nulls.py)
        cause = "none"
        notes.append(f"no coupling named: the coupled models that win held out (gain {100 * gain:.0f} %) hold a "
                     f"nonlinear term between coordinates on {sum(fold_terms)} of {len(fold_terms)} folds only: "
                     "the gain is not evidence of the coupling in the final model")
    elif cause == "modal_coupling" and agreement < AGREEMENT_LEAST:
        # the folds' coupled models win held out with coupling forces that disagree (session 20, h3-lin2:
        # cubic terms absorbing a biased linear part, their signs changing from fold to fold)
        cause = "none"
        notes.append(f"no coupling named: the coupled models win held out (gain {100 * gain:.0f} %) but the "
                     f"coupling force they identify is not reproduced from fold to fold (common share "
                     f"{100 * agreement:.0f} % of its power, at least {100 * AGREEMENT_LEAST:.0f} % needed): the gain "
                     "is not evidence of one coupling")
    return cause


def _amplitude_heard(cause: str, amp: list[dict], span: Any, notes: list[str]) -> str:
    """``none`` or a name turned ``unexplained`` by an amplitude symptom; the span said when the
    folds did not test extrapolation in amplitude (:mod:`eddi.mdof.amplitude`)."""
    if amp and cause in ("none", "modal_coupling"):
        worst = max(amp, key=lambda s: s["implied_nrmse"])
        notes.append(f"unexplained: the model's frequency and damping against amplitude depart from the records' "
                     f"(mode at {worst['mode_hz']:.4g} Hz: a blow ringing down from {worst['amplitude_m']:.3g} m "
                     f"would leave about {worst['implied_nrmse']:.2g} nrmse, allowed {worst['allowed']:.2g})"
                     + (" (modal coupling is the best partial explanation)" if cause == "modal_coupling" else ""))
        cause = "unexplained"
    if not span.tested:
        notes.append(span.text())
    return cause


def _earned(cause: str, per_channel: dict[str, list], records: Sequence[Any], names: tuple[str, ...],
            model: MdofModel, dp: str, floors: dict[str, float]):
    """The cause checked against each channel's prediction floor ``floors`` (:mod:`eddi.mdof.verdict`,
    :mod:`eddi.mdof.predfloor`), and the
    model's backbone against the records' at every amplitude the ring-downs sweep
    (:mod:`eddi.mdof.amplitude`, allowed the same factor of the floor): the verdict, the
    amplitude symptoms, the backbones and the captures' span."""
    from eddi.diagnosis.settings import NAMED_FACTOR, NONE_FACTOR
    from eddi.mdof.amplitude import amplitude_symptoms, backbones, capture_span
    from eddi.mdof.verdict import earned_verdict

    held = {c: float(np.mean(v)) for c, v in per_channel.items()}
    vals = [validate_mdof(model, r) for r in records]
    verdict = earned_verdict(cause, held, floors, vals,
                             [float(f) for f in model.natural_frequencies_hz()])
    modes = backbones(model, records, vals)
    factor = NAMED_FACTOR if cause == "modal_coupling" else NONE_FACTOR
    return verdict, amplitude_symptoms(modes, verdict.noise_floor, factor), modes, capture_span(records, names, dp)


def _chain_heard(verdict: Any, meas: Sequence[Any], records: Sequence[Any], names: tuple[str, ...], dp: str,
                 model: MdofModel) -> Any:
    """The verdict once the driving point's measurement chain is heard (clipping, double hit,
    base motion: :func:`eddi.mdof.verdict.chain_checked`), from the force as measured."""
    from eddi.mdof.verdict import chain_checked, driving_point_records
    from station.readers import response_channels

    forces, rests = [], []
    for m in meas:
        rest = int(m.pretrigger_samples or 0) or int(np.sum(np.asarray(m.t) < 0))
        f = m.channels.get("force")
        forces.append(None if f is None else np.asarray(f, float) - (np.median(f[:rest]) if rest > 8 else 0.0))
        rests.append(rest)
    qty = response_channels(meas[0].channels)[dp][0]
    dp_recs = driving_point_records(records, names.index(dp), forces, rests, qty)
    hz = [float(f) for f in model.natural_frequencies_hz() if math.isfinite(f) and f > 0]
    return chain_checked(verdict, dp_recs, min(hz) if hz else 0.0, dp)


def _coords(text: str) -> set[int]:
    import re

    return {int(k) - 1 for k in re.findall(r"[xv](\d+)", text)}


def diagnose_mdof_text(obj: dict[str, Any]) -> str:
    b, c = obj["baseline"], obj["coupled"]
    chans = lambda d: "  ".join(f"{k} {v:.4g}" for k, v in d["channel_nrmse"].items())  # noqa: E731
    modes = lambda d: "  ".join(f"q{i + 1} {v:.4g}" for i, v in enumerate(d["mode_nrmse"]))  # noqa: E731
    lines = [f"Held-out judging: {obj['scheme']}; channels {', '.join(obj['channels'])} "
             f"(driving point {obj['driving_point']}); {obj['coordinates']} coordinates",
             f"  uncoupled baseline  held-out nrmse {b['nrmse']:.4g}   per channel: {chans(b)}   per mode: {modes(b)}"
             + polish_tag(obj, "baseline"),
             f"  with coupling       held-out nrmse {c['nrmse']:.4g}   per channel: {chans(c)}   per mode: {modes(c)}"
             + polish_tag(obj, "coupled"),
             f"  gain {100 * obj['gain']:.0f} % (margin {100 * obj['margin']:.0f} %)",
             f"Cause: {obj['cause']}" + (" (uncertain)" if obj.get("uncertain") else "")
             + ("" if obj["cause"] != "modal_coupling" else
                                         f" (coupling terms: {obj['coupling_terms']})")
             + ("" if obj["amplitude"]["span"]["extrapolation_tested"] else
                f" (within {min(obj['amplitude']['span']['peak_m_s2']):.3g}..{max(obj['amplitude']['span']['peak_m_s2']):.3g}"
                f" m/s^2 at {obj['amplitude']['span']['channel']}; extrapolation in amplitude not tested)"),
             *mechanism_lines(obj),
             f"Natural frequencies: {', '.join(f'{f:.5g} Hz' for f in obj['natural_frequencies_hz'])}",
             "Coupling coefficients (value +- 95 % half-width; SI: N/m^k per physical coordinate, per unit "
             "modal coordinate otherwise; an interval wider than the value: not determined by these records): "
             + "; ".join(
                 f"eq {i + 1}: " + (", ".join(f"{t} {c:.4g} +- {h:.2g}" if h is not None else f"{t} {c:.4g}" for t, (c, h) in eq.items()) or "none")
                 for i, eq in enumerate(obj["coupling_coefficients"])),
             f"Model: {obj['model']}"]
    lines.append("Noise floor per channel (nrmse): " + "  ".join(f"{c} {v:.3g}" for c, v in obj["noise_floor"].items()))
    if obj.get("prediction_floor"):  # what every rule judges on (eddi.mdof.predfloor)
        parts = obj.get("floor_parts") or {}
        lines.append("Prediction floor per channel (nrmse, what a model identified from the other captures leaves "
                     "held out by the noise and the blows' impulse errors; the floor every verdict rule judges on): "
                     + "  ".join(f"{c} {v:.3g}" + (f" (noise {parts['noise'][c]:.2g}, blows' impulses {parts['blow'][c]:.2g}, "
                                                   f"the noise's chance {parts.get('chance', {}).get(c, 0.0):.2g}"
                                                   + (f", refit on noisier captures {parts['refit'][c]:.2g}" if 'refit' in parts else "")
                                                   + ";"
                                                   f" the folds' jackknife spread {parts['ident'][c]:.2g}, not counted)"
                                                   if parts else "")
                                 for c, v in obj["prediction_floor"].items()))
    lines += mode_lines(obj)
    lines += [f"Symptom: {s['text']}." for s in obj["symptoms"]]
    lines += [f"Note: {n}." for n in obj["notes"]]
    if "saved_model" in obj:
        lines.append(f"Model written to {obj['saved_model']}")
    lines += [f"WARNING: {w}" for w in obj.get("warnings", [])]
    return "\n".join(lines)
