"""HDF5 capture files: one test session per file, many captures, one versioned schema.

The schema is documented in ``docs/capture-format.md``; this module is its reference
implementation. In short::

    /                      attrs format="eddi-station-captures", format_version=1, ...
    /captures/0000/        attrs time base, flags, drop statistics, notes, mass_kg, source
    /captures/0000/channels/<name>   (n,) int32 counts (encoding="counts": SI = counts*scale+offset)
                                     or (n,) float64 SI values (encoding="si", imported data)
                                     attrs quantity, unit, scale, offset, ..., sha256
    /captures/0000/gaps    (k, 2) int64 (row, length) of missing samples
    /captures/0000/device  attrs model, serial, firmware, protocol_version, url
    /captures/0000/rig     attrs of the simulated rig (only for simulated captures)

Crash safety: the session file is never modified in place. Each save reads it into memory,
adds the capture there (h5py on a ``BytesIO``), writes the result to a temporary file beside
it with plain OS writes, ``fsync``s it, and atomically renames it over the original
(``os.replace``). A process killed at any moment
leaves either the old file or the new one, both complete; a stale temporary file is all that
can remain (removed by the next save). The price is one read and one write of the whole file per save (see
``benchmarks/bench_storage.py``).
"""

from __future__ import annotations

import datetime as _dt
import errno
import hashlib
import io
import json
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import h5py
import numpy as np

from drivers.channels import QUANTITY_UNITS, ChannelInfo
from station.errors import CaptureFormatError, InputFileError, StationError
from station.trigger import Capture

#: Value of the root attribute ``format``.
FORMAT_NAME = "eddi-station-captures"
#: Version of the schema this module writes (root attribute ``format_version``).
FORMAT_VERSION = 1
#: Quantity of a channel -> key of ``Measurement.channels``.
MEASUREMENT_KEYS: dict[str, str] = {"force": "force", "acceleration": "acc", "velocity": "vel", "displacement": "disp"}

_CHANNEL_ATTRS = ("quantity", "unit", "scale", "offset", "range_si", "adc_bits", "sensitivity", "sensitivity_unit")
_COMPRESSION: dict[str, Any] = {"compression": "gzip", "compression_opts": 4, "shuffle": True}


class StorageError(StationError, OSError):
    """Saving a capture failed (disk full, file too large, permission); earlier captures are intact."""


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
    return hashlib.sha256(np.ascontiguousarray(a, dtype=dt).tobytes()).hexdigest()


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


# ------------------------------------------------------------------------------------ writing
@dataclass(frozen=True)
class _Record:
    """What is written for one capture (internal)."""

    channels: tuple[ChannelInfo, ...]
    columns: tuple[np.ndarray, ...]  # int32 counts or float64 SI per channel
    encoding: str  # "counts" or "si"
    attrs: dict[str, Any]
    gaps: np.ndarray


def _record_from_capture(cap: Capture) -> _Record:
    attrs = {
        "rate_hz": float(cap.rate_hz),
        "n_samples": cap.n_samples,
        "pretrigger_samples": cap.pretrigger_samples,
        "trigger_sample": cap.trigger_sample,
        "first_sample": cap.first_sample,
        "trigger_time_s": cap.trigger_time_s,
        "double_hit": bool(cap.double_hit),
        "overload": bool(cap.overload),
        "overload_channels": json.dumps(list(cap.overload_channels)),
        "partial": bool(cap.partial),
        "dropped_samples": int(cap.dropped_samples),
    }
    gaps = np.asarray(cap.gaps, dtype=np.int64).reshape(-1, 2)
    cols = tuple(np.ascontiguousarray(cap.counts[:, j]) for j in range(len(cap.channels)))
    return _Record(tuple(cap.channels), cols, "counts", attrs, gaps)


