"""HDF5 capture files: one test session per file, many captures, one versioned schema.

The schema is documented in ``docs/capture-format.md``; this module is its reference
implementation (reading; appending is :mod:`station.session_writer`). In short::

    /                      attrs format="eddi-station-captures", format_version=2, ...
    /captures/0000/        attrs time base, t0 (wall clock of row 0), flags, drop statistics,
                           notes, mass_kg, source, session_index
    /captures/0000/channels/<name>   (n,) int32 counts (encoding="counts": SI = counts*scale+offset)
                                     or (n,) float64 SI values (encoding="si", imported data)
                                     attrs quantity, unit, scale, offset, ..., sensor, node, sha256
    /captures/0000/gaps    (k, 2) int64 (row, length) of missing samples
    /captures/0000/device  attrs model, serial, firmware, protocol_version, url
    /captures/0000/rig     attrs of the simulated rig (only for simulated captures)

Readers take the file's shared commit lock (:mod:`station.locks`) and finish a save a killed
writer left half-committed (:func:`station.journal.recover`) before they read.
:func:`iter_captures` streams captures one at a time (one in memory, the file open only while
one is read).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import hashlib
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Sequence

import h5py
import numpy as np

from drivers.channels import ChannelInfo
from station import journal
from station.errors import CaptureFormatError, InputFileError, StationError
from station.locks import FileLock

#: Value of the root attribute ``format``.
FORMAT_NAME = "eddi-station-captures"
#: Version of the schema this module writes (root attribute ``format_version``).
FORMAT_VERSION = 2
#: Versions this module reads (version 1 lacks the optional metadata of version 2).
READABLE_VERSIONS = (1, 2)
#: Quantity of a channel -> key of ``Measurement.channels``.
MEASUREMENT_KEYS: dict[str, str] = {"force": "force", "acceleration": "acc", "velocity": "vel", "displacement": "disp"}
#: Largest magnitude accepted for a stored or imported SI value (no sensor reads 1e12 N, m/s^2, m/s or m).
MAX_SI_MAGNITUDE = 1e12

_CHANNEL_ATTRS = ("quantity", "unit", "scale", "offset", "range_si", "adc_bits", "sensitivity", "sensitivity_unit")
_COMPRESSION: dict[str, Any] = {"compression": "gzip", "compression_opts": 4, "shuffle": True}


def __getattr__(name: str) -> Any:  # the writer lives in station.session_writer (imports this module)
    if name in ("CaptureWriter", "StorageError", "import_measurement"):
        from station import session_writer

        return getattr(session_writer, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def attr_value(v: Any) -> Any:
    """A value as a typed HDF5 attribute: bool, int64, float64 or str; dict/list as JSON text; None skipped."""
    if v is None:
        return None
    if isinstance(v, (bool, np.bool_)):
        return np.bool_(v)
    if isinstance(v, (int, np.integer)):
        return np.int64(v)
    if isinstance(v, (float, np.floating)):
        return np.float64(v)
    if isinstance(v, str):
        return v
    if isinstance(v, np.ndarray):
        return v
    return json.dumps(v, default=str)


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def sha256_of(data: np.ndarray) -> str:
    """SHA-256 of an array's little-endian bytes in C order (hex digest).

    Parameters
    ----------
    data : ndarray of int32 or float64
    """
    a = np.asarray(data)
    dt = "<i4" if a.dtype.kind in "iu" else "<f8"
    # hashed through the buffer protocol: the same bytes as ``.tobytes()`` without copying them
    return hashlib.sha256(memoryview(np.ascontiguousarray(a, dtype=dt)).cast("B")).hexdigest()


@dataclass(frozen=True)
class ChannelData:
    """One stored channel.

    Attributes
    ----------
    info : ChannelInfo
    counts : ndarray of int32, shape (n,) or None
        Raw counts (``None`` for imported SI data).
    si : ndarray of float64, shape (n,)
        Values in SI units (``counts * scale + offset``); NaN where samples are missing.
    """

    info: ChannelInfo
    counts: np.ndarray | None
    si: np.ndarray
    attrs: dict[str, Any] = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class StoredCapture:
    """A capture read back from a file, checksums verified.

    Attributes
    ----------
    index : int
        Position in the file (0-based).
    rate_hz : float
        Sample rate [Hz].
    pretrigger_samples, trigger_sample, first_sample, n_samples : int
        Time base: row ``pretrigger_samples`` is absolute sample ``trigger_sample``.
    channels : dict of str to ChannelData
        In stored order.
    double_hit, overload, partial : bool
    overload_channels : tuple of str
    gaps : ndarray of int64, shape (k, 2)
        ``(row, length)`` of missing samples.
    dropped_samples : int
    mass_kg : float or None
    notes, source : str
    device : dict
    rig : dict or None
    attrs : dict
        Every attribute of the capture group as stored.
    """

    index: int
    rate_hz: float
    pretrigger_samples: int
    trigger_sample: int
    first_sample: int
    n_samples: int
    channels: dict[str, ChannelData]
    double_hit: bool
    overload: bool
    partial: bool
    overload_channels: tuple[str, ...]
    gaps: np.ndarray
    dropped_samples: int
    mass_kg: float | None
    notes: str
    source: str
    device: dict[str, Any]
    rig: dict[str, Any] | None
    attrs: dict[str, Any] = field(repr=False)

    @property
    def t(self) -> np.ndarray:
        """Time of each row from the first sample, shape (n,) [s]."""
        return np.arange(self.n_samples) / self.rate_hz


@dataclass(frozen=True)
class CaptureSummary:
    """One line of a file listing."""

    index: int
    n_samples: int
    rate_hz: float
    trigger_time_s: float
    double_hit: bool
    overload: bool
    partial: bool
    dropped_samples: int
    notes: str


# ------------------------------------------------------------------------------------ reading
def _check_root(f: h5py.File, p: Path) -> None:
    """Refuse a foreign file, an unknown version or a ``/captures`` that is not a group."""
    fmt = f.attrs.get("format")
    if isinstance(fmt, bytes):
        fmt = fmt.decode()
    if fmt != FORMAT_NAME:
        raise CaptureFormatError(f"capture file {p}: expected root attribute format={FORMAT_NAME!r}, got {fmt!r} (foreign HDF5 file)")
    raw = _decode(f.attrs.get("format_version"))
    try:
        version = int(raw)
    except (TypeError, ValueError):
        version = None
    if version not in READABLE_VERSIONS:
        raise CaptureFormatError(f"capture file {p}: expected format_version in {list(READABLE_VERSIONS)}, got {raw!r}")
    caps = f.get("captures", getlink=False) if "captures" in f else None
    if not isinstance(caps, h5py.Group):
        found = "none" if caps is None else f"a {type(caps).__name__.lower()}"
        raise CaptureFormatError(f"capture file {p}: expected a /captures group, found {found}")


@contextlib.contextmanager
def _open(path: str | os.PathLike[str]) -> Iterator[h5py.File]:
    """Open a capture file for reading under its shared commit lock (a dead writer's save finished first)."""
    p = Path(path)
    if not p.exists():
        raise InputFileError(f"capture file {p}: no such file")
    if not p.is_file():
        raise InputFileError(f"capture file {p}: expected a file, got a directory or device")
    for _ in range(3):
        with FileLock(p, exclusive=False):
            # checked under the shared lock: a writer that died mid-commit left its journal
            if not journal.journal_path(p).exists():
                try:
                    f = h5py.File(p, "r")
                except OSError as exc:
                    first = str(exc).splitlines()[0] if str(exc) else "unreadable"
                    raise CaptureFormatError(f"capture file {p}: expected an HDF5 file, cannot open it ({first})") from None
                with f:
                    _check_root(f, p)
                    yield f
                return
        try:
            with FileLock(p, exclusive=True):
                journal.recover(p)
        except PermissionError:
            raise CaptureFormatError(f"capture file {p}: a save was interrupted; open it once with write "
                                     "permission to finish it") from None
    raise CaptureFormatError(f"capture file {p}: a save is being finished by another process; try again")


def check_file(path: str | os.PathLike[str]) -> int:
    """Check that ``path`` is a capture file of this schema; return its number of captures."""
    with _open(path) as f:
        return len(f["captures"])


def _decode(v: Any) -> Any:
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.generic):
        return v.item()
    return v


