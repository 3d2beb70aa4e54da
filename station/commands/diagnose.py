"""``station diagnose``: what the model gets wrong, why, the extended model and the gain.

    station diagnose CAPTURE... --mass M [--damping TERMS] [--stiffness TERMS]
                     [--model BASE.json] [--fit {eddi,equation-error}] [--margin F]
                     [--save-model OUT.json] [--report DIR] [--json]

Each capture (CSV or HDF5, with or without a force channel) is read, conditioned (drift-free
integration of the acceleration) and handed to :func:`eddi.diagnose.diagnose`. With several
captures each one is held out in turn; with one, its ring-down is split into amplitude bands.
The baseline is ``--model`` or EDDI's term libraries fitted to the data (by EDDI over the
training captures, unless ``--fit equation-error``); every mechanism of
the catalogue (``docs/effects.md``) is added, refitted on the training captures and judged on
the held-out ones. See ``docs/diagnosis.md``.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from eddi.errors import ModelError
from eddi.terms import DEFAULT_DAMPING, DEFAULT_STIFFNESS
from station.argtypes import damping_terms, finite_positive, fraction, stiffness_terms
from station.errors import InputFileError, StationError
from station.output import emit
from station.output_safety import write_text_atomic

if TYPE_CHECKING:  # the engine is imported when captures are diagnosed, not for --help
    from eddi.diagnosis import Diagnosis, PipelineBaseline, Record

#: ``eddi.diagnosis.FITS``, ``DEFAULT_MARGIN`` and ``ALL_NAMES``, written out so that ``--help``
#: does not import the engine (scipy, numba, pydantic: ~1 s); tests/station/test_cli_startup.py
#: checks that they equal the engine's.
FITS = ("eddi", "equation-error")
DEFAULT_MARGIN = 0.5
ALL_NAMES = ("coulomb_friction", "quadratic_damping", "cubic_damping", "clearance", "smooth_stiffening",
             "asymmetric_stiffness", "second_mode", "hysteresis", "amplitude_damping", "sensor_highpass")


def register(subparsers: Any) -> None:
    """Add the ``diagnose`` sub-command."""
    p = subparsers.add_parser(
        "diagnose", help="find what a model gets wrong, name the mechanism, extend it, measure the gain",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("captures", nargs="+", metavar="CAPTURE",
                   help="capture files (CSV or HDF5; FILE.h5:N picks capture N of a session)")
    p.add_argument("--mass", type=finite_positive, metavar="KG",
                   help="oscillating mass [kg] (default: the model's, or the capture's metadata)")
    p.add_argument("--damping", type=damping_terms, default=",".join(DEFAULT_DAMPING), metavar="TERMS",
                   help="baseline damping terms (default: %(default)s)")
    p.add_argument("--stiffness", type=stiffness_terms, default=",".join(DEFAULT_STIFFNESS), metavar="TERMS",
                   help="baseline stiffness terms (default: %(default)s)")
    p.add_argument("--model", metavar="BASE.json", help="baseline equation of motion (JSON); its "
                   "coefficients are kept and only the mechanisms are fitted")
    p.add_argument("--mechanisms", metavar="NAMES", help="comma-separated subset of: "
                   + ", ".join(ALL_NAMES))
    p.add_argument("--margin", type=fraction, default=DEFAULT_MARGIN, metavar="FRACTION",
                   help="relative cut of the held-out error the winner must exceed (default: %(default)s)")
    p.add_argument("--method", dest="fit", default="eddi", choices=FITS,
                   help="how the baseline and the extensions are fitted: EDDI over the training "
                        "captures, or least squares on the equation of motion (default: %(default)s)")
    p.add_argument("--save-model", metavar="OUT.json",
                   help="write the extended model (an equation of motion, or a modal-sum model when "
                        "the cause is a second mode seen in the measured signal; both load with "
                        "eddi.multimode.load_any_model)")
    p.add_argument("--report", metavar="DIR", help="write an HTML page (index.html) and its figures "
                   "(PNG, units on every axis) into DIR")
    from station.argtypes import add_refine_option, add_sensor_highpass_option

    add_refine_option(p)
    add_sensor_highpass_option(p)
    from eddi.chain_tolerance import CLOCK_PPM, GAIN_TOLERANCE  # no engine import for --help
    from station.argtypes import percent_tolerance, ppm_tolerance

    p.add_argument("--gain-tolerance", type=percent_tolerance, default=100 * GAIN_TOLERANCE, metavar="PCT",
                   help="how far the accelerometer's sensitivity may differ between captures [%%] "
                        "(remounted or recalibrated between sessions; ISO 16063-21 back-to-back "
                        "calibration: about 1 %%); the noise floor includes what that does to the "
                        "held-out predictions. With a force channel the captures' impulse/momentum "
                        "ratios measure it and the smaller is used (default: %(default)g)")
    p.add_argument("--gain-as-stated", action="store_true",
                   help="use --gain-tolerance as given, not lowered by the impulse/momentum ratios "
                        "(e.g. when the hammer was recalibrated together with the accelerometer)")
    p.add_argument("--clock-ppm", type=ppm_tolerance, default=CLOCK_PPM, metavar="PPM",
                   help="how far the DAQ's sample clock may differ between captures [ppm] (a DAQ "
                        "timebase: +-50 ppm; two DAQs: give 100) (default: %(default)g)")
    p.add_argument("--driving-point", metavar="CHANNEL",
                   help="multi-channel captures: the response channel at the hammer (default: the first)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=handle)


def _multichannel(specs: list[str]) -> bool:
    """True when the first capture has more than one response channel (acc1, acc2 ...)."""
    # station.readers' test itself (station.mdof_data.is_multichannel is this, but importing
    # it imports eddi.mdof and scipy.signal with it: ~0.45 s of CPU for one-mode captures)
    from station.readers import is_multichannel_record, read_measurement
    from station.session import expand_specs

    return is_multichannel_record(read_measurement(expand_specs(specs)[0]))


def load_records(specs: list[str]) -> tuple[list[Record], float | None]:
    """Read and condition every capture; returns the records and the mass found in metadata."""
    records, mass, _, _, _ = load_measurements(specs)
    return records, mass


def load_measurements(specs: list[str], sensor_highpass: float | None = None
                      ) -> tuple[list[Record], float | None, list[Any], str | None, list[Any]]:
    """Read and condition (:class:`eddi.fit_record.Pipeline`) every capture (``sensor_highpass``:
    ``--sensor-highpass``, :func:`station.session.with_sensor_highpass`).

    Returns
    -------
    records : list of Record
    mass : float or None
        Found in the metadata.
    measurements : list of station.readers.Measurement
    resampled : str or None
        What was resampled onto one grid (clocks differing by up to 200 ppm), None if nothing.
    conditioned : list of eddi.conditioning.ConditionedSignal
        The measurements conditioned (without the resampling note), for
        :func:`pipeline_baseline` (not conditioned twice).
    """
    from station.readers import read_measurement
    from station.session import expand_specs, with_sensor_highpass

    return condition_all([with_sensor_highpass(read_measurement(spec), sensor_highpass)
                          for spec in expand_specs(specs)])


def condition_all(read: list[Any], mapper: Any = None
                  ) -> tuple[list[Record], float | None, list[Any], str | None, list[Any]]:
    """:func:`load_measurements` on measurements already read (``station campaign --task
    diagnose`` reads its capture on the worker): the same checks, grid and conditioning.
    ``mapper`` (``mapper(fn, items)``, :class:`station.forkmap.ForkMap`): how the records'
    conditionings (independent) run; default here, in turn."""
    from eddi.diagnosis import Record
    from station.session import condition_measurement, on_one_grid

    for m in read:
        ch = m.channels
        if not any(k in ch for k in ("acc", "vel", "disp")):
            raise InputFileError(f"{m.source}: no response channel (expected acc, vel or disp; got "
                                 f"{', '.join(ch) or 'none'})")
    meas, note = on_one_grid(read)  # clocks differing by up to 200 ppm: one grid (said below)
    records: list[Record] = []
    conditioned = []
    mass: float | None = None
    # the first here (what conditioning imports when it needs it, scipy.signal, is then imported
    # once, before any fork), the others through ``mapper``
    got = [condition_measurement(m) for m in meas[:1]] + (mapper or _in_turn)(condition_measurement, meas[1:])
    for m, c in zip(meas, got):
        conditioned.append(c)
        if note:
            c = replace(c, notes=c.notes + (note,))
        records.append(Record.from_conditioned(c, label=Path(m.source).name,
                                               pretrigger_samples=getattr(m, "pretrigger_samples", None)))
        if mass is None and getattr(m, "mass", None):
            mass = float(m.mass)
    return records, mass, meas, note, conditioned


def _in_turn(fn: Any, items: list[Any]) -> list[Any]:
    return [fn(x) for x in items]


def pipeline_baseline(measurements: list[Any], mass: float, damping: str, stiffness: str,
                      refine: bool, conditioned: list[Any] | None = None, mapper: Any = None
                      ) -> tuple[dict[str, Any], PipelineBaseline, Any]:
    """The baseline every other command gives (:func:`station.session.run_session`).

    The same model and held-out error as ``station identify`` / ``report`` / ``replay`` on
    these records: identified on the middle force level, validated on the others. Returns
    the JSON object (as ``replay``), the :class:`~eddi.diagnosis.PipelineBaseline` the
    diagnosis takes as its baseline and the :class:`station.session.SessionResult`.
    ``conditioned``: the measurements already conditioned
    (:func:`load_measurements`), not conditioned again. ``mapper``: how the refinement's
    independent trials run (default: a :class:`station.forkmap.ForkMap` of
    :func:`~station.forkmap.jobs_wanted` processes).
    """
    from eddi.diagnosis import PipelineBaseline
    from eddi.fit_record import Pipeline
    from station.commands.replay import session_object
    from station.forkmap import ForkMap, jobs_wanted
    from station.session import run_session

    # the refinement's forward term selection tries independent terms: in forked workers when
    # cores are free (the same result)
    pipe = replace(Pipeline.create(damping, stiffness, refine=refine),
                   mapper=mapper if mapper is not None else ForkMap(jobs_wanted()))
    session = run_session(measurements, mass, pipeline=pipe, conditioned=conditioned)
    obj = session_object(session)
    obj["model"] = session.fit.model.eom.to_dict()
    k = session.fit_index
    others = [i for i in range(len(measurements)) if i != k]
    held = {i: float(c.nrmse) for i, c in zip(others, session.held_out)}
    nrmse = session.mean_nrmse if session.mean_nrmse is not None else session.fit.validation.nrmse
    choices = session.fit.choices.as_dict() if session.fit.choices is not None else {}
    return obj, PipelineBaseline(model=session.fit.model.eom, nrmse=float(nrmse), fit_record=k,
                                 held_out=held, choices=choices), session


def _coupling(session: Any, args: argparse.Namespace, obj: dict[str, Any]) -> None:
    """The undeclared-IEPE-coupling check of ``station identify`` (:mod:`station.coupling`), once,
    on the record the pipeline's model was fitted to: ``sensor_highpass_check`` in the JSON and
    one warning when the coupling is evident."""
    from station.coupling import check_coupling, coupling_warning

    meas = session.measurements[session.fit_index]
    chk = check_coupling(meas, session.fit, args.damping, args.stiffness, "auto")
    if chk is None:
        return
    obj["sensor_highpass_check"] = chk.as_dict()
    if chk.evident and chk.corner_hz is not None:
        obj["warnings"].append(coupling_warning(chk, f"the fit record ({meas.source})"))


def handle(args: argparse.Namespace) -> int:
    from station.output_safety import check_output

    inputs = [*args.captures, *([args.model] if args.model else [])]
    if args.save_model:
        check_output(args.save_model, "model", inputs, option="--save-model")
    if args.report:
        check_output(args.report, "dir", inputs, option="--report")
    if _multichannel(list(args.captures)):
        from station.mdof_commands import diagnose_mdof_object, diagnose_mdof_text

        obj = diagnose_mdof_object(list(args.captures), driving_point=args.driving_point, margin=args.margin,
                                   save_model=args.save_model, refine=args.refine)
        emit(args.json, diagnose_mdof_text(obj), obj)
        if obj.get("unstable"):
            from station.cli import flagged

            return flagged("diagnose", "the diagnosed model is unstable or its simulation diverges")
        return 0
    from station.readers import read_measurement
    from station.session import expand_specs, with_sensor_highpass

    read = [with_sensor_highpass(read_measurement(spec), args.sensor_highpass)
            for spec in expand_specs(list(args.captures))]
    diag, obj, records = diagnosis_object(read, args)
    if args.save_model:
        write_text_atomic(args.save_model, diag.extended.model.to_json() + "\n")
        obj["saved_model"] = args.save_model
    if args.report:
        from station.diagnosis_report import write_report

        try:
            files = write_report(diag, records, args.report)
        except StationError as exc:  # say what was saved before
            kept = f"; the extended model was written to {args.save_model}" if args.save_model else ""
            raise type(exc)(f"{exc}{kept}") from None
        obj["report"] = [str(f) for f in files]
    emit(args.json, render_text(diag, obj), obj)
    if obj["unstable"]:
        from station.cli import flagged

        return flagged("diagnose", "the diagnosed model is unstable or its simulation diverges")
    return 0


def default_args(**given: Any) -> argparse.Namespace:
    """``station diagnose``'s options as its parser sets them, with ``given`` ones replaced:
    ``station campaign --task diagnose`` diagnoses every capture as the command would."""
    root = argparse.ArgumentParser()
    register(root.add_subparsers())
    args = root.parse_args(["diagnose", "-"])
    unknown = sorted(set(given) - set(vars(args)))
    if unknown:
        raise TypeError(f"not options of station diagnose: {', '.join(unknown)}")
    for key, value in given.items():
        setattr(args, key, value)
    return args


def diagnosis_object(read: list[Any], args: argparse.Namespace) -> tuple[Diagnosis, dict[str, Any], list[Record]]:
    """Diagnose one-coordinate measurements (read, ``--sensor-highpass`` applied) with the
    options of ``args`` (:func:`default_args`); returns the diagnosis, the ``--json`` object
    (without the saved model and report) and the conditioned records.

    ``obj["unstable"]`` and ``obj["warnings"]``: the model the diagnosis stands behind is
    flagged (:func:`model_flags`), then the undeclared AC-coupling warning of ``station identify``.
    """
    from eddi.diagnosis import diagnose
    from eddi.fit_record import TOO_SHORT_TO_REFINE
    from eddi.model import EquationOfMotion

    base = None
    if args.model:
        from station.session import load_model_file

        loaded = load_model_file(args.model)
        if not isinstance(loaded, EquationOfMotion):
            raise InputFileError(f"{args.model}: --model takes a single-coordinate equation of motion, "
                                 f"got a modal-sum model")
        base = loaded
    if args.mass is not None and not (math.isfinite(args.mass) and args.mass > 0):
        raise ModelError(f"--mass must be > 0, got {args.mass}")
    mechanisms = None
    if args.mechanisms:
        mechanisms = [s.strip() for s in args.mechanisms.split(",") if s.strip()]
    from station.forkmap import ForkMap, jobs_wanted

    # the records' conditionings, the pipeline's independent refits and the folds' fits: in
    # forked workers when cores are free (the same result)
    mapper = ForkMap(jobs_wanted())
    records, meta_mass, measurements, resampled, conditioned = condition_all(read, mapper)
    mass = args.mass if args.mass is not None else (base.mass if base is not None else meta_mass)
    if mass is None:
        raise InputFileError("no mass: give --mass KG (or --model, or captures with a mass in their metadata)")
    if base is not None and args.mass is not None and abs(args.mass - base.mass) > 1e-9 * base.mass:
        raise ModelError(f"--mass {args.mass} differs from the model's mass {base.mass}")
    from eddi.diagnosis.measure import draw_jobs

    # the noise floor's perturbed records depend on the records alone: queued to run where a
    # map of the pipeline's refinement or of the folds leaves a core idle (ForkMap.beside)
    if mapper.jobs > 1:
        mapper.beside(draw_jobs(records))
    pipe_obj, baseline, session = None, None, None
    if base is None:  # the baseline is the pipeline's (the same model and error as identify); the
        # diagnosis judges its folds with the pipeline's choices, so it comes first
        pipe_obj, baseline, session = pipeline_baseline(measurements, float(mass), args.damping, args.stiffness,
                                                        args.refine, conditioned, mapper)
    diag = diagnose(records, mass, damping=args.damping, stiffness=args.stiffness, base=base,
                    mechanisms=mechanisms, margin=args.margin, fit=args.fit, pipeline=baseline,
                    mapper=mapper, chain=_tolerance(args))
    obj = diag.to_dict()
    obj["captures"] = [r.label for r in records]
    obj["resampled"] = resampled
    if pipe_obj is not None:
        obj["pipeline_baseline"] = pipe_obj
    span = capture_span(records, diag.scheme)
    if span is not None:
        obj["amplitude"] = {"span": span.as_dict()}
        if not span.tested:
            obj["notes"] = [*obj.get("notes", []), span.text()]
    warnings = model_flags(diag, pipe_obj)
    obj["unstable"] = bool(warnings)
    obj["warnings"] = list(warnings)
    reason = str(baseline.choices.get("refinement_reason", "")) if baseline is not None else ""
    if reason.startswith(TOO_SHORT_TO_REFINE):  # a warning, not a flag: EDDI's estimate stands
        obj["warnings"].append(f"the pipeline's model: {reason}")
    from eddi.diagnosis.pipeline_base import first_sample_warning

    if first_sample_warning(diag.pipeline):  # identify's held-out figure is its start state's (session 20)
        obj["warnings"].append(f"the pipeline's model: {first_sample_warning(diag.pipeline)}")
    if (session is not None and args.sensor_highpass is None and diag.cause in ("none", "unexplained", "sensor_highpass")
            and not any(m.metadata.get("ac_coupling_s") for m in measurements)):
        # after `unstable`: a warning, not a flag. Not when the held-out judgement named another
        # mechanism (sensor_highpass is a candidate there and lost): hidden friction's drive misfit
        # was also "explained" by a 2.5 Hz coupling on the fit record (tests/station/test_cli_diagnose.py)
        _coupling(session, args, obj)
    return diag, obj, records


def _tolerance(args: argparse.Namespace) -> Any:
    """The measurement chain's tolerances of ``--gain-tolerance``, ``--gain-as-stated``, ``--clock-ppm``."""
    from eddi.diagnosis.tolerance import ChainTolerance

    return ChainTolerance(gain=args.gain_tolerance / 100.0, clock_ppm=args.clock_ppm,
                          from_data=not args.gain_as_stated)


