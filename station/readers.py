"""Reading measurements from files, chosen by file suffix.

:func:`read_measurement` takes ``FILE`` or ``FILE:CAPTURE`` and dispatches on the suffix of
``FILE`` through :data:`READERS`, an immutable mapping ``suffix -> "module:function"``. Each
reader is called as ``function(path, capture)`` and returns a :class:`Measurement` in SI
units. ``.csv`` (``.tsv``, ``.txt``) is read here (:func:`read_csv`); ``.h5`` / ``.hdf5`` captures are
read by ``station.storage.read_measurement``, ``.uff`` / ``.unv`` by ``station.uff_reader.read_uff``,
``.mat`` by ``station.mat_reader.read_mat``.

CSV format: a header line naming the columns among ``t``, ``force``, ``acc``, ``vel``,
``disp`` (SI units: s, N, m/s^2, m/s, m), then one row per sample, comma-separated, uniform
sampling. Other tools' exports are read too (:mod:`station.csv_header`: tab, semicolon or blank
delimiters, a decimal comma, ``#`` notes before the header, names such as ``Time [s]`` or
``Acceleration (g)`` with their units converted to SI; ``.tsv`` and ``.txt`` files alike).
``.uff`` / ``.unv`` time responses (UFF58) are read by :func:`station.uff_reader.read_uff`. At least ``t`` and one of ``acc``, ``vel``, ``disp``. Several response channels
(several sensors) are named by a quantity and a suffix: ``acc1, acc2, ...`` or
``acc_tip, vel_root`` (:data:`MULTI_COLUMN`); :func:`response_channels` lists them.
"""

from __future__ import annotations

import importlib
import io
import sys
import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from station.csv_header import Header, parse_header
from station.errors import InputFileError

#: Reader of each file suffix, as ``"module:function"``.
READERS: Mapping[str, str] = MappingProxyType({
    ".csv": "station.readers:read_csv",
    ".tsv": "station.readers:read_csv",
    ".txt": "station.readers:read_csv",
    ".uff": "station.uff_reader:read_uff",
    ".unv": "station.uff_reader:read_uff",
    ".mat": "station.mat_reader:read_mat",
    ".h5": "station.storage:read_measurement",
    ".hdf5": "station.storage:read_measurement",
})

#: Columns a CSV may hold, with their units.
CSV_COLUMNS: Mapping[str, str] = MappingProxyType(
    {"t": "s", "force": "N", "acc": "m/s^2", "vel": "m/s", "disp": "m"}
)
RESPONSE_CHANNELS = ("acc", "vel", "disp")
#: Largest magnitude of a measured value [SI]; beyond it the file is not a measurement.
MAX_VALUE = 1e12
#: Largest time stamp [s] (about 31 years).
MAX_TIME_S = 1e9
#: Lines read to find the header (notes ``#...``, the header, one data line).
HEADER_LINES = 64
#: Largest CSV read by the compiled pass (:func:`_plain_columns`; 1 GiB: ~27 M rows of t,force,acc).
MAX_PASS_BYTES = 1 << 30
#: Fewest samples a record may hold.
MIN_SAMPLES = 16
#: A response column of a multi-sensor record: a quantity and a suffix (``acc2``, ``vel_tip``).
MULTI_COLUMN = re.compile(r"^(acc|vel|disp)(?:[0-9]+|_[a-z0-9_]+)$")


def is_multichannel_record(meas: Measurement) -> bool:
    """True when a record has several response sensors (suffixed names: ``acc1, acc2, ...``).

    Plain ``acc`` / ``vel`` / ``disp`` side by side are one coordinate measured several ways.
    """
    resp = response_channels(meas.channels)
    return len(resp) > 1 and any(name not in RESPONSE_CHANNELS for name in resp)


def require_one_coordinate(meas: Measurement, command: str) -> None:
    """Refuse a multi-sensor record on a one-coordinate command, saying what to use instead.

    Raises
    ------
    InputFileError
        When ``meas`` has several response sensors.
    """
    if is_multichannel_record(meas):
        names = ", ".join(response_channels(meas.channels))
        raise InputFileError(
            f"{meas.source}: {len(response_channels(meas.channels))} response sensors ({names}); "
            f"`station {command}` identifies one coordinate: use `station diagnose` on these captures for "
            f"the coupled multi-DOF model (no mass needed) and `station validate MODEL.json` to score it")