def _write_record(f: h5py.File, rec: _Record, meta: Mapping[str, Any]) -> int:
    caps = f.require_group("captures")
    index = len(caps)
    g = caps.create_group(f"{index:04d}")
    for k, v in rec.attrs.items():
        g.attrs[k] = v
    g.attrs["index"] = index
    g.attrs["saved_utc"] = _now()
    g.attrs["channel_order"] = json.dumps([c.name for c in rec.channels])
    g.attrs["checksum_algorithm"] = "sha256"
    mass = meta.get("mass_kg")
    g.attrs["mass_kg"] = float("nan") if mass is None else float(mass)
    g.attrs["notes"] = str(meta.get("notes") or "")
    g.attrs["source"] = str(meta.get("source") or "")
    g.attrs["dropped_before_total"] = int(meta.get("dropped_before_total") or 0)
    for k, v in (meta.get("extra") or {}).items():
        g.attrs[k] = v
    chg = g.create_group("channels")
    for info, col in zip(rec.channels, rec.columns):
        ds = chg.create_dataset(info.name, data=col, **_COMPRESSION)
        ds.attrs["encoding"] = rec.encoding
        for a in _CHANNEL_ATTRS:
            ds.attrs[a] = getattr(info, a)
        ds.attrs["sha256"] = sha256_of(col)
    g.create_dataset("gaps", data=rec.gaps.astype(np.int64).reshape(-1, 2))
    dev = g.create_group("device")
    for k, v in (meta.get("device") or {}).items():
        dev.attrs[k] = v if isinstance(v, (int, float, str, bool)) else json.dumps(v)
    rig = meta.get("rig")
    if rig is not None:
        rg = g.create_group("rig")
        for k, v in rig.items():
            rg.attrs[k] = v if isinstance(v, (int, float, str, bool)) else json.dumps(v)
    caps.attrs["count"] = index + 1
    return index


def _new_file(target: Any, session: Mapping[str, Any]) -> None:
    with h5py.File(target, "w", libver="latest") as f:
        f.attrs["format"] = FORMAT_NAME
        f.attrs["format_version"] = FORMAT_VERSION
        f.attrs["created_utc"] = _now()
        f.attrs["software"] = "eddi-station"
        for k, v in session.items():
            f.attrs[k] = v if isinstance(v, (int, float, str, bool)) else json.dumps(v)
        f.create_group("captures").attrs["count"] = 0