def capture_span(records: list[Record], scheme: str) -> Any:
    """How far the leave-one-record-out folds extrapolate in amplitude (peak acceleration of
    each record's free response; :class:`eddi.mdof.amplitude.CaptureSpan`), or None for the
    amplitude-band scheme (its bands are held out by amplitude, so it tests extrapolation)."""
    import numpy as np

    from eddi.mdof.amplitude import span_of

    if scheme != "leave-one-record-out" or len(records) < 2:
        return None
    return span_of([float(np.max(np.abs(r.a[r.free_start:r.free_stop]))) for r in records],
                   "the response (free part)")


def model_flags(diag: Diagnosis, pipe_obj: dict[str, Any] | None) -> tuple[str, ...]:
    """Why the model this diagnosis stands behind cannot be trusted as a simulation
    (:func:`eddi.diagnosis.soundness.model_flags`), plus a pipeline baseline flagged as
    ``station identify`` flags it when no mechanism is named. Empty when the model is sound."""
    from eddi.diagnosis.soundness import model_flags as engine_flags

    out = list(engine_flags(diag))
    if diag.cause in ("none", "unexplained") and pipe_obj is not None and pipe_obj.get("unstable"):
        out.append("the pipeline baseline (as station identify) is flagged unstable: "
                   + "; ".join(pipe_obj.get("identified", {}).get("warnings", []) or ["see its warnings"]))
    return tuple(out)