def response_channels(channels: Mapping[str, np.ndarray]) -> dict[str, tuple[str, np.ndarray]]:
    """Response channels of a record, in order: ``name -> (quantity, samples)``.

    ``quantity`` is ``acc``, ``vel`` or ``disp``; plain ``acc`` and suffixed names
    (``acc1``, ``acc_tip``) both count. Force and time are left out.
    """
    out: dict[str, tuple[str, np.ndarray]] = {}
    for name, y in channels.items():
        if name in RESPONSE_CHANNELS:
            out[name] = (name, y)
        else:
            m = MULTI_COLUMN.match(name)
            if m is not None:
                out[name] = (m.group(1), y)
    return out


@dataclass(frozen=True)
class Measurement:
    """One measured record in SI units.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
        Uniform, increasing.
    channels : mapping of str to ndarray, shape (n,)
        Among ``force`` [N], ``acc`` [m/s^2], ``vel`` [m/s], ``disp`` [m].
    rate_hz : float
    pretrigger_samples : int or None
        Samples before the trigger, when the file says.
    mass : float or None
        Mass of the structure [kg], when the file says.
    source : str
        Where it came from (``file`` or ``file:capture``).
    metadata : dict
        Anything else the file holds.
    """

    t: np.ndarray
    channels: Mapping[str, np.ndarray]
    rate_hz: float
    pretrigger_samples: int | None
    mass: float | None
    source: str
    metadata: dict[str, Any] = field(default_factory=dict)


def split_spec(spec: str) -> tuple[Path, str | None]:
    """``FILE[:CAPTURE]`` -> (path, capture or None). A name that exists as a file wins."""
    path = Path(spec)
    if path.exists() or ":" not in spec:
        return path, None
    head, _, tail = spec.rpartition(":")
    return Path(head), (tail or None)


def read_measurement(spec: str) -> Measurement:
    """Read ``FILE`` or ``FILE:CAPTURE`` with the reader of its suffix.

    Raises
    ------
    InputFileError
        Unknown suffix, missing file, missing reader module, or bad content (one line).
    """
    path, capture = split_spec(spec)
    suffix = path.suffix.lower()
    target = READERS.get(suffix)
    if target is None:
        raise InputFileError(
            f"{path}: unknown file type {suffix or '(none)'!r}; expected one of {', '.join(READERS)}"
        )
    if path.is_dir():
        raise InputFileError(f"{path}: is a folder; expected a {suffix} file")
    if not path.is_file():
        raise InputFileError(f"{path}: no such file")
    module_name, _, func_name = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError:
        raise InputFileError(
            f"{path}: cannot read {suffix} files here (reader {target} is not installed)"
        ) from None
    reader = getattr(module, func_name, None)
    if reader is None:
        raise InputFileError(f"{path}: cannot read {suffix} files here (reader {target} is missing)")
    return reader(path, capture)


def read_csv(path: str | Path, capture: str | None = None) -> Measurement:
    """Read a CSV measurement (see the module docstring for the format).

    Parameters
    ----------
    path : str or Path
    capture : str, optional
        Must be None (a CSV holds one record).

    Raises
    ------
    InputFileError
        Empty file, unknown or missing columns, ragged rows, text in a number, NaN (column
        and line named), non-uniform or non-increasing time, a clipped channel.
    """
    path = Path(path)
    if capture is not None:
        raise InputFileError(f"{path}: a CSV file holds one record; got capture {capture!r}")
    enc = text_encoding(path)
    try:
        with open(path, encoding=enc) as fh:
            head = [fh.readline() for _ in range(HEADER_LINES)]
        hdr = parse_header(head, str(path))
        names = list(hdr.names)
        _check_header(path, names, hdr.ignored)
        columns = _plain_columns(path, hdr, enc)
        if columns is None:
            columns = _loadtxt_columns(path, hdr, names, enc)
    except UnicodeDecodeError:
        what = "UTF-8" if enc == "utf-8-sig" else f"{enc.upper()} (its byte-order mark says so)"
        raise InputFileError(f"{path}: not a text CSV file (not valid {what} text)") from None
    cols = dict(zip(names, columns))
    for name, scale in zip(names, hdr.scales):
        if scale != 1.0:  # a unit the header names (csv_header.UNITS); SI columns stay untouched
            cols[name] = cols[name] * scale
    if hdr.ignored:
        note(f"{path}: read past column{'s' if len(hdr.ignored) > 1 else ''} "
             f"{', '.join(repr(c) for c in hdr.ignored)} (not a time, force or response channel)")
    skip = hdr.skiprows
    meta = {"format": "csv", "columns": names,
            **({"header": list(hdr.cells), "converted": hdr.conversions()} if not hdr.plain else {}),
            **({"ignored_columns": list(hdr.ignored)} if hdr.ignored else {})}
    return checked_measurement(cols, str(path), lambda i: f"line {i + skip + 1} (data row {i + 1})",
                               lambda i: f"from line {i + skip + 1}", meta)