def _resolve(f: h5py.File, path: Path, capture: int | str | None) -> tuple[int, h5py.Group]:
    caps = f["captures"]
    names = sorted(caps.keys())
    n = len(names)
    if n == 0:
        raise InputFileError(f"capture file {path}: holds no capture")
    if capture is None or capture == "":
        idx = 0
    else:
        try:
            idx = int(capture)
        except (TypeError, ValueError):
            raise InputFileError(f"capture {capture!r}: expected an index 0..{n - 1} (or -1 for the last)") from None
    if idx < 0:
        idx += n
    if not 0 <= idx < n:
        raise InputFileError(f"capture {capture}: expected an index 0..{n - 1}, the file {path.name} holds {n} capture(s)")
    g = caps[names[idx]]
    if not isinstance(g, h5py.Group):
        raise CaptureFormatError(f"capture {idx} of {path}: /captures/{names[idx]} is a {type(g).__name__.lower()}, "
                                 "expected a group (damaged file)")
    return idx, g


def list_captures(path: str | os.PathLike[str]) -> list[CaptureSummary]:
    """Summaries of every capture in the file, in order."""
    out = []
    with _open(path) as f:
        for i, name in enumerate(sorted(f["captures"].keys())):
            a = {k: _decode(v) for k, v in f["captures"][name].attrs.items()}
            out.append(
                CaptureSummary(
                    index=i,
                    n_samples=int(a.get("n_samples", 0)),
                    rate_hz=float(a.get("rate_hz", 0.0)),
                    trigger_time_s=float(a.get("trigger_time_s", 0.0)),
                    double_hit=bool(a.get("double_hit", False)),
                    overload=bool(a.get("overload", False)),
                    partial=bool(a.get("partial", False)),
                    dropped_samples=int(a.get("dropped_samples", 0)),
                    notes=str(a.get("notes", "")),
                )
            )
    return out


