"""``station identify PATH --mass M``: identify an equation of motion from a measured record.

Reads the record (:func:`station.readers.read_measurement`), conditions it
(:func:`eddi.conditioning.condition`: drift-free integration, impact end, noise floor),
identifies with EDDI, refines when that lowers the validation error, and validates by
simulation: :class:`eddi.fit_record.Pipeline`, the pipeline every command uses.
"""

from __future__ import annotations

import argparse
import math
from typing import TYPE_CHECKING, Any

from eddi.term_defaults import DEFAULT_DAMPING, DEFAULT_STIFFNESS  # numpy-free: --help loads no numpy
from station.argtypes import add_adc_filter_option, add_refine_option, add_sensor_highpass_option, damping_terms, finite_positive, stiffness_terms  # noqa: F401 (re-export)
from station.errors import ConfigError
from station.output import emit

if TYPE_CHECKING:  # the engine is imported when a record is identified, not for --help
    from eddi.fit_record import PipelineResult
    from station.readers import Measurement


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "identify",
        help="identify an equation of motion from a measured impact record (CSV or HDF5 capture)",
        description=(
            "Identify m x'' + sum b_j B_j(x, v) + sum k_n K_n(x) = F(t) from a record of force and "
            "acceleration (or velocity / displacement) with the EDDI method, and validate it by "
            "simulation. PATH is a CSV with a header among t,force,acc,vel,disp (SI units) or "
            "FILE.h5[:CAPTURE]."
        ),
    )
    p.add_argument("path", metavar="PATH", nargs="+",
                   help="CSV file, or HDF5 file with optional :CAPTURE (FILE.h5 alone: every capture); with "
                        "several records the model is identified on the middle force level and validated on "
                        "the others, as station report does")
    p.add_argument("--fit", type=int, default=None, metavar="N",
                   help="with several records: the one to identify on (default: the middle force level)")
    p.add_argument("--mass", type=finite_positive, default=None, metavar="KG",
                   help="mass [kg] (or inertia); required unless the file records it")
    p.add_argument("--damping", type=damping_terms, default=",".join(DEFAULT_DAMPING), metavar="TERMS",
                   help="damping candidates, comma-separated (default: %(default)s)")
    p.add_argument("--stiffness", type=stiffness_terms, default=",".join(DEFAULT_STIFFNESS), metavar="TERMS",
                   help="stiffness candidates, comma-separated (default: %(default)s)")
    p.add_argument("--route", choices=("auto", "potential", "lagrangian"), default="auto",
                   help="phase-two route (default: %(default)s)")
    add_refine_option(p)
    add_adc_filter_option(p)
    add_sensor_highpass_option(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=handler)


def _mass(arg: float | None, meas: Measurement) -> float:
    mass = arg if arg is not None else meas.mass
    if mass is None:
        raise ConfigError(f"--mass is required: {meas.source} does not record the mass")
    if not (math.isfinite(mass) and mass > 0):
        raise ConfigError(f"--mass must be a number > 0 [kg], got {mass:g}")
    return float(mass)


def run_identify(meas: Measurement, mass: float, damping: str, stiffness: str,
                 route: str = "auto", refine: bool = True) -> PipelineResult:
    """Condition, identify and validate one measurement (:class:`eddi.fit_record.Pipeline`)."""
    from eddi.fit_record import Pipeline
    from station.session import condition_measurement

    pipe = Pipeline.create(damping, stiffness, route, refine)
    return pipe.fit(condition_measurement(meas, pipe), mass)


def result_object(meas: Measurement, res: PipelineResult) -> dict[str, Any]:
    """The ``--json`` object."""
    eom = res.model.eom
    cond = res.conditioned
    val = res.validation
    t = cond.t
    obj: dict[str, Any] = {
        "source": meas.source,
        "mass": eom.mass,
        "damping": dict(eom.damping),
        "stiffness": dict(eom.stiffness),
        "units": res.units,
        "ci95": res.ci95,
        "route": res.model.route,
        "route_scores": dict(res.model.route_scores),
        "equation": eom.equation_text(),
        "validation": {
            "nrmse": val.nrmse,
            "nmte": val.nmte,
            "nrmse_force_sensor_only": res.nrmse_force_sensor,
            "driven_by": ("measured impact force from rest (force sensor fused with m*a)"
                          if res.driven_by_force else "measured initial state"),
            "window_s": [float(t[val.window[0]]), float(t[val.window[1] - 1])],
            "diverged": val.diverged or any(h.diverged for h in res.held_out),
            "warnings": list(val.warnings),
            "unstable": res.unstable,
        },
        "conditioning": {
            "method": cond.method,
            "rate_hz": cond.rate_hz,
            "free_window_s": [float(t[cond.free_start]), float(t[cond.free_stop - 1])],
            "free_window_samples": [cond.free_start, cond.free_stop],
            "noise_rms": cond.noise_rms,
            "notes": list(cond.notes),
        },
        "crossings_used": int(res.model.phase_one.gamma.size),
        "pipeline": res.choices.as_dict() if res.choices is not None else None,
        "warnings": list(res.warnings),
        "model": eom.to_dict(),
    }
    ref = res.model.refinement
    if ref is not None and res.model.unrefined is not None:
        obj["refinement"] = {
            "kept": res.choices is None or res.choices.refinement == "kept",
            "fitted_to": ref.channel,
            "nrmse_before": ref.nrmse_before,
            "nrmse_after": ref.nrmse_after,
            "simulations": ref.evaluations,
            "eddi_damping": dict(res.model.unrefined.damping),
            "eddi_stiffness": dict(res.model.unrefined.stiffness),
        }
    return obj


