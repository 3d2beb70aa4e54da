"""``station report FILE... --out DIR [--json]``: HTML report with the paper's figure set.

    station report session.h5 --out report      # identify on the middle impact, validate on the others

Identifies on one record (default: the middle force level; ``--fit N`` to choose) and
validates on every other one (:func:`station.session.run_session`), then writes
``DIR/index.html`` with PNG figures (:func:`station.report.write_report`): force;
displacement with its CWT and Fourier spectrum; kinetic energy with T at the zero crossings;
measured versus modelled dissipated energy; mechanical energy; restoring force (or
potential); validation overlays on the records not used for the fit; the coefficient table.
``FILE.h5`` without ``:CAPTURE`` means every capture in it. See docs/report.md.

Captures with several response sensors take the multi-DOF path (:mod:`station.mdof_report`):
the coupled model identified on every capture but the last (no mass), one panel per channel
per capture, measured beside simulated, and the per-channel nrmse table.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from station.argtypes import damping_terms, finite_positive, nonnegative_int, stiffness_terms
from station.output import emit


def register(subparsers: Any) -> None:
    from station.argtypes import add_refine_option

    """Add the ``report`` sub-command."""
    p = subparsers.add_parser("report", help="HTML report with the paper's figures (identify + validate)",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("records", metavar="FILE", nargs="+", help="FILE.h5 (all captures), FILE.h5:N or FILE.csv")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created)")
    p.add_argument("--mass", type=finite_positive, default=None, metavar="KG", help="mass [kg] (default: the one the records store)")
    p.add_argument("--damping", type=damping_terms, default=None, metavar="TERMS", help="damping candidates, comma-separated")
    p.add_argument("--stiffness", type=stiffness_terms, default=None, metavar="TERMS", help="stiffness candidates, comma-separated")
    p.add_argument("--route", choices=("auto", "potential", "lagrangian"), default="auto",
                   help="phase-two route (default: %(default)s)")
    p.add_argument("--fit", type=nonnegative_int, default=None, metavar="N",
                   help="record to identify on, 0-based among the records given (default: the middle force level)")
    add_refine_option(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=handle)


def handle(args: argparse.Namespace) -> int:
    """Run ``station report``; return the exit code."""
    import time

    from eddi.terms import DEFAULT_DAMPING, DEFAULT_STIFFNESS
    from station.commands.replay import session_object, session_text, terms_or_default
    from station.demo import rig_truth
    from station.output_safety import check_output
    from station.report import write_report
    from station.session import read_all, run_session

    check_output(args.out, "dir", args.records, option="--out")
    t0 = time.perf_counter()
    from station.mdof_data import is_multichannel
    from station.readers import read_measurement
    from station.session import expand_specs

    specs = expand_specs(list(args.records))
    first = read_measurement(specs[0])
    if is_multichannel(first):  # several sensors: the coupled model, one panel per channel
        return _mdof_report(args, [first] + [read_measurement(s) for s in specs[1:]], t0)
    recs = read_all(args.records, command="report")
    terms = (terms_or_default(args.damping, DEFAULT_DAMPING), terms_or_default(args.stiffness, DEFAULT_STIFFNESS),
             args.route)
    session = run_session(recs, args.mass, damping=terms[0], stiffness=terms[1], route=terms[2],
                          fit_index=args.fit, refine=args.refine)
    fit = session.measurements[session.fit_index]
    truth = None
    if "capture" in fit.metadata and "file" in fit.metadata:
        truth = rig_truth(fit.metadata["file"], int(fit.metadata["capture"]))
    obj = session_object(session, terms)
    t1 = time.perf_counter()
    rep = write_report(session, args.out, truth=truth, warnings=obj["identified"]["warnings"])
    t2 = time.perf_counter()
    obj["report"] = str(rep.index)
    obj["figures"] = [str(p) for p in rep.figures]
    obj["elapsed_s"] = {"identify_validate": t1 - t0, "report": t2 - t1}
    text = session_text(obj) + f"\nreport: {rep.index} ({len(rep.figures)} figures, {t2 - t1:.1f} s)"
    emit(args.json, text, obj)
    return 0


def _mdof_report(args: argparse.Namespace, measurements: list, t0: float) -> int:
    """``station report`` on multi-channel captures (:mod:`station.mdof_report`)."""
    import time

    from station.mdof_replay import replay_mdof_object, replay_mdof_text
    from station.mdof_report import write_mdof_report

    obj = replay_mdof_object(measurements)
    t1 = time.perf_counter()
    figures = write_mdof_report(obj, args.out)
    obj.pop("_validations")
    obj["report"] = str(Path(args.out) / "index.html")
    obj["figures"] = [str(p) for p in figures]
    obj["elapsed_s"] = {"identify_validate": t1 - t0, "report": time.perf_counter() - t1}
    emit(args.json, replay_mdof_text(obj) + f"\nreport: {obj['report']} ({len(figures)} figures)", obj)
    if obj["unstable"]:
        from station.cli import flagged

        return flagged("report", "the identified model is unstable or its simulation diverges")
    return 0