#: Byte-order marks of the Unicode texts a CSV is read in besides UTF-8 (Excel's "Unicode text" export
#: is UTF-16 LE with its mark, tab-separated): the longer marks first (UTF-32 LE's starts as UTF-16 LE's).
UNICODE_BOMS = ((b"\xff\xfe\x00\x00", "utf-32"), (b"\x00\x00\xfe\xff", "utf-32"),
                (b"\xff\xfe", "utf-16"), (b"\xfe\xff", "utf-16"))


def text_encoding(path: Path) -> str:
    """The encoding a CSV is read in: UTF-16 or UTF-32 when the file starts with their byte-order
    mark, else UTF-8 (with or without its mark).

    Raises
    ------
    InputFileError
        UTF-16 without a byte-order mark (a zero byte beside each of the first characters): which
        byte order it is cannot be told for sure, said in one line.
    """
    with open(path, "rb") as fh:
        head = fh.read(8)
    for bom, enc in UNICODE_BOMS:
        if head.startswith(bom):
            return enc
    text = set(range(32, 127)) | {9, 10, 13}
    if len(head) == 8 and any(not any(head[z::2]) and set(head[1 - z::2]) <= text for z in (0, 1)):
        raise InputFileError(f"{path}: looks like UTF-16 text without a byte-order mark; save it as UTF-8 "
                             "(or as Unicode text, which starts with the mark)")
    return "utf-8-sig"


def _plain_columns(path: Path, hdr: Header, enc: str = "utf-8-sig") -> np.ndarray | None:
    """The data rows as an array of shape (columns, rows) by one compiled pass over the file's
    bytes (:func:`eddi.decimal_text.parse_columns`: the same float64 values as ``numpy.loadtxt``,
    bit for bit, in about half its CPU), or None when the file is not plain numbers between one
    delimiter (blanks, quotes, comments, a decimal comma, columns read past, ``nan``) or the pass
    is not built ahead of time: :func:`_loadtxt_columns` then reads it, and names any bad row.
    Files above :data:`MAX_PASS_BYTES` too (the pass holds the whole text in memory beside the
    array; ``loadtxt`` reads in chunks)."""
    if hdr.delimiter is None or hdr.decimal_comma or hdr.ignored or len(hdr.cells) != len(hdr.names):
        return None
    if path.stat().st_size > MAX_PASS_BYTES:
        return None
    from eddi.decimal_text import data_start, parse_columns

    raw = path.read_bytes()
    if enc != "utf-8-sig":  # UTF-16/32 (text_encoding): the same text in UTF-8, whose bytes the pass reads
        raw = raw.decode(enc).encode("utf-8")
    start = data_start(raw, hdr.skiprows)
    return None if start is None else parse_columns(raw, start, hdr.delimiter, len(hdr.names))