def read_capture(path: str | os.PathLike[str], capture: int | str | None = None, verify: bool = True) -> StoredCapture:
    """Read one capture (default: the first), verifying checksums.

    Parameters
    ----------
    path : str or Path
    capture : int or str, optional
        0-based index (negative counts from the end) or its text.
    verify : bool
        Check every channel's SHA-256 (raises :class:`CaptureFormatError` on mismatch).
    """
    p = Path(path)
    with _open(p) as f:
        idx, g = _resolve(f, p, capture)
        try:
            return _read_group(p, idx, g, verify)
        except (KeyError, ValueError, TypeError, OSError, AttributeError, IndexError) as exc:
            if isinstance(exc, StationError):
                raise
            raise CaptureFormatError(f"capture {idx} of {p}: damaged or incomplete ({exc})") from None


def _read_group(p: Path, idx: int, g: h5py.Group, verify: bool) -> StoredCapture:
    a = {k: _decode(v) for k, v in g.attrs.items()}
    rate, n = float(a["rate_hz"]), int(a["n_samples"])
    if not (math.isfinite(rate) and rate > 0):
        raise CaptureFormatError(f"capture {idx} of {p}: sample rate {rate} Hz; expected a finite rate > 0")
    if n < 0:
        raise CaptureFormatError(f"capture {idx} of {p}: {n} samples; expected a count >= 0")
    order = json.loads(a["channel_order"])
    gaps = np.asarray(g["gaps"][()], dtype=np.int64).reshape(-1, 2)
    missing = np.zeros(int(a["n_samples"]), dtype=bool)
    for row, length in gaps:
        missing[row : row + length] = True
    channels: dict[str, ChannelData] = {}
    for name in order:
        ds = g["channels"][name]
        da = {k: _decode(v) for k, v in ds.attrs.items()}
        data = ds[()]
        if verify and sha256_of(data) != da["sha256"]:
            raise CaptureFormatError(f"capture {idx} of {p}: channel {name!r} fails its SHA-256 check (data damaged)")
        info = ChannelInfo(name=name, **{k: da[k] for k in _CHANNEL_ATTRS})
        if da["encoding"] == "counts":
            counts = np.asarray(data, dtype=np.int32)
            si = info.to_si(counts)
            si[missing] = np.nan
        elif da["encoding"] == "si":
            counts, si = None, np.asarray(data, dtype=np.float64)
        else:
            raise CaptureFormatError(f"capture {idx} of {p}: channel {name!r} encoding expected 'counts' or 'si', got {da['encoding']!r}")
        if si.shape != (int(a["n_samples"]),):
            raise CaptureFormatError(f"capture {idx} of {p}: channel {name!r} expected {a['n_samples']} samples, got {si.shape}")
        channels[name] = ChannelData(info, counts, si, da)
    mass = float(a.get("mass_kg", float("nan")))
    dev = {k: _decode(v) for k, v in g["device"].attrs.items()} if "device" in g else {}
    rig = {k: _decode(v) for k, v in g["rig"].attrs.items()} if "rig" in g else None
    return StoredCapture(
        index=idx,
        rate_hz=float(a["rate_hz"]),
        pretrigger_samples=int(a["pretrigger_samples"]),
        trigger_sample=int(a["trigger_sample"]),
        first_sample=int(a["first_sample"]),
        n_samples=int(a["n_samples"]),
        channels=channels,
        double_hit=bool(a["double_hit"]),
        overload=bool(a["overload"]),
        partial=bool(a["partial"]),
        overload_channels=tuple(json.loads(a.get("overload_channels", "[]"))),
        gaps=gaps,
        dropped_samples=int(a["dropped_samples"]),
        mass_kg=None if not np.isfinite(mass) else mass,
        notes=str(a.get("notes", "")),
        source=str(a.get("source", "")),
        device=dev,
        rig=rig,
        attrs=a,
    )


