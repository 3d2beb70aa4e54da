"""The header of a CSV measurement as labs write it: delimiter, column names, units.

:func:`parse_header` turns the first line of a text record into the station's column names
(``t``, ``force``, ``acc``, ``vel``, ``disp``, and suffixed sensors ``acc1``, ``acc_tip``) and the
factor that brings each column to SI. Files written by the station (``t,force,acc``) read
exactly as before (every factor 1, values untouched). Files exported by other tools are read
when their header says what a column is:

* **delimiter**: a tab, a semicolon, a comma (first of these the header holds), else runs of
  blanks; cells and numbers may be quoted (``"Time [s]"``, a spreadsheet's export); with a tab or semicolon delimiter and a comma inside the numbers, the decimal
  separator is a comma (a European spreadsheet export);
* **names**: the quantity in words or short (``Time``, ``time``, ``Force``, ``Hammer``,
  ``Acceleration``, ``accel``, ``Velocity``, ``Displacement``, ...), case and blanks ignored,
  with a sensor number or name after it for several sensors (``Acceleration 2``, ``accel_tip``);
* **units** in brackets or parentheses after the name (``Time [s]``, ``Velocity (mm/s)``,
  ``Acceleration [g]``, ``Force [kN]``): converted to SI by the factors of :data:`UNITS`; a unit
  not there, or a voltage (an unscaled sensor signal), is refused in one line.

* **a units row** under the names (``Time,Force,Accel`` then ``[s],[N],[g]`` or ``s;kN;m/s^2``, as
  loggers export): each unit joins its column's name.

Leading lines starting with ``#`` (a logger's notes) are skipped. A header the rules cannot read
is refused naming the cell, as before: a guessed column is worse than a refusal.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from types import MappingProxyType
from typing import Mapping

from station.errors import InputFileError

#: Spellings of each quantity (after lower-casing and blanks/hyphens to ``_``).
ALIASES: Mapping[str, str] = MappingProxyType({
    **dict.fromkeys(("t", "time", "times", "timestamp", "time_stamp"), "t"),
    **dict.fromkeys(("force", "f", "hammer", "hammer_force", "impact_force", "excitation", "load",
                     "input_force"), "force"),
    **dict.fromkeys(("acc", "accel", "acceleration", "a", "accelerometer"), "acc"),
    **dict.fromkeys(("vel", "velocity", "v"), "vel"),
    **dict.fromkeys(("disp", "displacement", "x", "d"), "disp"),
})
#: Response quantities that may carry a sensor suffix, with their long spellings.
_SENSOR_STEMS = {"acc": "acc", "accel": "acc", "acceleration": "acc", "accelerometer": "acc", "vel": "vel",
                 "velocity": "vel", "disp": "disp", "displacement": "disp"}
_SUFFIXED = re.compile(r"^(accelerometer|acceleration|accel|acc|velocity|vel|displacement|disp)"
                       r"(?:_?([0-9]+)|_([a-z][a-z0-9_]*))$")

#: Factor to SI of each unit a column may be in, per quantity (unit spellings normalised by
#: :func:`unit_key`). g is the standard gravity 9.80665 m/s^2 (ISO 80000-3); lbf = 4.4482216152605 N
#: and in = 0.0254 m exactly (international yard and pound, 1959).
UNITS: Mapping[str, Mapping[str, float]] = MappingProxyType({
    "t": MappingProxyType({"s": 1.0, "sec": 1.0, "ms": 1e-3, "us": 1e-6}),
    "force": MappingProxyType({"n": 1.0, "kn": 1e3, "mn": 1e-3, "lbf": 4.4482216152605}),
    "acc": MappingProxyType({"m/s^2": 1.0, "m/s2": 1.0, "ms^-2": 1.0, "m*s^-2": 1.0, "m/s/s": 1.0,
                             "g": 9.80665, "mm/s^2": 1e-3, "mm/s2": 1e-3, "in/s^2": 0.0254,
                             "ft/s^2": 0.3048}),
    "vel": MappingProxyType({"m/s": 1.0, "ms^-1": 1.0, "mm/s": 1e-3, "um/s": 1e-6, "in/s": 0.0254}),
    "disp": MappingProxyType({"m": 1.0, "mm": 1e-3, "um": 1e-6, "in": 0.0254}),
})
_UNIT = re.compile(r"^(?P<name>.*?)\s*(?:\[(?P<a>[^\]]*)\]|\((?P<b>[^)]*)\))\s*$")


@dataclass(frozen=True)
class Header:
    """What a CSV header says.

    Attributes
    ----------
    names : tuple of str
        The station's column names, in file order.
    scales : tuple of float
        Factor to SI per column (1.0 for SI or no unit given).
    delimiter : str or None
        Between values (None: runs of blanks).
    decimal_comma : bool
        Numbers are written with a decimal comma.
    skiprows : int
        Lines before the first data row (notes and the header).
    cells : tuple of str
        The header's cells as written.
    ignored : tuple of str
        Cells that name no time, force or response quantity (a temperature, a trigger line, a
        tachometer): their columns are not read.
    usecols : tuple of int
        The file's columns that are read, in the order of ``names``.
    """

    names: tuple[str, ...]
    scales: tuple[float, ...]
    delimiter: str | None
    decimal_comma: bool
    skiprows: int
    cells: tuple[str, ...]
    ignored: tuple[str, ...] = ()
    usecols: tuple[int, ...] = ()

    @property
    def plain(self) -> bool:
        """True for the station's own format (comma, SI, no notes): read with no conversion."""
        return self.delimiter == "," and not self.decimal_comma and all(s == 1.0 for s in self.scales)

    def conversions(self) -> dict[str, str]:
        """``name -> "cell (x factor)"`` for each column converted to SI."""
        return {n: f"{c} (x{s:g})" for n, c, s in zip(self.names, self.cells, self.scales) if s != 1.0}