def _loadtxt_columns(path: Path, hdr: Header, names: list[str], enc: str = "utf-8-sig") -> np.ndarray:
    """The data rows by ``numpy.loadtxt``, as an array of shape (columns, rows) (each column
    contiguous), for any text the header allows.

    Raises
    ------
    InputFileError
        No data rows, a row of another length, text in a number (the line named).
    UnicodeDecodeError
        Not text in ``enc`` (:func:`text_encoding`).
    """
    try:  # numpy's C reader, given the path (~20 % faster than a file object): correctly rounded,
        # ~0.18 s for 2.6 M numbers (numba's compile of the hand-written parser it replaces cost
        # 1.1 s on a first run, its speed-up 0.1 s)
        with warnings.catch_warnings():  # "input contained no data": said below, in one line
            warnings.simplefilter("ignore", UserWarning)
            source: Any = path
            if hdr.decimal_comma:  # rare: a spreadsheet export; one copy of the text
                source = io.StringIO(path.read_text(encoding=enc).replace(",", "."))
            data = np.loadtxt(source, delimiter=hdr.delimiter, ndmin=2, dtype=float, skiprows=hdr.skiprows,
                              encoding=enc, quotechar='"', usecols=hdr.usecols if hdr.ignored else None)
    except ValueError as exc:
        raise InputFileError(f"{path}: {_row_problem(path, len(hdr.cells), exc, hdr, enc)}") from None
    if data.size == 0:
        raise InputFileError(f"{path}: no data rows after the header")
    if data.shape[1] != len(names):
        raise InputFileError(f"{path}: rows have {data.shape[1]} values, the header names {len(names)} columns")
    # one transposing copy (rows of it are the contiguous columns): 2.5x faster than a strided
    # copy per column
    return np.ascontiguousarray(data.T)


_NOTED: set[str] = set()


def note(text: str) -> None:
    """Say something about a file that is read all the same, once per process, on stderr
    (``station: note: ...``; stdout keeps the result and the JSON)."""
    if text not in _NOTED:
        _NOTED.add(text)
        print(f"station: note: {text}", file=sys.stderr)


def unit_of(name: str) -> str:
    """SI unit of a column (``acc2`` -> m/s^2)."""
    if name in CSV_COLUMNS:
        return CSV_COLUMNS[name]
    m = MULTI_COLUMN.match(name)
    return CSV_COLUMNS[m.group(1)] if m is not None else ""


def checked_measurement(cols: dict[str, np.ndarray], where: str, at: Any, since: Any,
                        metadata: dict[str, Any]) -> Measurement:
    """A record's columns (``t`` and the channels, SI) checked and made a :class:`Measurement`.

    ``at(i)`` / ``since(i)`` say where sample ``i`` is in the file (``line 9 (data row 8)``,
    ``from line 9``). Every text or array reader ends here, so that all refuse alike.

    Raises
    ------
    InputFileError
        A value not finite or beyond :data:`MAX_VALUE` (:data:`MAX_TIME_S`), a time that is not a
        uniform grid, a force with no impact, a constant response, a clipped channel.
    """
    for name, col in cols.items():
        limit = MAX_TIME_S if name == "t" else MAX_VALUE
        ok = np.abs(col) <= limit
        if not ok.all():
            i = int(np.flatnonzero(~ok)[0])
            what = "not a finite number" if not np.isfinite(col[i]) else f"{col[i]:g}, beyond +-{limit:g} {unit_of(name)}"
            raise InputFileError(f"{where}: column {name!r} is {what} at {at(i)}")
    rate, t = time_grid(cols.pop("t"), where)
    cols, metadata = _one_sensor(cols, metadata)
    if "force" in cols:
        check_force_impact(cols["force"], f"{where}: column 'force'")
        from station.swapped_channels import check_swapped_channels

        check_swapped_channels(cols, {n: a for n, (_q, a) in response_channels(cols).items()}, where, rate)
    for name in response_channels(cols):  # every sensor of a multi-channel record too
        if not np.ptp(cols[name]) > 0:
            raise InputFileError(f"{where}: column {name!r} is constant ({cols[name][0]:g}); expected a measured "
                                 "response")
    from eddi.conditioning import clip_on_blow, clipped_run  # local: the engine (scipy) only once a file is read

    for name, col in cols.items():
        c = clipped_run(col)
        on_blow = clip_on_blow(col, cols.get("force"), c) if c is not None and name != "force" else None
        if on_blow is not None:  # read; the impulse check and diagnose name the overload
            note(f"{where}: column {name!r} is flat at its extreme value {col[c]:g} for {on_blow} samples "
                 f"{since(c)}, during the hammer blow: overloaded by the blow (the free response after it "
                 "is used; the impulse check and the force-driven validation cannot trust the blow)")
        elif c is not None:
            raise InputFileError(
                f"{where}: column {name!r} looks clipped: flat at its extreme value {col[c]:g} "
                f"{since(c)}; expected a signal within the sensor's range"
            )
    for name in response_channels(cols):
        cols[name] = _filled_dropouts(cols[name], f"{where}: column {name!r}", since)
    return Measurement(t=t, channels=MappingProxyType(cols), rate_hz=rate, pretrigger_samples=None, mass=None,
                       source=where, metadata=metadata)


