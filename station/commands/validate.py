"""``station validate MODEL.json CAPTURE... [--json]``: simulate a model for measured records.

    station validate model.json session.h5            # every capture of the file
    station validate model.json session.h5:0 other.csv

Each record is simulated with the model (an equation of motion, or a modal-sum model) and
compared with the measurement (see :func:`station.session.validate_measurement`):

* with a force channel: from rest, driven by its measured impact force;
* without: from its measured initial state (a modal-sum model predicts the velocity).

Prints ``nrmse`` and ``nmte`` per record and their means. ``FILE.h5`` without ``:CAPTURE``
means every capture in it.

A multi-DOF model (``"kind": "mdof"``, from ``station diagnose`` on captures with several
response channels) predicts every channel: per-channel ``nrmse`` of the displacement and their
mean as ``nrmse`` (see ``docs/multi-dof.md``).
"""

from __future__ import annotations

import argparse
from typing import Any

from station.argtypes import add_sensor_highpass_option
from station.output import emit


def register(subparsers: Any) -> None:
    """Add the ``validate`` sub-command."""
    p = subparsers.add_parser("validate", help="simulate a model for measured records and score it",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("model", metavar="MODEL.json", help="equation of motion or modal-sum model (JSON)")
    p.add_argument("records", metavar="CAPTURE", nargs="+", help="FILE.csv, FILE.h5 (all captures) or FILE.h5:N")
    add_sensor_highpass_option(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=handle)


def validate_object(model_path: str, specs: list[str], sensor_highpass_hz: float | None = None) -> dict[str, Any]:
    """Validate the model on every record; the ``--json`` object (``sensor_highpass_hz``: a declared
    accelerometer AC coupling [Hz], inverted in conditioning; 0 DC-coupled; None: as recorded)."""
    from eddi.multimode import ModalSumModel
    from station.session import (expand_specs, load_model_file, mean_of, read_measurement, validate_measurement,
                                 with_sensor_highpass)

    model = load_model_file(model_path)
    if getattr(model, "kind", None) == "mdof":  # several coordinates: every channel predicted
        from station.mdof_commands import validate_mdof_object

        return validate_mdof_object(model, model_path, specs)  # type: ignore[arg-type]
    checks = [validate_measurement(model, with_sensor_highpass(read_measurement(s), sensor_highpass_hz))
              for s in expand_specs(specs)]
    return {
        "model": model_path,
        "model_kind": "modal_sum" if isinstance(model, ModalSumModel) else "equation_of_motion",
        "compared": "velocity" if isinstance(model, ModalSumModel) else "displacement",
        "records": [c.as_dict() for c in checks],
        "nrmse": mean_of([c.nrmse for c in checks]),
        "nmte": mean_of([c.nmte for c in checks if c.nmte is not None]),
    }


def _text(obj: dict[str, Any]) -> str:
    lines = [f"{obj['model']} ({obj['model_kind'].replace('_', ' ')}), {obj['compared']} compared:"]
    for r in obj["records"]:
        how = "from rest, measured force" if r["driven_by"] == "force" else "from the measured state"
        nmte = "–" if r["nmte"] is None else f"{r['nmte']:.4g}"
        lines.append(f"  {r['source']:<40} nrmse {r['nrmse']:.4g}  nmte {nmte}  ({how}"
                     + (", diverged" if r["diverged"] else "") + ")")
        lines += [f"    WARNING: {w}" for w in r.get("warnings", [])]
    nmte = "–" if obj["nmte"] is None else f"{obj['nmte']:.4g}"
    lines.append(f"  mean over {len(obj['records'])} record(s): nrmse {obj['nrmse']:.4g}  nmte {nmte}")
    return "\n".join(lines)


def handle(args: argparse.Namespace) -> int:
    """Run ``station validate``; return the exit code."""
    obj = validate_object(args.model, list(args.records), args.sensor_highpass)
    diverged = sum(bool(r.get("diverged")) for r in obj["records"])
    obj["diverged"] = diverged
    if obj["model_kind"] == "mdof":
        from station.mdof_commands import validate_mdof_text

        emit(args.json, validate_mdof_text(obj), obj)
    else:
        emit(args.json, _text(obj), obj)
    if diverged:
        from station.cli import flagged

        return flagged("validate", f"the model's simulation diverges on {diverged} of {len(obj['records'])} "
                                   f"record(s)")
    return 0