def sniff_delimiter(line: str) -> str | None:
    """The delimiter of a header line: tab, semicolon or comma (first found), else blanks (None)."""
    for d in ("\t", ";", ","):
        if d in line:
            return d
    return None


def _is_number(cell: str) -> bool:
    try:
        float(cell.replace(",", "."))
    except ValueError:
        return False
    return True


def unit_key(unit: str) -> str:
    """A unit as written, normalised for :data:`UNITS` (blanks out, lower case, ² -> ^2, µ -> u)."""
    u = unit.strip().replace("²", "^2").replace("**", "^").replace("µ", "u").replace("μ", "u")
    return re.sub(r"\s+", "", u).lower()


def column_name(cell: str, where: str) -> tuple[str, float]:
    """The station's name of one header cell and its factor to SI.

    Raises
    ------
    InputFileError
        Unknown quantity or unit, or a voltage.
    """
    text, unit = cell.strip(), None
    m = _UNIT.match(text)
    if m is not None:
        text, unit = m.group("name"), (m.group("a") if m.group("a") is not None else m.group("b"))
    key = re.sub(r"[\s\-]+", "_", text.strip().lower().replace(".", " ")).strip("_")  # "Disp." = "Disp"
    name = ALIASES.get(key)
    if name is None:
        s = _SUFFIXED.match(key)
        if s is None:
            raise InputFileError(
                f"{where}: unknown column {cell.strip()!r} in the header; expected names among t, force, acc, "
                "vel, disp or Time, Force, Acceleration, Velocity, Displacement, with a unit in brackets "
                "(several sensors: acc1, acc2, ... or acc_NAME)")
        stem = _SENSOR_STEMS[s.group(1)]
        name = f"{stem}{s.group(2)}" if s.group(2) is not None else f"{stem}_{s.group(3)}"
    quantity = name if name in UNITS else next(q for q in ("acc", "vel", "disp") if name.startswith(q))
    if unit is None or not unit.strip():
        return name, 1.0
    u = unit_key(unit)
    if u in ("v", "mv", "volt", "volts"):
        raise InputFileError(
            f"{where}: column {cell.strip()!r} is in volts: scale it to SI with the sensor's sensitivity "
            "first (the station reads physical units)")
    factor = UNITS[quantity].get(u)
    if factor is None:
        raise InputFileError(
            f"{where}: column {cell.strip()!r}: unknown unit {unit.strip()!r}; expected one of "
            f"{', '.join(sorted(UNITS[quantity]))}")
    return name, factor


