"""Reading records from Universal File Format files (dataset 58 time responses), with pyuff.

Modal-analysis tools (Simcenter Testlab, ME'scope, SDyPy, the station's own ``station export
--uff``) write measured time series as UFF58 *function at nodal DOF* sets. A record here is the
sets of one load case (``load_case_id``; the station writes one per capture) that are time
responses (function type 1) on one time axis:

* a set's quantity is its ordinate's specific data type: 13 (excitation force) ``force``, 12
  ``acc``, 11 ``vel``, 8 ``disp``; other types (FRFs, strain...) are left out;
* several response sets of one quantity are several sensors: ``acc1, acc2, ...`` in file order
  (the station's multi-DOF naming), one of each is ``acc`` / ``vel`` / ``disp``;
* values are brought to SI by the ordinate's unit label when it is one of
  :data:`station.csv_header.UNITS` (``g``, ``mm/s``, ...), else by the file's units dataset 164
  (its factors divide: UFF units per SI unit, raised to the ordinate's length and force
  exponents), else taken as SI;
* time: ``abscissa_min + i * abscissa_inc`` (UFF58 prints the increment with 6 digits, E13.5);
  a station export's id3 (``rate R Hz, pretrigger P samples`` or ``pretrigger unknown``) gives the
  exact rate and the pretrigger.

``FILE.uff:N`` selects load case ``N``; without it the file must hold one load case.
"""

from __future__ import annotations

import re
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from station.csv_header import UNITS, unit_key
from station.errors import InputFileError

#: Station channel of each UFF58 ordinate specific data type.
QUANTITY_OF_TYPE = MappingProxyType({13: "force", 12: "acc", 11: "vel", 8: "disp"})
_EXPORT_ID3 = re.compile(r"rate ([0-9.eE+-]+) Hz, pretrigger (?:([0-9]+) samples|unknown)")