def _write_bytes(path: Path, data: memoryview, chunk: int = 1 << 22) -> None:
    """Write ``data`` to a new file and ``fsync`` it (plain OS writes: errors are clean OSErrors)."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
    try:
        for i in range(0, len(data), chunk):
            view = data[i : i + chunk]
            while len(view):
                n = os.write(fd, view)
                view = view[n:]
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_path(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _storage_error(exc: BaseException, path: Path, what: str) -> StorageError:
    code = getattr(exc, "errno", None)
    text = str(exc)
    if code == errno.ENOSPC or "No space left" in text:
        reason = "disk full"
    elif code == errno.EFBIG or "File too large" in text:
        reason = "file size limit reached"
    elif code == errno.EACCES or "ermission denied" in text:
        reason = "permission denied"
    else:
        reason = text.splitlines()[0] if text else type(exc).__name__
    err = StorageError(f"cannot save {what} to {path}: {reason}; captures saved before are intact")
    err.errno = code if code is not None else errno.EIO
    return err


class CaptureWriter:
    """Appends captures to a session file, crash-safely (copy, fsync, atomic rename).

    Parameters
    ----------
    path : str or Path
        The session file. Created (with ``session`` attributes) if missing; an existing file
        must be a capture file of this schema, and new captures are appended to it.
    session : mapping, optional
        Root attributes for a new file (``bench_config`` JSON, ``session_notes``...).
    """

    def __init__(self, path: str | os.PathLike[str], session: Mapping[str, Any] | None = None) -> None:
        self.path = Path(path)
        self._session = dict(session or {})
        if self.path.exists():
            check_file(self.path)  # refuse to append to a foreign or damaged file
        elif not self.path.parent.is_dir():
            raise InputFileError(f"output file {self.path}: expected an existing directory {self.path.parent}")
        self._remove_stale_temporaries()

    def _tmp_path(self) -> Path:
        return self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")

    def _remove_stale_temporaries(self) -> None:
        pat = re.compile(rf"^\.{re.escape(self.path.name)}\.(\d+)\.tmp$")
        for p in self.path.parent.iterdir():
            m = pat.match(p.name)
            if not m:
                continue
            pid = int(m.group(1))
            alive = pid != os.getpid()
            if alive:
                try:
                    os.kill(pid, 0)
                except ProcessLookupError:
                    alive = False
                except PermissionError:
                    pass
            if not alive:
                p.unlink(missing_ok=True)

    @property
    def count(self) -> int:
        """Captures in the file now."""
        if not self.path.exists():
            return 0
        with _open(self.path) as f:
            return len(f["captures"])

    def append(self, capture: Capture, **meta: Any) -> int:
        """Save one trigger capture; return its index in the file.

        Parameters
        ----------
        capture : Capture
        **meta
            ``device`` (dict), ``rig`` (dict or None), ``notes`` (str), ``mass_kg`` (float),
            ``source`` (str), ``dropped_before_total`` (int), ``extra`` (dict of attributes).
        """
        return self._save(_record_from_capture(capture), meta)

    def append_si(
        self,
        values: Mapping[str, np.ndarray],
        rate_hz: float,
        pretrigger_samples: int = 0,
        **meta: Any,
    ) -> int:
        """Save imported data given in SI units (stored as float64, ``encoding="si"``).

        Parameters
        ----------
        values : mapping of str to ndarray, shape (n,)
            Keyed ``force``, ``acc``, ``vel`` or ``disp`` [N, m/s^2, m/s, m].
        rate_hz : float
            Sample rate [Hz].
        pretrigger_samples : int
            Rows before the trigger (0 when unknown).
        """
        quantities = {v: k for k, v in MEASUREMENT_KEYS.items()}
        infos, cols = [], []
        n = None
        for name, arr in values.items():
            base = next((k for k in ("acc", "vel", "disp") if _multi_name(name, k)), name)
            if base not in quantities:
                raise InputFileError(f"channel {name!r}: expected one of {sorted(quantities)} "
                                     "(or acc1, acc2 ... for several sensors)")
            a = np.ascontiguousarray(arr, dtype=np.float64)
            if n is not None and a.shape != (n,):
                raise InputFileError(f"channel {name!r}: expected {n} samples, got {a.shape}")
            n = a.shape[0]
            q = quantities[base]
            infos.append(ChannelInfo(name=name, quantity=q, unit=QUANTITY_UNITS[q], scale=1.0, adc_bits=0, sensitivity=0.0))
            cols.append(a)
        if n is None:
            raise InputFileError("import: expected at least one channel")
        if not 0 <= pretrigger_samples < n:
            raise InputFileError(f"pre-trigger samples: expected 0..{n - 1}, got {pretrigger_samples}")
        attrs = {
            "rate_hz": float(rate_hz),
            "n_samples": n,
            "pretrigger_samples": int(pretrigger_samples),
            "trigger_sample": int(pretrigger_samples),
            "first_sample": 0,
            "trigger_time_s": pretrigger_samples / float(rate_hz),
            "double_hit": False,
            "overload": False,
            "overload_channels": "[]",
            "partial": False,
            "dropped_samples": 0,
        }
        rec = _Record(tuple(infos), tuple(cols), "si", attrs, np.zeros((0, 2), dtype=np.int64))
        return self._save(rec, meta)

    def _save(self, rec: _Record, meta: Mapping[str, Any]) -> int:
        # The new version of the file is built in memory (HDF5 never meets a file-system
        # error half-way through its metadata), written to a temporary file with plain OS
        # writes and fsync, then renamed over the original: old or new file, never a mix.
        tmp = self._tmp_path()
        what = "a capture"
        try:
            buf = io.BytesIO(self.path.read_bytes()) if self.path.exists() else io.BytesIO()
            if not self.path.exists():
                _new_file(buf, self._session)
            with h5py.File(buf, "r+") as f:
                index = _write_record(f, rec, meta)
            what = f"capture {index}"
            _write_bytes(tmp, buf.getbuffer())
            os.replace(tmp, self.path)
            _fsync_path(self.path.parent)
        except (OSError, RuntimeError) as exc:
            tmp.unlink(missing_ok=True)
            if isinstance(exc, StationError):
                raise
            raise _storage_error(exc, self.path, what) from None
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        return index


# ------------------------------------------------------------------------------------ reading
def _open(path: str | os.PathLike[str]) -> h5py.File:
    p = Path(path)
    if not p.exists():
        raise InputFileError(f"capture file {p}: no such file")
    try:
        f = h5py.File(p, "r")
    except OSError as exc:
        first = str(exc).splitlines()[0] if str(exc) else "unreadable"
        raise CaptureFormatError(f"capture file {p}: expected an HDF5 file, cannot open it ({first})") from None
    fmt = f.attrs.get("format")
    if isinstance(fmt, bytes):
        fmt = fmt.decode()
    if fmt != FORMAT_NAME:
        f.close()
        raise CaptureFormatError(f"capture file {p}: expected root attribute format={FORMAT_NAME!r}, got {fmt!r} (foreign HDF5 file)")
    version = int(f.attrs.get("format_version", -1))
    if version != FORMAT_VERSION:
        f.close()
        raise CaptureFormatError(f"capture file {p}: expected format_version {FORMAT_VERSION}, got {version}")
    if "captures" not in f:
        f.close()
        raise CaptureFormatError(f"capture file {p}: expected a /captures group, found none")
    return f


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
    return idx, caps[names[idx]]


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
        except (KeyError, ValueError, TypeError, OSError) as exc:
            if isinstance(exc, StationError):
                raise
            raise CaptureFormatError(f"capture {idx} of {p}: damaged or incomplete ({exc})") from None


def _read_group(p: Path, idx: int, g: h5py.Group, verify: bool) -> StoredCapture:
    a = {k: _decode(v) for k, v in g.attrs.items()}
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
        channels[name] = ChannelData(info, counts, si)
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


def read_measurement(path: str | os.PathLike[str], capture: str | None = None) -> Any:
    """Read one capture as a :class:`station.readers.Measurement` (SI units, time from row 0).

    Channels are keyed by quantity (``force``, ``acc``, ``vel``, ``disp``); a capture with
    missing samples is refused (its time series has holes).
    """
    from station.readers import Measurement  # station.readers dispatches .h5 files here

    cap = read_capture(path, capture)
    if cap.dropped_samples:
        raise InputFileError(
            f"capture {cap.index} of {path}: {cap.dropped_samples} samples are missing (gaps at rows "
            f"{[int(r) for r, _ in cap.gaps]}); expected a complete record"
        )
    chans: dict[str, np.ndarray] = {}
    keys = [MEASUREMENT_KEYS.get(ch.info.quantity) for ch in cap.channels.values()]
    seen: dict[str, int] = {}
    for ch, key in zip(cap.channels.values(), keys):
        if key is None:
            continue
        if key != "force" and keys.count(key) > 1:  # several sensors of one quantity: acc1, acc2 ...
            seen[key] = seen.get(key, 0) + 1
            key = ch.info.name if _multi_name(ch.info.name, key) else f"{key}{seen[key]}"
        if key not in chans:
            chans[key] = ch.si
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
    t0 = float(cap.attrs.get("t0_s", 0.0))  # imported records keep their first time stamp
    return Measurement(
        t=t0 + cap.t,
        channels=chans,
        rate_hz=cap.rate_hz,
        pretrigger_samples=cap.pretrigger_samples,
        mass=cap.mass_kg,
        source=f"{path}:{cap.index}",
        metadata=meta,
    )


def _multi_name(name: str, key: str) -> bool:
    """True when ``name`` is a suffixed response channel of quantity ``key`` (``acc2``)."""
    from station.readers import MULTI_COLUMN

    m = MULTI_COLUMN.match(name)
    return m is not None and m.group(1) == key


def import_measurement(writer: CaptureWriter, measurement: Any, notes: str = "") -> int:
    """Append a :class:`station.readers.Measurement` (e.g. read from CSV) as an SI capture.

    Parameters
    ----------
    writer : CaptureWriter
    measurement : Measurement
        ``t`` (n,) [s] uniform, ``channels`` keyed force/acc/vel/disp [SI], ``rate_hz``,
        ``pretrigger_samples``, ``mass`` [kg] or None, ``source``.

    Returns
    -------
    int
        Index of the new capture.
    """
    t = np.asarray(measurement.t, dtype=float)
    chans = {k: np.asarray(v, dtype=float) for k, v in measurement.channels.items() if v is not None}
    meta = dict(getattr(measurement, "metadata", None) or {})
    return writer.append_si(
        chans,
        rate_hz=float(measurement.rate_hz),
        pretrigger_samples=int(measurement.pretrigger_samples or 0),
        mass_kg=measurement.mass,
        source=str(measurement.source),
        notes=notes,
        extra={"t0_s": float(t[0]) if t.size else 0.0, "import_metadata": json.dumps(meta, default=str)},
    )