def iter_captures(path: str | os.PathLike[str], indices: Sequence[int] | None = None,
                  verify: bool = True) -> Iterator[StoredCapture]:
    """Stream captures one at a time (default: all, in order), each read when it is asked for.

    Only one capture is in memory, and the file is open (and its shared lock held) only while
    that capture is read, so a writer can append between two of them.

    Parameters
    ----------
    path : str or Path
    indices : sequence of int, optional
        0-based indices (negative count from the end); all captures when None.
    verify : bool
        Check SHA-256 checksums.
    """
    if indices is None:
        indices = range(check_file(path))
    for i in indices:
        yield read_capture(path, i, verify)


def iter_measurements(path: str | os.PathLike[str], indices: Sequence[int] | None = None) -> Iterator[Any]:
    """Stream captures as :class:`station.readers.Measurement` (see :func:`iter_captures`)."""
    for cap in iter_captures(path, indices):
        yield measurement_of(cap, path)


def read_measurement(path: str | os.PathLike[str], capture: str | None = None) -> Any:
    """Read one capture as a :class:`station.readers.Measurement` (SI units, time from row 0).

    Channels are keyed by quantity (``force``, ``acc``, ``vel``, ``disp``); a capture with
    missing samples, or with values that are not finite or beyond :data:`MAX_SI_MAGNITUDE`,
    is refused.
    """
    return measurement_of(read_capture(path, capture), path)


