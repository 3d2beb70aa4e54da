"""``station export`` (HDF5 captures -> UFF58 and/or SEP-005 JSON) and ``station import`` (CSV -> HDF5).

    station export session.h5[:CAPTURE] --uff out.uff [--ascii] [--sep005 out.json] [--json]
    station import ringdown-01.csv [more.csv ...] --out session.h5 [--mass KG] [--notes TEXT]
                   [--new-session] [--json]

``import`` reads each CSV exactly as ``station identify`` does (:mod:`station.readers`) and
stores its SI values unchanged (``encoding="si"``, docs/capture-format.md). It refuses a record
whose rate, mass or channels disagree with the session already in the file, unless
``--new-session`` says it starts a new one. One writer at a time: a second ``import`` or
``acquire`` into the same file waits (at most ``--lock-wait`` s), then exits 2.

No output may overwrite an input or a file of another kind (``station.output_safety``).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from station.argtypes import add_adc_filter_option, add_sensor_highpass_option, finite_positive, nonnegative_seconds
from station.errors import InputFileError
from station.output import emit
from station.output_safety import check_output


def register(subparsers: Any) -> None:
    """Add the ``export`` and ``import`` sub-commands."""
    e = subparsers.add_parser("export", help="write force and acceleration of captures to a UFF58 file",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    e.add_argument("source", metavar="FILE[:CAPTURE]", help="HDF5 session file; all captures unless one is named")
    e.add_argument("--uff", metavar="OUT", help="UFF58 file to write")
    e.add_argument("--ascii", action="store_true", help="ASCII records (default binary float64)")
    e.add_argument("--sep005", metavar="OUT.json", help="SDyPy SEP-005 JSON file to write")
    e.add_argument("--json", action="store_true", help="print one JSON object")
    e.set_defaults(func=handle_export)

    i = subparsers.add_parser("import", help="store CSV measurements as captures of an HDF5 session file",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    i.add_argument("csv", nargs="+", metavar="CSV", help="CSV files in the format station identify reads")
    i.add_argument("--out", required=True, metavar="FILE", help="HDF5 session file (created, or appended to)")
    i.add_argument("--mass", type=finite_positive, metavar="KG", help="oscillating mass [kg] stored with each capture")
    i.add_argument("--notes", default="", help="operator notes stored with each capture")
    add_adc_filter_option(i)
    add_sensor_highpass_option(i)
    i.add_argument("--new-session", action="store_true",
                   help="the records start a new session in the file (else each must match the "
                   "session's rate, mass and channels)")
    i.add_argument("--lock-wait", type=nonnegative_seconds, default=60.0, metavar="S",
                   help="wait at most S seconds for another writer of the file (default %(default)s)")
    i.add_argument("--json", action="store_true", help="print one JSON object")
    i.set_defaults(func=handle_import)


def handle_export(args: argparse.Namespace) -> int:
    """Run ``station export``."""
    from station.readers import split_spec
    from station.storage import list_captures

    if not args.uff and not args.sep005:
        raise InputFileError("export: expected --uff OUT and/or --sep005 OUT.json")
    if args.uff and args.sep005 and Path(args.uff).resolve() == Path(args.sep005).resolve():
        raise InputFileError(f"--uff and --sep005 name the same file {args.uff}")
    if args.uff:
        check_output(args.uff, "uff", [args.source], option="--uff")
    if args.sep005:
        check_output(args.sep005, "sep005", [args.source], option="--sep005")
    path, cap = split_spec(args.source)
    n = len(list_captures(path))
    if cap is None:
        indices = None
    else:
        try:
            k = int(cap)
        except ValueError:
            raise InputFileError(f"capture {cap!r}: expected an index") from None
        if not -n <= k < n:
            raise InputFileError(f"capture {k}: expected an index 0..{n - 1}, the file {Path(path).name} holds {n} capture(s)")
        indices = [k % n]
    obj: dict[str, Any] = {"source": str(path), "captures": indices}
    lines = []
    if args.uff:
        from station.uff import export_uff58

        records = export_uff58(path, args.uff, indices, binary=not args.ascii)
        obj.update({"file": str(args.uff), "records": records})
        lines.append(f"{records} UFF58 record(s) written to {args.uff}")
    if args.sep005:
        from station.sep005 import export_sep005

        chans = export_sep005(path, args.sep005, indices)
        obj.update({"sep005_file": str(args.sep005), "sep005_channels": chans})
        lines.append(f"{chans} SEP-005 channel(s) written to {args.sep005}")
    emit(args.json, "\n".join(lines), obj)
    return 0


def handle_import(args: argparse.Namespace) -> int:
    """Run ``station import``."""
    from station.readers import read_measurement
    from station.session import with_adc_filter, with_sensor_highpass
    from station.session_writer import CaptureWriter, import_measurement, same_session_check

    out = check_output(args.out, "hdf5", args.csv, option="--out", append=True)
    measurements = [read_measurement(c) for c in args.csv]  # all read before anything is written
    writer = CaptureWriter(out, lock_wait_s=args.lock_wait)
    indices = []
    with writer:  # one writer: the records go in together, checked against the session under the lock
        for k, m in enumerate(measurements):
            if args.mass is not None:
                m = _with_mass(m, args.mass)
            m = with_sensor_highpass(with_adc_filter(m, args.adc_filter), args.sensor_highpass)
            check = same_session_check(out, new_session=args.new_session and k == 0, verify=not args.new_session)
            indices.append(import_measurement(writer, m, notes=args.notes, check=check))
    emit(args.json, f"{len(indices)} capture(s) imported into {args.out} (indices {indices[0]}..{indices[-1]})",
         {"file": str(args.out), "captures": len(indices), "indices": indices, "sources": list(args.csv)})
    return 0


def _with_mass(m: Any, mass: float) -> Any:
    import dataclasses

    if dataclasses.is_dataclass(m):
        return dataclasses.replace(m, mass=mass)
    if hasattr(m, "model_copy"):
        return m.model_copy(update={"mass": mass})
    m.mass = mass
    return m