#: Longest run of dropped samples filled, and the largest share of a channel's samples.
MAX_DROPOUT_RUN = 8
MAX_DROPOUT_SHARE = 0.05


def _filled_dropouts(col: np.ndarray, what: str, since: Callable[[int], str]) -> np.ndarray:
    """A response channel with its dropouts (:func:`eddi.conditioning.dropout_runs`: exact zeros
    amid the motion) filled from a cubic through the samples either side, with a note; refused
    when a run is longer than :data:`MAX_DROPOUT_RUN` samples or the runs hold more than
    :data:`MAX_DROPOUT_SHARE` of the samples. Left in, 12 zeros in a 709-sample velocity record
    read as a poor fit with an x^3 59 % off and nothing naming them (blind unseen11 I3)."""
    from eddi.calculus import fill_gaps
    from eddi.conditioning import dropout_runs

    runs = dropout_runs(col)
    if not runs:
        return col
    lengths = [b - a for a, b in runs]
    total = sum(lengths)
    said = (f"{what} reads exactly 0 for {total} sample{'s' if total > 1 else ''} in {len(runs)} "
            f"run{'s' if len(runs) > 1 else ''} amid the motion (the first {since(runs[0][0])}, the longest "
            f"{max(lengths)} samples): the sensor lost its signal (a laser vibrometer's dropouts)")
    if max(lengths) > MAX_DROPOUT_RUN or total > MAX_DROPOUT_SHARE * col.size:
        raise InputFileError(f"{said}; too many to fill (at most {MAX_DROPOUT_RUN} samples a run and "
                             f"{100 * MAX_DROPOUT_SHARE:g} % of the record): re-measure or cut the record")
    bad = np.zeros(col.size, dtype=bool)
    for a, b in runs:
        bad[a:b] = True
    note(f"{said}; filled from a cubic through the samples either side")
    return fill_gaps(col, bad)


def _one_sensor(cols: dict[str, np.ndarray], metadata: dict[str, Any]) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """A record with ONE response channel named with a sensor suffix (``Accel 1 (g)`` ->
    ``acc1``, ``acc_tip``) is that quantity's record: the channel is read as ``acc`` (``vel``,
    ``disp``), and the metadata says so (``renamed``). Several stay several (multi-DOF)."""
    resp = [n for n in cols if n in RESPONSE_CHANNELS or MULTI_COLUMN.match(n)]
    if len(resp) != 1 or resp[0] in RESPONSE_CHANNELS:
        return cols, metadata
    m = MULTI_COLUMN.match(resp[0])
    assert m is not None
    stem = m.group(1)
    return ({(stem if n == resp[0] else n): v for n, v in cols.items()},
            {**metadata, "renamed": {resp[0]: stem}})


def time_grid_rate(t: np.ndarray, where: str) -> float:
    """Sample rate [Hz] of a time column (see :func:`time_grid`)."""
    return time_grid(t, where)[0]


