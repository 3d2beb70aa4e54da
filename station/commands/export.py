"""``station export`` (HDF5 captures -> UFF58) and ``station import`` (CSV -> HDF5 session file).

    station export session.h5[:CAPTURE] --uff out.uff [--ascii] [--json]
    station import ringdown-01.csv [more.csv ...] --out session.h5 [--mass KG] [--notes TEXT] [--json]

``import`` reads each CSV exactly as ``station identify`` does (:mod:`station.readers`) and
stores its SI values unchanged (``encoding="si"``, docs/capture-format.md).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from station.errors import InputFileError
from station.output import emit
from station.storage import CaptureWriter, import_measurement, list_captures
from station.uff import export_uff58


def register(subparsers: Any) -> None:
    """Add the ``export`` and ``import`` sub-commands."""
    e = subparsers.add_parser("export", help="write force and acceleration of captures to a UFF58 file",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    e.add_argument("source", metavar="FILE[:CAPTURE]", help="HDF5 session file; all captures unless one is named")
    e.add_argument("--uff", required=True, metavar="OUT", help="UFF58 file to write")
    e.add_argument("--ascii", action="store_true", help="ASCII records (default binary float64)")
    e.add_argument("--json", action="store_true", help="print one JSON object")
    e.set_defaults(func=handle_export)

    i = subparsers.add_parser("import", help="store CSV measurements as captures of an HDF5 session file",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    i.add_argument("csv", nargs="+", metavar="CSV", help="CSV files in the format station identify reads")
    i.add_argument("--out", required=True, metavar="FILE", help="HDF5 session file (created, or appended to)")
    i.add_argument("--mass", type=float, metavar="KG", help="oscillating mass [kg] stored with each capture")
    i.add_argument("--notes", default="", help="operator notes stored with each capture")
    i.add_argument("--json", action="store_true", help="print one JSON object")
    i.set_defaults(func=handle_import)


def handle_export(args: argparse.Namespace) -> int:
    """Run ``station export``."""
    from station.readers import split_spec

    path, cap = split_spec(args.source)
    if cap is None:
        indices = None
    else:
        try:
            n = len(list_captures(path))
            k = int(cap)
        except ValueError:
            raise InputFileError(f"capture {cap!r}: expected an index") from None
        if not -n <= k < n:
            raise InputFileError(f"capture {k}: expected an index 0..{n - 1}, the file {Path(path).name} holds {n} capture(s)")
        indices = [k % n]
    records = export_uff58(path, args.uff, indices, binary=not args.ascii)
    emit(args.json, f"{records} UFF58 record(s) written to {args.uff}", {"file": str(args.uff), "records": records,
                                                                           "source": str(path), "captures": indices})
    return 0


def handle_import(args: argparse.Namespace) -> int:
    """Run ``station import``."""
    from station.readers import read_measurement

    if args.mass is not None and not args.mass > 0:
        raise InputFileError(f"--mass: expected a mass > 0 kg, got {args.mass}")
    measurements = [read_measurement(c) for c in args.csv]  # all read before anything is written
    writer = CaptureWriter(args.out)
    indices = []
    for src, m in zip(args.csv, measurements):
        if args.mass is not None:
            m = _with_mass(m, args.mass)
        indices.append(import_measurement(writer, m, notes=args.notes))
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