def parse_header(lines: list[str], where: str) -> Header:
    """Read the header of a CSV from its first lines (notes ``#...``, the header, then data lines:
    a decimal comma is looked for in those given).

    Raises
    ------
    InputFileError
        Empty file, unknown column or unit.
    """
    i = 0
    while i < len(lines) and (not lines[i].strip() or lines[i].lstrip().startswith("#")):
        i += 1
    if i >= len(lines):
        raise InputFileError(f"{where}: empty file; expected a header naming columns t, acc, ...")
    header = lines[i].strip()
    delim = sniff_delimiter(header)
    cells = [c.strip().strip('"').strip("'") for c in (header.split(delim) if delim is not None else header.split())]
    if all(_is_number(c) for c in cells):
        raise InputFileError(
            f"{where}: no header: line {i + 1} holds numbers ({header[:40]!r}); expected a header naming the "
            "columns (t, force, acc, ...) before the data")
    skip = i + 1
    units = _units_row(lines, skip, delim, len(cells))
    if units is not None:  # a row of units under the names (a logger's export): joined to them
        skip, row = units
        cells = [_with_unit(c, u, where) for c, u in zip(cells, row)]
    parsed, ignored, usecols = [], [], []
    for k, c in enumerate(cells):
        if _other_quantity(c):
            ignored.append(c.strip())
            continue
        parsed.append(column_name(c, where))
        usecols.append(k)
    data = [ln for ln in lines[skip:] if ln.strip() and not ln.lstrip().startswith("#")]
    decimal_comma = delim in ("\t", ";", None) and any("," in ln for ln in data)
    return Header(names=tuple(n for n, _ in parsed), scales=tuple(s for _, s in parsed), delimiter=delim,
                  decimal_comma=decimal_comma, skiprows=skip, cells=tuple(c.strip() for c in cells),
                  ignored=tuple(ignored), usecols=tuple(usecols))


#: Every unit :data:`UNITS` knows, normalised (:func:`unit_key`), and the blank cell.
_ANY_UNIT = frozenset(u for q in UNITS.values() for u in q) | {"", "-"}


def _units_row(lines: list[str], start: int, delim: str | None, n: int) -> tuple[int, list[str]] | None:
    """``(lines to skip, the units)`` when the first line after the header is a row of units
    (``[s],[N],[m/s^2]`` or ``s;N;g``: no number, every cell a known unit or blank, as many cells
    as the header), else None."""
    j = start
    while j < len(lines) and (not lines[j].strip() or lines[j].lstrip().startswith("#")):
        j += 1
    if j >= len(lines):
        return None
    line = lines[j].strip()
    raw = line.split(delim) if delim is not None else line.split()
    row = [c.strip().strip('"').strip("'").strip() for c in raw]
    row = [c[1:-1].strip() if len(c) >= 2 and c[0] + c[-1] in ("[]", "()") else c for c in row]
    if len(row) != n or any(_is_number(c) for c in row if c):
        return None
    if not all(unit_key(c) in _ANY_UNIT or unit_key(c) in ("v", "mv", "volt", "volts") for c in row):
        return None
    return j + 1, row


def _with_unit(cell: str, unit: str, where: str) -> str:
    """A header cell with the unit its units row gives (the cell's own unit, when it has one,
    must be the same)."""
    if not unit or unit == "-":
        return cell
    m = _UNIT.match(cell.strip())
    if m is None:
        return f"{cell.strip()} [{unit}]"
    own = m.group("a") if m.group("a") is not None else m.group("b")
    if unit_key(own) != unit_key(unit):
        raise InputFileError(f"{where}: column {cell.strip()!r} has unit {own!r} in the header and {unit!r} in the "
                             "units row below it; expected one unit per column")
    return cell


#: Stems of header cells that name another quantity a DAQ logs beside the vibration (read past,
#: not refused: a lab's export often carries them): temperature, trigger or digital lines,
#: tachometer / speed, microphone / sound pressure, strain, voltage monitors, counters, comments.
_OTHER = re.compile(r"^(temp(erature)?|trig(ger)?|digital|di\d*|do\d*|tacho?(meter)?|rpm|speed|mic(rophone)?|"
                    r"sound|spl|pressure|strain|sg\d*|volt(age)?|counter|count|index|sample|samples|"
                    r"comment|notes?|marker|event|status|flag|channel_?\d*_?(unused|spare)|spare|unused)"
                    r"([\s_\-]*\d*)?(\s*[\[(].*[\])])?$", re.IGNORECASE)


def _other_quantity(cell: str) -> bool:
    """A header cell that names another logged quantity (:data:`_OTHER`), not a time, force or
    response channel: its column is read past, and said (``ignored``)."""
    return _OTHER.match(cell.strip()) is not None