def time_grid(t: np.ndarray, where: str) -> tuple[float, np.ndarray]:
    """Sample rate [Hz] and uniform time vector of a time column, allowing the jitter of times
    printed with few digits.

    Returns ``t`` itself when it is within 1 % of a step of its grid; when the rounding
    allowance was needed, the least-squares grid ``t_mean + step * (i - (n - 1) / 2)`` that the
    rounded times stand for (so later stages see uniform sampling, as the device produced it).

    A time column is uniform when every ``t[i]`` is within a tolerance of the grid
    ``t[0] + i * step``, ``step = (t[-1] - t[0]) / (n - 1)``. The tolerance is 1 % of a step, or,
    when larger, the rounding the file's own precision explains: the number of significant
    digits ``S`` the times are printed with is found from the values, and each time may be off
    by half a unit of its last digit from the least-squares grid through all of them (whose
    step is then the rate's), allowed one unit of the last digit of the largest time. A 320 s record at 19.2 kHz printed with 9 digits
    (``320.000000``, rounding up to 5e-7 s = 1.1 % of a step) is accepted; a sample shifted by
    more than that, or times too coarse to tell
    samples apart (a unit of the last digit above half a step: a missing sample could no longer be
    told from the rounding) are refused; samples missing (a step of twice the others) are refused
    naming the gap.

    Raises
    ------
    InputFileError
        One line naming the first offending line of the file.
    """
    n = t.size
    if n < MIN_SAMPLES:
        raise InputFileError(f"{where}: {n} data rows; expected at least {MIN_SAMPLES}")
    dt = np.diff(t)
    if not np.all(dt > 0):
        i = int(np.nonzero(~(dt > 0))[0][0])
        raise InputFileError(f"{where}: time must increase; line {i + 3} has t = {t[i + 1]:.9g} after {t[i]:.9g}")
    step = (t[-1] - t[0]) / (n - 1)
    top = float(max(abs(t[0]), abs(t[-1])))  # t increases: the largest magnitude is at an end
    if 4 * np.spacing(top) > 1e-6 * step:
        raise InputFileError(f"{where}: time stamps near {top:.3g} s cannot resolve steps of {step:.3g} s in "
                             "double precision; expected times counted from the start of the record")
    dev = _grid_deviation(t, t[0], step, 0.0)
    if float(np.max(dev)) <= 0.01 * step:
        return 1.0 / step, t
    digits = _printed_digits(t)
    unit = 10.0 ** (math.floor(math.log10(top)) - digits + 1) if top > 0 else 0.0
    rounding = unit + 4 * np.finfo(float).eps * top  # t[i] and t[0] (the grid's origin) each off by unit / 2
    _refuse_gaps(dt, unit, where)
    if rounding > 0.5 * step:
        raise InputFileError(f"{where}: times are printed with {digits} significant digits, too few to tell "
                             f"samples {step:.3g} s apart; expected more digits in column 't'")
    # rounded times: the grid is the least-squares line through all of them (its slope is
    # sqrt(n) times less sensitive to rounding than the two end points)
    k = np.arange(n, dtype=float)
    k -= (n - 1) / 2.0
    mean = float(t.mean())
    step = float((np.dot(k, t) - mean * k.sum()) / np.dot(k, k))
    dev = _grid_deviation(t, mean, step, (n - 1) / 2.0)
    tol = max(0.01 * step, rounding)
    i = int(np.argmax(dev))
    if dev[i] > tol:
        raise InputFileError(
            f"{where}: time must be uniformly sampled; line {i + 2} has t = {t[i]:.12g} s, {dev[i]:.3g} s off the "
            f"grid of step {step:.6g} s (expected within {tol:.3g} s: 1 % of a step or "
            f"the rounding of {digits}-digit times)"
        )
    grid = np.arange(n, dtype=float)
    grid -= (n - 1) / 2.0
    grid *= step
    grid += mean
    return 1.0 / step, grid


def _refuse_gaps(dt: np.ndarray, unit: float, where: str) -> None:
    """Refuse a record with samples missing (a DAQ's dropped block), naming where and how many.

    A step between printed times is at most ``h + unit`` (``h`` the median step, ``unit`` the
    last printed digit's); a sample missing makes it at least ``2 h - unit``. A step beyond
    ``h + max(h / 2, unit)`` is a gap (times printed with a unit below half a step tell the two
    apart; coarser ones are refused as too coarse after this); a long step that a neighbouring
    short one makes up for is a sample shifted in time, left to the grid check."""
    h = float(np.median(dt))
    slack = max(0.5 * h, unit)
    # a long step whose neighbour makes up for it is a shifted sample (its two steps sum to 2 h;
    # refused by the grid check), not a gap (3 h)
    pair = np.full(dt.size, np.inf)
    pair[1:] = dt[1:] + dt[:-1]
    pair[:-1] = np.minimum(pair[:-1], dt[:-1] + dt[1:])
    gap = (dt > h + slack) & (pair > 2 * h + slack)
    big = np.nonzero(gap)[0]
    if not big.size:
        return
    i = int(big[0])
    h = float(np.mean(dt[dt <= h + slack]))  # the mean step (the median of rounded steps is one of their values)
    missing = int(round(dt[i] / h)) - 1
    more = f" (and {big.size - 1} more gaps)" if big.size > 1 else ""
    raise InputFileError(
        f"{where}: samples missing: the time jumps {dt[i]:.4g} s at line {i + 3} where a step is {h:.4g} s "
        f"(about {max(missing, 1)} samples dropped{more}); expected a record without gaps (export the "
        "block again, or cut the record at the gap)")


