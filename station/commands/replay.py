"""``station replay FILE [--through-device] [--json]``: rerun the pipeline on saved captures.

    station replay session.h5                   # identify on the middle impact, validate on the others
    station replay session.h5 --through-device  # first stream every capture through the emulated DAQ

The pipeline is :func:`station.session.run_session` (as ``station report``, without the
figures). With ``--through-device`` each stored capture's raw counts are served by a
:class:`simulated_rig.replay.ReplaySource` inside the emulated DAQ firmware, on a pseudo-terminal, read back with the
serial driver, and compared with the file: they must arrive bit-exact.

Captures with several response sensors (``acc1, acc2, ...``) take the multi-DOF path
(:mod:`station.mdof_replay`): the coupled model is identified on every capture but the last
(no mass needed; ``--mass``, ``--damping``, ``--stiffness``, ``--fit`` do not apply) and every
channel of every capture is predicted, per-channel nrmse, the last one held out.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from typing import Any

import numpy as np

from station.argtypes import damping_terms, finite_positive, nonnegative_int, stiffness_terms
from station.errors import InputFileError
from station.output import emit


@dataclass(frozen=True)
class StreamCheck:
    """One capture streamed through the emulated device and the driver.

    Attributes
    ----------
    capture : int
    samples : int
        Samples compared (the whole capture).
    bit_exact : bool
        Every count arrived unchanged, in order.
    mismatched_samples : int
        Rows with any differing count.
    dropped_samples, crc_errors : int
        Link statistics of the driver.
    transport_url : str
        The pty the driver opened.
    """

    capture: int
    samples: int
    bit_exact: bool
    mismatched_samples: int
    dropped_samples: int
    crc_errors: int
    transport_url: str


def stream_through_device(path: str, capture: int, *, timeout_s: float = 5.0) -> StreamCheck:
    """Serve a stored capture's counts through the emulated DAQ on a pty and the serial driver.

    Raises
    ------
    InputFileError
        The capture holds imported SI values (no raw counts) or missing samples.
    DriverError
        The link failed (one line).
    """
    from drivers import open_device
    from simulated_rig.device import EmulatedDaq
    from simulated_rig.replay import ReplaySource
    from simulated_rig.serve import PtyServer
    from station.storage import read_capture

    cap = read_capture(path, capture)
    if any(ch.counts is None for ch in cap.channels.values()):
        raise InputFileError(f"capture {cap.index} of {path}: holds SI values (imported), not raw counts; "
                             f"expected a capture recorded by a DAQ")
    if cap.dropped_samples:
        raise InputFileError(f"capture {cap.index} of {path}: {cap.dropped_samples} samples are missing; "
                             f"expected a complete record to replay")
    counts = np.column_stack([ch.counts for ch in cap.channels.values()])
    infos = tuple(ch.info for ch in cap.channels.values())
    scenario = json.dumps(cap.rig) if cap.rig else ""
    source = ReplaySource(counts, infos, cap.rate_hz, scenario_json=scenario)
    server = PtyServer(EmulatedDaq(source, model="EDDI-REPLAY", serial=f"REPLAY-{cap.index}"), paced=False).start()
    try:
        with open_device("serial://" + server.port, timeout_s=timeout_s) as daq:
            daq.start()
            first, got, _si, _dropped = daq.read_samples(counts.shape[0], timeout_s=timeout_s)
            daq.stop()
            stats = daq.stats
            url = daq.url
    finally:
        server.close()
    got = got[: counts.shape[0]]
    bad = int(np.count_nonzero(np.any(got != counts, axis=1))) if got.shape == counts.shape else counts.shape[0]
    return StreamCheck(cap.index, int(counts.shape[0]), bad == 0 and first == 0, bad,
                       int(getattr(stats, "dropped_samples", 0)), int(getattr(stats, "crc_errors", 0)), str(url))


def register(subparsers: Any) -> None:
    from station.argtypes import add_refine_option

    """Add the ``replay`` sub-command."""
    p = subparsers.add_parser("replay", help="rerun the pipeline on saved captures (optionally through the device)",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", metavar="FILE", help="HDF5 session file (all captures) or FILE.h5:N, or a CSV")
    p.add_argument("--through-device", action="store_true",
                   help="stream every capture through the emulated DAQ and the serial driver, check it bit-exact")
    p.add_argument("--mass", type=finite_positive, default=None, metavar="KG", help="mass [kg] (default: the one the captures record)")
    p.add_argument("--damping", type=damping_terms, default=None, metavar="TERMS", help="damping candidates, comma-separated")
    p.add_argument("--stiffness", type=stiffness_terms, default=None, metavar="TERMS", help="stiffness candidates, comma-separated")
    p.add_argument("--fit", type=nonnegative_int, default=None, metavar="N",
                   help="record to identify on (default: the middle force level)")
    add_refine_option(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=handle)


def session_object(session: Any, terms: tuple[Any, Any, str] | None = None) -> dict[str, Any]:
    """``identified`` (as ``station identify --json``) and ``validation`` of a session.

    ``terms``: the ``(damping, stiffness, route)`` identified with; given, the fit record is
    checked for an undeclared AC coupling as ``station identify`` checks it (the same warning).
    """
    from station.commands.identify import result_object

    meas = session.measurements[session.fit_index]
    identified = result_object(meas, session.fit)
    if terms is not None:
        from station.coupling import session_coupling_check

        session_coupling_check(session, *terms, identified)
    return {
        "records": [m.source for m in session.measurements],
        "fit_record": meas.source,
        "identified": identified,
        "validation": {"nrmse": session.mean_nrmse, "nmte": session.mean_nmte,
                       "held_out": [c.as_dict() for c in session.held_out]},
        "unstable": bool(session.fit.unstable or any(c.diverged for c in session.held_out)),
    }


def session_text(obj: dict[str, Any]) -> str:
    """People-friendly lines of :func:`session_object`."""
    ident = obj["identified"]
    lines = [f"identified on {obj['fit_record']}: {ident['equation']}"]
    p = ident.get("pipeline")
    if p:
        lines.append(f"  pipeline: {p['route']} route; refinement {p['refinement']}: {p['refinement_reason']}")
    lines += [f"  WARNING: {w}" for w in ident.get("warnings", [])]
    for c in obj["validation"]["held_out"]:
        how = "from rest, measured force" if c["driven_by"] == "force" else "from the measured state"
        lines.append(f"  validated on {c['source']}: nrmse {c['nrmse']:.4g} ({how})")
    if obj["validation"]["nrmse"] is not None:
        lines.append(f"  mean nrmse on the records not used for the fit: {obj['validation']['nrmse']:.4g}")
    else:
        lines.append(f"  a single record: validated on itself, nrmse {ident['validation']['nrmse']:.4g}")
    return "\n".join(lines)


def terms_or_default(text: str | None, default: tuple[str, ...]) -> str | tuple[str, ...]:
    """``--damping`` / ``--stiffness`` text, or the default candidates."""
    return text if text else default


def handle(args: argparse.Namespace) -> int:
    """Run ``station replay``; return the exit code."""
    from eddi.terms import DEFAULT_DAMPING, DEFAULT_STIFFNESS
    from station.session import expand_specs, read_all, run_session
    from station.readers import split_spec

    specs = expand_specs([args.file])
    obj: dict[str, Any] = {"file": args.file}
    lines: list[str] = []
    if args.through_device:
        checks = []
        for spec in specs:
            path, capture = split_spec(spec)
            if path.suffix.lower() not in (".h5", ".hdf5"):
                raise InputFileError(f"--through-device: expected an HDF5 capture file, got {path}")
            checks.append(stream_through_device(str(path), int(capture or 0)))
        obj["through_device"] = [c.__dict__ for c in checks]
        obj["bit_exact"] = all(c.bit_exact for c in checks)
        for c in checks:
            lines.append(f"capture {c.capture}: {c.samples} samples through {c.transport_url}: "
                         + ("bit-exact" if c.bit_exact else f"{c.mismatched_samples} samples differ")
                         + f" (dropped {c.dropped_samples}, CRC errors {c.crc_errors})")
    from station.mdof_data import is_multichannel
    from station.readers import read_measurement

    first = read_measurement(specs[0])
    if is_multichannel(first):  # several sensors: the coupled multi-DOF model, every channel predicted
        from station.mdof_replay import replay_mdof_object, replay_mdof_text

        obj.update(replay_mdof_object([first] + [read_measurement(s) for s in specs[1:]]))
        obj.pop("_validations")
        lines.append(replay_mdof_text(obj))
        emit(args.json, "\n".join(lines), obj)
        if args.through_device and not obj["bit_exact"]:
            return 1
        if obj["unstable"]:
            from station.cli import flagged

            return flagged("replay", "the identified model is unstable or its simulation diverges")
        return 0
    terms = (terms_or_default(args.damping, DEFAULT_DAMPING), terms_or_default(args.stiffness, DEFAULT_STIFFNESS),
             "auto")
    session = run_session(read_all(specs, command="replay"), args.mass, damping=terms[0], stiffness=terms[1],
                          route=terms[2], fit_index=args.fit, refine=args.refine)
    obj.update(session_object(session, terms))
    lines.append(session_text(obj))
    emit(args.json, "\n".join(lines), obj)
    if args.through_device and not obj["bit_exact"]:
        return 1
    if session.fit.unstable or any(c.diverged for c in session.held_out):
        from station.cli import flagged

        return flagged("replay", "the identified model is unstable or its simulation diverges")
    return 0