def _check_complete(path: Path) -> None:
    """Refuse a UFF file cut short: every data set ends with the delimiter ``    -1`` (text and
    binary sets alike; a binary set's data runs up to it on the same line), so a file whose last non-blank line is anything else was truncated
    (a copy or a logger stopped mid-write) and pyuff would read its last set short."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(80).lstrip(b" \t\r\n")
            fh.seek(0, 2)
            fh.seek(max(0, fh.tell() - 512))
            tail = fh.read().rstrip(b" \t\r\n\x00")
    except OSError as exc:
        raise InputFileError(f"{path}: cannot read ({exc.strerror or exc})") from None
    looks_uff = head.startswith(b"-1")  # otherwise pyuff's own refusal says what it is
    if looks_uff and not re.search(rb"(^|\s)-1$", tail):
        raise InputFileError(f"{path}: truncated UFF file (its last data set has no closing -1 line)")


def _sets(path: Path) -> list[dict[str, Any]]:
    import pyuff  # local: only a UFF file needs it

    _check_complete(path)
    try:
        uff = pyuff.UFF(str(path))
        types = list(uff.get_set_types())
        got = uff.read_sets() if types else []
    except Exception as exc:  # pyuff raises bare Exception on a malformed file
        raise InputFileError(f"{path}: not a readable UFF file ({str(exc).splitlines()[0][:120] if str(exc) else type(exc).__name__})") from None
    return [got] if isinstance(got, dict) else list(got)


def load_cases(path: str | Path) -> list[int]:
    """The load cases of a UFF file that hold time responses, sorted (headers only: no data read).

    Raises
    ------
    InputFileError
        Not a readable UFF file.
    """
    import pyuff

    path = Path(path)
    _check_complete(path)
    try:
        uff = pyuff.UFF(str(path))
        got = uff.read_sets(header_only=True) if list(uff.get_set_types()) else []
    except Exception as exc:  # pyuff raises bare Exception on a malformed file
        raise InputFileError(f"{path}: not a readable UFF file ({type(exc).__name__})") from None
    sets = [got] if isinstance(got, dict) else list(got)
    return sorted({int(s.get("load_case_id", 0)) for s in sets
                   if s.get("type") == 58 and int(s.get("func_type", 0)) == 1})


def _si_factor(s: dict[str, Any], units164: dict[str, Any] | None, quantity: str, where: str) -> float:
    label = str(s.get("ordinate_axis_units_lab", "") or "").strip()
    if label:
        key = unit_key(label)
        if key in ("v", "mv", "volt", "volts"):
            raise InputFileError(f"{where}: the {quantity} set is in volts: scale it with the sensor's "
                                 "sensitivity first (the station reads physical units)")
        factor = UNITS["t" if quantity == "t" else quantity].get(key)
        if factor is not None:
            return factor
    if units164 is not None:
        length = float(units164.get("length", 1.0) or 1.0)
        force = float(units164.get("force", 1.0) or 1.0)
        return 1.0 / (length ** int(s.get("ordinate_len_unit_exp", 0)) * force ** int(s.get("ordinate_force_unit_exp", 0)))
    return 1.0


def read_uff(path: str | Path, capture: str | None = None) -> Any:
    """Read one record (load case) of a UFF58 file as a :class:`station.readers.Measurement`.

    Raises
    ------
    InputFileError
        Not a UFF file, no time response, several load cases and none chosen, an unknown load
        case, sets of one record on different time axes, values in volts.
    """
    from station.readers import Measurement, check_force_impact  # station.readers dispatches here

    path = Path(path)
    sets = _sets(path)
    units164 = next((s for s in sets if s.get("type") == 164), None)
    series = [s for s in sets if s.get("type") == 58 and int(s.get("func_type", 0)) == 1
              and int(s.get("ordinate_spec_data_type", -1)) in QUANTITY_OF_TYPE]
    if not series:
        raise InputFileError(f"{path}: no time response (UFF58 function type 1 of force, acceleration, "
                             "velocity or displacement) in the file")
    cases = sorted({int(s.get("load_case_id", 0)) for s in series})
    if capture is None:
        if len(cases) > 1:
            raise InputFileError(f"{path}: {len(cases)} load cases ({', '.join(map(str, cases[:8]))}); choose one "
                                 f"as {path.name}:CASE")
        case = cases[0]
    else:
        try:
            case = int(capture)
        except ValueError:
            raise InputFileError(f"{path}: load case {capture!r} is not a number") from None
        if case not in cases:
            raise InputFileError(f"{path}: no load case {case}; the file holds {', '.join(map(str, cases[:8]))}")
    mine = [s for s in series if int(s.get("load_case_id", 0)) == case]
    where = f"{path}:{case}"
    n = {int(s["num_pts"]) for s in mine}
    inc = {float(s["abscissa_inc"]) for s in mine}
    t0 = {float(s.get("abscissa_min", 0.0)) for s in mine}
    if len(n) > 1 or len(inc) > 1 or len(t0) > 1:
        raise InputFileError(f"{where}: its sets are on different time axes (points {sorted(n)}, steps {sorted(inc)})")
    step = inc.pop()
    if not step > 0:
        raise InputFileError(f"{where}: time step {step:g} s; expected a positive abscissa increment")
    rate, pretrigger = 1.0 / step, None
    m = _EXPORT_ID3.search(str(mine[0].get("id3", "")))
    if m is not None:  # the station's own export: the exact rate and the pretrigger
        rate, pretrigger = float(m.group(1)), (int(m.group(2)) if m.group(2) is not None else None)
    quantities = [QUANTITY_OF_TYPE[int(s["ordinate_spec_data_type"])] for s in mine]
    channels: dict[str, np.ndarray] = {}
    count: dict[str, int] = {}
    for s, q in zip(mine, quantities):
        if q == "force" and "force" in channels:
            continue  # one hammer: the first force set
        name = q
        if q != "force" and quantities.count(q) > 1:
            count[q] = count.get(q, 0) + 1
            name = f"{q}{count[q]}"
        y = np.asarray(s["data"], dtype=np.float64)
        factor = _si_factor(s, units164, q, where)
        y = y * factor if factor != 1.0 else y.copy()
        if not np.all(np.abs(y) <= 1e12):
            raise InputFileError(f"{where}: the {name} set holds values that are not finite or beyond +-1e12 SI")
        channels[name] = y
    if all(q == "force" for q in channels):
        raise InputFileError(f"{where}: no response set (acceleration, velocity or displacement)")
    if "force" in channels:
        check_force_impact(channels["force"], f"{where}: the force set")
    size = n.pop()
    return Measurement(
        t=t0.pop() + np.arange(size) / rate, channels=MappingProxyType(channels), rate_hz=rate,
        pretrigger_samples=pretrigger, mass=None, source=where,
        metadata={"format": "uff58", "load_case": case, "sets": [str(s.get("id1", "")).strip() for s in mine]},
    )