def check_force_impact(force: np.ndarray, where: str) -> None:
    """Refuse a force channel that holds no hammer blow (flat, or its peak within its noise).

    The peak of ``|force - median|`` must exceed 8 robust standard deviations (1.4826 MAD) of
    the channel, and be > 0: a Gaussian noise record of a million samples peaks near 5.

    Raises
    ------
    InputFileError
    """
    from eddi.median import median  # numpy.median's float by selection: ~5x faster on a long record

    f = np.asarray(force, dtype=float)
    centred = np.abs(f - median(f))
    peak = float(np.max(centred)) if f.size else 0.0
    noise = 1.4826 * median(centred) if f.size else 0.0
    if not (peak > 0 and peak > 8 * noise):
        raise InputFileError(f"{where} holds no impact (peak {peak:.3g} above its median, noise {noise:.3g}); "
                             "expected a hammer blow, or leave the force channel out for a free ring-down")


def _grid_deviation(t: np.ndarray, origin: float, step: float, centre: float) -> np.ndarray:
    """``|t[i] - (origin + step * (i - centre))|`` in place in one buffer (long records: 6 M rows)."""
    g = np.arange(t.size, dtype=float)
    g -= centre
    g *= step
    g += origin
    g -= t
    return np.abs(g, out=g)


def _printed_digits(t: np.ndarray, sample: int = 2000) -> int:
    """Fewest significant digits that reproduce (a sample of) the values exactly (1..17)."""
    idx = np.unique(np.linspace(0, t.size - 1, min(sample, t.size)).astype(int))
    vals = [float(v) for v in t[idx]]
    for s in range(1, 18):
        if all(float(f"{v:.{s}g}") == v for v in vals):
            return s
    return 17


def _check_header(path: Path, names: list[str], ignored: Sequence[str] = ()) -> None:
    """The columns a record needs, each once (names as :func:`station.csv_header.parse_header` gives;
    ``ignored``: the cells it read past, named when no response is left)."""
    if len(set(names)) != len(names):
        raise InputFileError(f"{path}: a column is named twice in the header {','.join(names)}")
    if "t" not in names:
        raise InputFileError(f"{path}: no time column 't' in the header {','.join(names)}")
    if not any(n in RESPONSE_CHANNELS or MULTI_COLUMN.match(n) for n in names):
        past = f" (read past: {', '.join(repr(c) for c in ignored)})" if ignored else ""
        raise InputFileError(
            f"{path}: no response column in the header {','.join(names)}{past}; expected one of acc, vel, disp"
        )


def _row_problem(path: Path, n_cols: int, exc: ValueError, hdr: Header, enc: str = "utf-8-sig") -> str:
    """Find the first bad data row (slow path, only on error)."""
    with open(path, encoding=enc) as fh:
        for _ in range(hdr.skiprows):
            fh.readline()
        for line_no, line in enumerate(fh, start=hdr.skiprows + 1):
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            if hdr.decimal_comma:
                line = line.replace(",", ".")
            parts = line.strip().split(hdr.delimiter)
            if len(parts) != n_cols:
                return f"line {line_no} has {len(parts)} values, expected {n_cols} like the header"
            for k, p in enumerate(parts):
                if hdr.ignored and k not in hdr.usecols:
                    continue  # a column read past (csv_header._other_quantity): any text
                try:
                    float(p)
                except ValueError:
                    return f"line {line_no}: {p.strip()!r} is not a number"
    return f"cannot read the data: {exc}"
