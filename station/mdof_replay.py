"""``station replay`` on multi-channel captures (several sensors): identify, then predict every channel.

The one-coordinate replay identifies on one record and validates on the others; a coupled
multi-DOF model needs several force levels to see its nonlinearity, so here the model is
identified (:func:`eddi.mdof.identify.identify_mdof`, no mass needed) on every capture but the
last, which is held out; every capture is then predicted from rest by its measured force and
scored per channel (:func:`eddi.mdof.validate.validate_mdof`). A single capture is identified
and validated on itself (said so).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from eddi.errors import IdentificationError
from eddi.mdof.collocation import check_driving_point
from eddi.mdof.identify import identify_mdof
from eddi.mdof.validate import validate_mdof
from station.errors import InputFileError
from station.mdof_data import condition_all, driving_point_how


def replay_mdof_object(measurements: Sequence[Any], driving_point: str | None = None) -> dict[str, Any]:
    """The ``--json`` object of ``station replay`` for multi-channel captures.

    Its ``_validations`` entry (one :class:`eddi.mdof.validate.MdofValidation` per capture, with
    the measured and simulated displacement) is for the report; drop it before printing JSON.

    Raises
    ------
    InputFileError
        Captures that cannot be identified (the message says why).
    """
    records, names, dp = condition_all(list(measurements), driving_point)
    train = records[:-1] if len(records) > 1 else records
    try:
        ident = identify_mdof(train, names, dp)
    except IdentificationError as exc:
        raise InputFileError(f"multi-DOF identification: {exc}") from None
    out, validations = [], []
    for k, r in enumerate(records):
        v = validate_mdof(ident.model, r)
        validations.append(v)
        out.append({"source": r.label, "role": "train" if k < len(train) else "held out",
                    "nrmse": v.nrmse, "channel_nrmse": v.channel_nrmse, "diverged": v.diverged})
    if len(records) == 1:
        out[0]["role"] = "train (single capture: validated on itself)"
    held = [o for o in out if o["role"] == "held out"]
    model = ident.model
    flags = replay_flags(model, validations)
    fitted = [o["nrmse"] for o in out if o["role"] != "held out"]
    warnings = flags + _poor_fit(fitted, [o["nrmse"] for o in held])
    return {"model_kind": "mdof", "channels": list(names), "driving_point": dp,
            "captures": [r.label for r in records], "fit_records": [r.label for r in train],
            "coordinates": ident.coordinates, "notes": list(ident.notes),
            "masses_kg": list(model.mass), "natural_frequencies_hz": model.natural_frequencies_hz().tolist(),
            "equation": model.equation_text(), "model": model.model_dump(mode="json"),
            "records": out,
            "held_out_nrmse": float(np.mean([o["nrmse"] for o in held])) if held else None,
            "warnings": warnings + check_driving_point(ident.modes, records, names, dp,
                                                       driving_point_how(measurements[0], driving_point)),
            "unstable": bool(flags), "_validations": validations}


def growth_flag(model: Any) -> list[str]:
    """A sentence when the model's linear part grows (shared by replay, report and diagnose)."""
    from eddi.mdof.identify import linear_growth_rate

    growth = linear_growth_rate(model)
    return [f"the model's linear part is unstable: a mode grows at {growth:.3g} 1/s"] if growth > 0 else []


def replay_flags(model: Any, validations: Sequence[Any]) -> list[str]:
    """Why the identified model cannot be trusted as a simulation (the command then exits with
    :data:`station.cli.EXIT_FLAGGED`): its linear part grows, or its simulation of a capture
    diverged (as ``station diagnose`` flags a multi-DOF model)."""
    out = growth_flag(model)
    if any(v.diverged for v in validations):
        out.append("the model's simulation diverged on a capture")
    return out


def _poor_fit(fitted: Sequence[float], held: Sequence[float]) -> list[str]:
    """The one-coordinate commands' "poor fit" / "poor prediction" sentences (:data:`eddi.stability.
    POOR_FIT_NRMSE`), on the captures' mean per-channel nrmse."""
    from eddi.stability import POOR_FIT_NRMSE

    out = []
    worst = max((f for f in fitted if np.isfinite(f)), default=float("nan"))
    if np.isfinite(worst) and worst > POOR_FIT_NRMSE:
        out.append(f"poor fit: the model reproduces the captures it was fitted on with nrmse up to {worst:.3g} "
                   f"(> {POOR_FIT_NRMSE:g}, mean over channels): a mechanism outside the model's library or a "
                   "measurement problem; `station diagnose` on several captures lists the symptoms")
    bad = [h for h in held if np.isfinite(h) and h > POOR_FIT_NRMSE]
    if bad:
        out.append(f"poor prediction: held-out nrmse up to {max(bad):.3g} (> {POOR_FIT_NRMSE:g}) on {len(bad)} "
                   f"of {len(held)} held-out captures")
    return out


def replay_mdof_text(obj: dict[str, Any]) -> str:
    """People-friendly lines of :func:`replay_mdof_object`."""
    lines = [f"multi-DOF: identified on {', '.join(obj['fit_records'])} ({obj['coordinates']} coordinates, "
             f"driving point {obj['driving_point']}, no mass given)",
             f"  masses {', '.join(f'{m:.4g}' for m in obj['masses_kg'])} kg; natural frequencies "
             f"{', '.join(f'{f:.5g}' for f in obj['natural_frequencies_hz'])} Hz",
             f"  {obj['notes'][-1]}" if obj["notes"] else ""]
    for r in obj["records"]:
        chans = "  ".join(f"{c} {v:.4g}" for c, v in r["channel_nrmse"].items())
        lines.append(f"  {r['role']:<9} {r['source']:<40} nrmse {r['nrmse']:.4g}  ({chans})"
                     + ("  WARNING: diverged" if r["diverged"] else ""))
    if obj["held_out_nrmse"] is not None:
        lines.append(f"  held-out nrmse (mean over channels): {obj['held_out_nrmse']:.4g}")
    lines += [f"  WARNING: {w}" for w in obj.get("warnings", [])]
    return "\n".join(line for line in lines if line)