def render_text(diag: Diagnosis, obj: dict[str, Any]) -> str:
    """People-friendly summary: ranked table, verdict, what the baseline got wrong."""
    lines = [f"Held-out judging: {diag.scheme} ({len(diag.parts)} parts: "
             + ", ".join(p.label for p in diag.parts) + ")",
             "",
             f"{'rank':>4}  {'mechanism':<22} {'held-out nrmse':>14} {'gain':>7}  {'every part':<10} "
             f"{'consistent':<10} parameters (± spread over folds)",
             f"{'':>4}  {'(baseline per fold)' if diag.judged is not None else '(baseline)':<22} "
             f"{diag.judging.nrmse:>14.4g}"]
    rank = 0
    for c in diag.candidates:
        if c.skipped:
            lines.append(f"{'-':>4}  {c.name:<22} {'skipped':>14} {'':>7}  {'':<10} {'':<10} {c.skipped}")
            continue
        rank += 1
        params = ", ".join(f"{k}={v:.4g}" + (f"±{c.spread[k]:.2g}" if math.isfinite(c.spread.get(k, math.nan)) else "")
                           for k, v in c.params.items())
        lines.append(f"{rank:>4}  {c.name:<22} {c.nrmse:>14.4g} {100 * c.gain:>6.0f}%  "
                     f"{'yes' if c.wins_every_part else 'no':<10} {'yes' if c.consistent else 'no':<10} "
                     f"{params or '(no physical fit)'}"
                     + (f" [gain vs the {c.reference}, nrmse {c.reference_nrmse:.4g}]"
                        if c.reference != "baseline" else ""))
    fl = diag.noise_floor
    if fl is not None:
        from eddi.diagnosis.settings import PRED_CAP
        from eddi.diagnosis.tolerance import chain_text

        lines.insert(1, f"Noise floor of the held-out nrmse (from the records' noise and conditioning"
                        + (" and the chain's tolerance" if fl.chain_nrmse else "") + f"): "
                        f"{fl.nrmse:.3g} (per part " + ", ".join(f"{f:.3g}" for f in fl.fold_nrmse) + ")"
                        + (f"; {chain_text(fl)}" if fl.chain_nrmse else "")
                        + (f"; the floor of the data, which `none` is judged against (the baseline's own refit "
                           f"spread counted at most {PRED_CAP:g}x the records' share): {fl.data_nrmse:.3g} (per part "
                           + ", ".join(f"{f:.3g}" for f in fl.data_fold_nrmse) + ")"
                           if fl.data_fold_nrmse and fl.data_nrmse < 0.999 * fl.nrmse else ""))
    lines += ["", diag.verdict, f"What the baseline got wrong: {diag.symptom}."]
    if diag.symptoms:
        lines.append("Symptoms (held-out parts, median; measurement chain):")
        lines += [f"  - {s.kind}: {s.text}" for s in diag.symptoms]
    lines += [f"Note: {n}." for n in obj.get("notes", diag.notes)]
    lines += [f"WARNING: {w}" for w in obj.get("warnings", [])]
    if obj.get("resampled"):
        lines.append(f"Note: {obj['resampled']}.")
    lines += ["", f"Baseline: {diag.baseline.model.equation_text()}"]
    if diag.judged is not None:
        lines.append(f"Judged against (the same terms fitted on all the records, as in every fold): "
                     f"{diag.judged.model.equation_text()}")
    pb = obj.get("pipeline_baseline")
    if pb is not None:
        v = pb["validation"]["nrmse"]
        lines.append(f"Pipeline baseline (as station identify/report, on {pb['fit_record']}): "
                     f"{pb['identified']['equation']}"
                     + (f"; held-out nrmse {v:.4g}" if v is not None else
                        f"; nrmse on itself {pb['identified']['validation']['nrmse']:.4g}"))
    if diag.cause not in ("none", "unexplained"):
        lines.append(f"Extended: {diag.extended.model.equation_text()}")
    if "saved_model" in obj:
        lines.append(f"Extended model written to {obj['saved_model']}")
    if "report" in obj:
        pngs = [f for f in obj["report"] if f.endswith(".png")]
        lines.append(f"Report: {Path(obj['report'][-1])} and {len(pngs)} figures beside it")
    return "\n".join(lines)