def measurement_of(cap: StoredCapture, path: str | os.PathLike[str]) -> Any:
    """A stored capture as a :class:`station.readers.Measurement` (refusals as :func:`read_measurement`)."""
    from station.readers import Measurement  # station.readers dispatches .h5 files here

    if cap.dropped_samples:
        raise InputFileError(
            f"capture {cap.index} of {path}: {cap.dropped_samples} samples are missing (gaps at rows "
            f"{[int(r) for r, _ in cap.gaps]}); expected a complete record"
        )
    chans: dict[str, np.ndarray] = {}
    keys = [MEASUREMENT_KEYS.get(ch.info.quantity) for ch in cap.channels.values()]
    seen: dict[str, int] = {}
    for ch, key in zip(cap.channels.values(), keys):
        if key is not None and key != "force" and keys.count(key) > 1:
            # several sensors of one quantity (multi-DOF): acc1, acc2 ... or their own names
            seen[key] = seen.get(key, 0) + 1
            key = ch.info.name if multi_channel_name(ch.info.name, key) else f"{key}{seen[key]}"
        if key is not None and key not in chans:
            check_values(ch.si, f"capture {cap.index} of {path}: channel {ch.info.name!r}")
            chans[key] = ch.si
    if cap.n_samples < 2:
        raise InputFileError(f"capture {cap.index} of {path}: {cap.n_samples} sample(s); expected a record")
    for key, y in chans.items():  # a dead or unplugged sensor: refused as a text record's column is
        if key != "force" and not np.ptp(y) > 0:
            raise InputFileError(f"capture {cap.index} of {path}: channel {key!r} is constant ({y[0]:g}); "
                                 f"expected a measured response")
    meta = {
        "file": str(path),
        "capture": cap.index,
        "double_hit": cap.double_hit,
        "overload": cap.overload,
        "partial": cap.partial,
        "notes": cap.notes,
        "device": cap.device,
        "units": {MEASUREMENT_KEYS[c.info.quantity]: c.info.unit for c in cap.channels.values() if c.info.quantity in MEASUREMENT_KEYS},
        "sensitivities": {c.info.name: [c.info.sensitivity, c.info.sensitivity_unit] for c in cap.channels.values()},
    }
    if "adc_sinc_order" in cap.attrs:  # the DAQ's decimation filter (station import --adc-filter; 0: point samples)
        meta["adc_sinc_order"] = int(cap.attrs["adc_sinc_order"])
        meta["adc_osr"] = int(cap.attrs.get("adc_osr", 0) or 0)
    if float(cap.attrs.get("ac_coupling_s", 0) or 0) > 0:  # the accelerometer's AC coupling (import --sensor-highpass)
        meta["ac_coupling_s"] = float(cap.attrs["ac_coupling_s"])
    if cap.attrs.get("driving_point"):  # multi-DOF: the response channel at the hammer
        meta["driving_point"] = str(cap.attrs["driving_point"])
    t0 = float(cap.attrs.get("t0_s", 0.0))  # imported records keep their first time stamp
    return Measurement(
        t=t0 + cap.t,
        channels=chans,
        rate_hz=cap.rate_hz,
        pretrigger_samples=cap.pretrigger_samples if pretrigger_known(cap.attrs, cap.pretrigger_samples) else None,
        mass=cap.mass_kg,
        source=f"{path}:{cap.index}",
        metadata=meta,
    )



def pretrigger_known(attrs: Any, pretrigger_samples: int) -> bool:
    """Whether a capture's ``pretrigger_samples`` is known: ``pretrigger_known`` when stored;
    captures imported before that attribute existed (``import_metadata`` present) stored 0
    for "unknown" (a CSV does not say), so their 0 is unknown too."""
    known = attrs.get("pretrigger_known")
    if known is not None:
        return bool(int(known))
    return not ("import_metadata" in attrs and int(pretrigger_samples) == 0)


def check_values(x: np.ndarray, what: str) -> None:
    """Refuse NaN/inf and magnitudes beyond :data:`MAX_SI_MAGNITUDE` (one line naming the row)."""
    bad = np.flatnonzero(~(np.abs(x) <= MAX_SI_MAGNITUDE))
    if bad.size:
        i = int(bad[0])
        raise InputFileError(f"{what} holds {x[i]:g} at row {i}; expected finite values within "
                             f"+-{MAX_SI_MAGNITUDE:g} SI units (not a measurement)")


def multi_channel_name(name: str, key: str) -> bool:
    """True when ``name`` is a suffixed response channel of quantity ``key`` (``acc2``, ``acc_tip``)."""
    from station.readers import MULTI_COLUMN

    m = MULTI_COLUMN.match(name)
    return m is not None and m.group(1) == key