def coupling_check(meas: Measurement, res: PipelineResult, args: argparse.Namespace, obj: dict[str, Any],
                   which: str = "the record") -> None:
    """Check the hammer impulse and look for an undeclared accelerometer AC coupling
    (:func:`station.coupling.add_coupling_check`; no coupling search when one is declared)."""
    from station.coupling import add_coupling_check

    search = not meas.metadata.get("ac_coupling_s") and args.sensor_highpass is None
    add_coupling_check(meas, res, args.damping, args.stiffness, args.route, obj, which, search)


def _text(obj: dict[str, Any]) -> str:
    lines = [f"{obj['source']}: {obj['equation']}", ""]
    lines.append(f"  mass        {obj['mass']:.6g} kg")
    for title, key in (("damping", "damping"), ("stiffness", "stiffness")):
        for term, c in obj[key].items():
            ci = obj.get("ci95", {}).get(key, {}).get(term)
            unit = obj.get("units", {}).get(key, {}).get(term, "")
            lines.append(f"  {title:<11} {term:<10} {c:+.6g}" + (f" ± {ci:.2g}" if ci is not None else "")
                         + f" {unit}")
    p = obj.get("pipeline") or {}
    for term, why in p.get("dropped", {}).items():
        lines.append(f"  dropped     {term:<10} {why}")
    v = obj["validation"]
    c = obj["conditioning"]
    lines += [
        "",
        f"  phase two: {obj['route']} route",
        f"  free response: {c['free_window_s'][0]:.4g} s .. {c['free_window_s'][1]:.4g} s ({c['method']})",
        f"  validation ({v['driven_by']}): nrmse {v['nrmse']:.4g}",
    ]
    if "refinement" in obj:
        r = obj["refinement"]
        how = "refined" if r["kept"] else "refinement tried and rejected"
        lines.append(f"  {how} (output error on {r['fitted_to']}, {r['simulations']} simulations): "
                     f"fit nrmse {r['nrmse_before']:.4g} -> {r['nrmse_after']:.4g}; EDDI estimate:")
        for title, key in (("damping", "eddi_damping"), ("stiffness", "eddi_stiffness")):
            for term, c in r[key].items():
                lines.append(f"  {title:<11} {term:<10} {c:+.6g}")
    p = obj.get("pipeline")
    if p:
        lines.append(f"  pipeline: {p['route']} route; refinement {p['refinement']}: {p['refinement_reason']}")
    for w in obj.get("warnings", []):
        lines.append(f"  WARNING: {w}")
    return "\n".join(lines)


def handler(args: argparse.Namespace) -> int:
    from station.readers import read_measurement, require_one_coordinate
    from station.session import expand_specs, read_all, run_session, with_adc_filter, with_sensor_highpass

    specs = expand_specs(list(args.path))
    if len(specs) == 1:
        meas = with_sensor_highpass(with_adc_filter(read_measurement(specs[0]), args.adc_filter), args.sensor_highpass)
        require_one_coordinate(meas, "identify")
        mass = _mass(args.mass, meas)
        res = run_identify(meas, mass, args.damping, args.stiffness, args.route, args.refine)
        obj = result_object(meas, res)
        coupling_check(meas, res, args, obj)
        obj["unstable"] = res.unstable
        emit(args.json, _text(obj), obj)
        return _exit_code(res.unstable)
    recs = [with_sensor_highpass(with_adc_filter(m, args.adc_filter), args.sensor_highpass) for m in read_all(specs)]
    session = run_session(recs, args.mass, damping=args.damping, stiffness=args.stiffness, route=args.route,
                          fit_index=args.fit, refine=args.refine)
    meas = session.measurements[session.fit_index]
    obj = result_object(meas, session.fit)
    obj["held_out"] = {"nrmse": session.mean_nrmse, "nmte": session.mean_nmte,
                       "records": [c.as_dict() for c in session.held_out]}
    text = _text(obj) + "".join(f"\n  held out {c['source']}: nrmse {c['nrmse']:.4g}" for c in obj["held_out"]["records"])
    if session.mean_nrmse is not None:
        text += f"\n  mean nrmse on the records not used for the fit: {session.mean_nrmse:.4g}"
    # one check, on the record the model was fitted to (no corner search with a declared coupling)
    from station.coupling import session_coupling_check

    before = len(obj["warnings"])
    session_coupling_check(session, args.damping, args.stiffness, args.route, obj,
                           search=args.sensor_highpass is None)
    text += "".join(f"\n  WARNING: {w}" for w in obj["warnings"][before:])
    obj["unstable"] = bool(session.fit.unstable or any(c.diverged for c in session.held_out))
    emit(args.json, text, obj)
    return _exit_code(obj["unstable"])


def _exit_code(unstable: bool) -> int:
    """0, or :data:`station.cli.EXIT_FLAGGED` with one line when the model is not trustworthy."""
    if not unstable:
        return 0
    from station.cli import flagged

    return flagged("identify", "the identified model is unstable or its simulation diverges")
