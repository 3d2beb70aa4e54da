"""SDyPy SEP-005 export of captures: one JSON list of channel dicts, validated with ``sdypy-sep005``.

SEP-005 (https://github.com/sdypy/sdypy, "SEP 005: time series data") is the SDyPy convention
for time series exchanged between Python tools: a list of dicts, one per channel, with at least
``data``, ``name``, ``unit_str`` and ``fs`` (or ``time``). Each exported channel is such a dict:

=================  ===================================================================
key                value
=================  ===================================================================
name               ``"<file stem> capture <i> <channel>"``
data               SI values (JSON numbers: Python's shortest repr, exact float64)
unit_str           SI unit (``N``, ``m/s^2``, ...)
fs                 sample rate [Hz]
quantity           ``f``, ``a``, ``v`` or ``d``
group              ``"capture <i>"``
start_timestamp    ISO 8601 wall-clock time of the first sample (when the file has it)
capture            capture index; ``pretrigger_samples``; ``mass_kg`` (when known)
sensor_model, sensor_serial, calibration_date, node, direction    when the file has them
=================  ===================================================================

Every dict is checked with :class:`sdypy_sep005.Sep005Data` before the file is written, and
:func:`read_sep005` checks them again when reading.
"""

from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from station.errors import InputFileError, StationError
from station.storage import check_values, iter_captures, list_captures

QUANTITY_CODES = {"force": "f", "acceleration": "a", "velocity": "v", "displacement": "d"}
_SENSOR_KEYS = ("sensor_model", "sensor_serial", "calibration_date", "node", "direction")


def _validate(d: dict[str, Any], where: str) -> None:
    from pydantic import ValidationError
    from sdypy_sep005 import Sep005Data

    try:
        Sep005Data.model_validate(d)
    except (ValidationError, ValueError, TypeError) as exc:
        first = str(exc).splitlines()
        raise InputFileError(f"{where}: not SEP-005 ({' '.join(first[:3])})") from None


def export_sep005(h5_path: str | os.PathLike[str], out_path: str | os.PathLike[str],
                  captures: Iterable[int] | None = None) -> int:
    """Write the channels of captures as SEP-005 JSON; return the number of channels written.

    Parameters
    ----------
    h5_path : str or Path
        Session file.
    out_path : str or Path
        JSON file to create (replaced if present).
    captures : iterable of int, optional
        0-based indices; all when None. Captures are read one at a time.

    Raises
    ------
    InputFileError
        A capture with missing samples.
    """
    src = Path(h5_path)
    indices = list(captures) if captures is not None else [c.index for c in list_captures(src)]
    out: list[dict[str, Any]] = []
    for cap in iter_captures(src, indices):
        if cap.dropped_samples:
            raise InputFileError(f"capture {cap.index} of {src}: {cap.dropped_samples} samples missing; "
                                 "SEP-005 export needs a complete record")
        for name, ch in cap.channels.items():
            check_values(ch.si, f"capture {cap.index} of {src}: channel {name!r}")  # as every reader refuses
            d: dict[str, Any] = {
                "name": f"{src.stem} capture {cap.index} {name}",
                "data": np.asarray(ch.si, dtype=np.float64).tolist(),
                "unit_str": ch.info.unit,
                "fs": float(cap.rate_hz),
                "quantity": QUANTITY_CODES.get(ch.info.quantity),
                "group": f"capture {cap.index}",
                "capture": cap.index,
                "pretrigger_samples": cap.pretrigger_samples,
            }
            if cap.attrs.get("t0_utc"):
                d["start_timestamp"] = str(cap.attrs["t0_utc"])
            if cap.mass_kg is not None:
                d["mass_kg"] = cap.mass_kg
            for k in _SENSOR_KEYS:
                if k in ch.attrs:
                    d[k] = ch.attrs[k]
            _validate(d, f"capture {cap.index} channel {name!r}")
            out.append(d)
    if not out:
        raise InputFileError(f"{src}: no channel to export")
    dest = Path(out_path)
    tmp = dest.with_name(f".{dest.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(out, fh, allow_nan=False)
        os.replace(tmp, dest)
    except OSError as exc:
        with contextlib.suppress(OSError):  # a read-only folder refuses even this
            tmp.unlink(missing_ok=True)
        raise StationError(f"cannot write {dest}: {exc.strerror or exc}") from None
    return len(out)


def read_sep005(path: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Read a SEP-005 JSON file (a list of channel dicts), each checked; ``data`` as float64 arrays."""
    p = Path(path)
    try:
        items = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputFileError(f"{p}: cannot read SEP-005 JSON ({exc})") from None
    if not isinstance(items, list):
        raise InputFileError(f"{p}: expected a JSON list of channel dicts (SEP-005), got {type(items).__name__}")
    for i, d in enumerate(items):
        if not isinstance(d, dict):
            raise InputFileError(f"{p}: item {i} is not a dict")
        _validate(d, f"{p} item {i}")
        d["data"] = np.asarray(d["data"], dtype=np.float64)
    return items
