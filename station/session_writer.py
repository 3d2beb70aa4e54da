"""Appending captures to a session file: one writer at a time, O(1) per save, crash-safe.

The schema is in ``docs/capture-format.md`` (reader: :mod:`station.storage`). A save

1. takes the file's writer lock (:class:`station.locks.WriterLock`; a second writer waits a
   bounded time, then is refused with one line: never two writers, never a lost save);
2. finishes any save a killed process left half-committed (:func:`station.journal.recover`);
3. lets h5py add the capture to an in-memory overlay of the file
   (:class:`station.journal.OverlayFile`): the file on disk is untouched;
4. commits: new bytes appended past the old end, then the few KB HDF5 changed in place go
   through a redo journal (:func:`station.journal.commit`), under the exclusive commit lock.

The cost is proportional to the new capture, not to the file (``benchmarks/bench_storage.py``).
A new file is built in memory and renamed into place (``os.replace``).
"""

from __future__ import annotations

import errno
import io
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping

import h5py
import numpy as np

from drivers.channels import QUANTITY_UNITS, ChannelInfo
from station import journal
from station.errors import InputFileError, StationError
from station.locks import FileLock, WriterLock, WRITER_WAIT_S
from station.storage import (
    _CHANNEL_ATTRS,
    _COMPRESSION,
    FORMAT_NAME,
    FORMAT_VERSION,
    MEASUREMENT_KEYS,
    _check_root,
    _now,
    attr_value,
    check_file,
    multi_channel_name,
    sha256_of,
)
from station.trigger import Capture

#: Per-channel sensor fields a save may carry (``sensors={name: {...}}``), with their types.
SENSOR_FIELDS: dict[str, type] = {"sensor_model": str, "sensor_serial": str, "calibration_date": str,
                                  "node": int, "direction": str}


class StorageError(StationError, OSError):
    """Saving a capture failed (disk full, file too large, permission); earlier captures are intact."""


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


def _set_attrs(obj: Any, items: Mapping[str, Any]) -> None:
    for k, v in items.items():
        v = attr_value(v)
        if v is not None:
            obj.attrs[k] = v


def _write_record(f: h5py.File, rec: _Record, meta: Mapping[str, Any]) -> int:
    caps = f["captures"]
    index = len(caps)
    g = caps.create_group(f"{index:04d}")
    _set_attrs(g, rec.attrs)
    g.attrs["index"] = index
    g.attrs["saved_utc"] = _now()
    g.attrs["channel_order"] = json.dumps([c.name for c in rec.channels])
    g.attrs["checksum_algorithm"] = "sha256"
    mass = meta.get("mass_kg")
    g.attrs["mass_kg"] = float("nan") if mass is None else float(mass)
    g.attrs["notes"] = str(meta.get("notes") or "")
    g.attrs["source"] = str(meta.get("source") or "")
    g.attrs["dropped_before_total"] = int(meta.get("dropped_before_total") or 0)
    g.attrs["session_index"] = int(meta.get("session_index") or 0)
    t0 = meta.get("t0_unix_s")
    if t0 is not None and np.isfinite(t0):
        import datetime as _dt

        g.attrs["t0_unix_s"] = float(t0)
        g.attrs["t0_utc"] = _dt.datetime.fromtimestamp(float(t0), _dt.timezone.utc).isoformat(timespec="microseconds")
    _set_attrs(g, meta.get("extra") or {})
    sensors = meta.get("sensors") or {}
    chg = g.create_group("channels")
    for info, col in zip(rec.channels, rec.columns):
        ds = chg.create_dataset(info.name, data=col, **_COMPRESSION)
        ds.attrs["encoding"] = rec.encoding
        for a in _CHANNEL_ATTRS:
            ds.attrs[a] = getattr(info, a)
        for k, typ in SENSOR_FIELDS.items():
            v = (sensors.get(info.name) or {}).get(k)
            if v is not None:
                ds.attrs[k] = typ(v)
        ds.attrs["sha256"] = sha256_of(col)
    g.create_dataset("gaps", data=rec.gaps.astype(np.int64).reshape(-1, 2))
    _set_attrs(g.create_group("device"), meta.get("device") or {})
    rig = meta.get("rig")
    if rig is not None:
        _set_attrs(g.create_group("rig"), rig)
    caps.attrs["count"] = index + 1
    return index


def _new_file(target: Any, session: Mapping[str, Any]) -> None:
    with h5py.File(target, "w", libver="latest") as f:
        f.attrs["format"] = FORMAT_NAME
        f.attrs["format_version"] = FORMAT_VERSION
        f.attrs["created_utc"] = _now()
        f.attrs["software"] = "eddi-station"
        _set_attrs(f, session)
        f.create_group("captures").attrs["count"] = 0


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


#: A consistency check run under the lock before a save: ``check(file, record_attrs)``; raises to
#: refuse the capture, or returns attributes to set on it (e.g. ``session_index``).
Check = Callable[[h5py.File, Mapping[str, Any]], "Mapping[str, Any] | None"]


class CaptureWriter:
    """Appends captures to a session file: one writer at a time, crash-safe, O(1) per save.

    Parameters
    ----------
    path : str or Path
        The session file. Created (with ``session`` attributes) if missing; an existing file
        must be a capture file of this schema, and new captures are appended to it.
    session : mapping, optional
        Root attributes for a new file (``bench_config`` JSON, ``session_notes``...).
    lock_wait_s : float
        Longest wait for another writer of the same file [s]; then :class:`LockTimeout`.
    """

    def __init__(self, path: str | os.PathLike[str], session: Mapping[str, Any] | None = None,
                 lock_wait_s: float = WRITER_WAIT_S) -> None:
        self.path = Path(path)
        self._session = dict(session or {})
        if self.path.exists():
            check_file(self.path)  # refuse to append to a foreign or damaged file
        elif not self.path.parent.is_dir():
            raise InputFileError(f"output file {self.path}: expected an existing directory {self.path.parent}")
        self._lock = WriterLock(self.path, lock_wait_s)
        #: Test hooks: step name -> callable, run at that step of a commit (journal.commit).
        self.hooks: dict[str, Callable[[], None]] = {}
        self._remove_stale_temporaries()

    # -- the writer lock
    def hold(self) -> "CaptureWriter":
        """Keep the writer lock until :meth:`close` (a whole acquisition run); waits like a save."""
        self._lock.acquire()
        return self

    def close(self) -> None:
        """Release a lock taken by :meth:`hold`."""
        self._lock.release()

    def __enter__(self) -> "CaptureWriter":
        return self.hold()

    def __exit__(self, *exc: object) -> None:
        self.close()

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
        return check_file(self.path) if self.path.exists() else 0

    def append(self, capture: Capture, *, check: Check | None = None, **meta: Any) -> int:
        """Save one trigger capture; return its index in the file.

        Parameters
        ----------
        capture : Capture
        check : callable, optional
            Run under the lock with the open file and the new capture's attributes; raises to refuse.
        **meta
            ``device`` (dict), ``rig`` (dict or None), ``notes`` (str), ``mass_kg`` (float),
            ``source`` (str), ``dropped_before_total`` (int), ``t0_unix_s`` (float, wall-clock
            time of row 0 [s since 1970 UTC]), ``sensors`` ({channel: {sensor_model, ...}}),
            ``session_index`` (int), ``extra`` (dict of attributes).
        """
        return self._save(_record_from_capture(capture), meta, check)

    def append_si(
        self,
        values: Mapping[str, np.ndarray],
        rate_hz: float,
        pretrigger_samples: int = 0,
        *,
        check: Check | None = None,
        **meta: Any,
    ) -> int:
        """Save imported data given in SI units (stored as float64, ``encoding="si"``).

        Parameters
        ----------
        values : mapping of str to ndarray, shape (n,)
            Keyed ``force``, ``acc``, ``vel`` or ``disp`` [N, m/s^2, m/s, m].
        rate_hz : float
            Sample rate [Hz], finite and > 0.
        pretrigger_samples : int
            Rows before the trigger (0 when unknown).
        """
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise InputFileError(f"sample rate: expected a finite rate > 0 Hz, got {rate_hz}")
        quantities = {v: k for k, v in MEASUREMENT_KEYS.items()}
        infos, cols = [], []
        n = None
        for name, arr in values.items():
            base = next((k for k in ("acc", "vel", "disp") if multi_channel_name(name, k)), name)
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
        return self._save(rec, meta, check)

    def _save(self, rec: _Record, meta: Mapping[str, Any], check: Check | None) -> int:
        what = "a capture"
        with self._lock:
            try:
                if not self.path.exists():
                    return self._create(rec, meta, check)
                with FileLock(self.path, exclusive=True):
                    journal.recover(self.path)
                overlay = journal.OverlayFile(self.path)
                try:
                    with h5py.File(overlay, "r+", libver="latest") as f:
                        _check_root(f, self.path)
                        attrs = {**rec.attrs, **meta, "channels": [c.name for c in rec.channels]}
                        if check is not None:
                            meta = {**meta, **(check(f, attrs) or {})}
                        index = _write_record(f, rec, meta)
                    what = f"capture {index}"
                    with FileLock(self.path, exclusive=True):
                        journal.commit(self.path, overlay, self.hooks)
                finally:
                    overlay.close()
            except (OSError, RuntimeError) as exc:
                if isinstance(exc, StationError):
                    raise
                raise _storage_error(exc, self.path, what) from None
        return index

    def _create(self, rec: _Record, meta: Mapping[str, Any], check: Check | None) -> int:
        # a new file: built in memory, written beside, fsync'ed and renamed into place
        tmp = self._tmp_path()
        try:
            buf = io.BytesIO()
            _new_file(buf, self._session)
            with h5py.File(buf, "r+") as f:
                if check is not None:
                    meta = {**meta, **(check(f, {**rec.attrs, **meta, "channels": [c.name for c in rec.channels]}) or {})}
                index = _write_record(f, rec, meta)
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            try:
                journal.pwrite_all(fd, buf.getbuffer(), 0)
                os.fsync(fd)
            finally:
                os.close(fd)
            os.replace(tmp, self.path)
            journal.fsync_dir(self.path)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        return index


def import_measurement(writer: CaptureWriter, measurement: Any, notes: str = "",
                       check: Check | None = None, session_index: int = 0) -> int:
    """Append a :class:`station.readers.Measurement` (e.g. read from CSV) as an SI capture.

    Parameters
    ----------
    writer : CaptureWriter
    measurement : Measurement
        ``t`` (n,) [s] uniform, ``channels`` keyed force/acc/vel/disp [SI], ``rate_hz``,
        ``pretrigger_samples``, ``mass`` [kg] or None, ``source``.
    check : callable, optional
        Consistency check run under the writer lock (see :meth:`CaptureWriter.append`).

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
        check=check,
        mass_kg=measurement.mass,
        source=str(measurement.source),
        notes=notes,
        session_index=session_index,
        # a CSV says nothing of its pre-trigger: 0 is stored (the schema's integer) with
        # pretrigger_known 0, so the reader gives None (unknown) as the CSV reader does, and
        # the conditioning looks for the rest itself either way (same floor, same verdict)
        extra={"t0_s": float(t[0]) if t.size else 0.0, "import_metadata": json.dumps(meta, default=str),
               "pretrigger_known": int(measurement.pretrigger_samples is not None),
               **({"adc_sinc_order": int(meta["adc_sinc_order"]), "adc_osr": int(meta.get("adc_osr") or 0)}
                  if meta.get("adc_sinc_order") is not None else {}),  # 0: point samples, stated
               **({"ac_coupling_s": float(meta["ac_coupling_s"])} if meta.get("ac_coupling_s") else {})},
    )


def disagreement(last: Mapping[str, Any], rate_hz: float, mass_kg: float | None, channels: list[str]) -> str | None:
    """How a new record disagrees with the last capture's attributes (rate, mass, channels), or None.

    Rates and masses agree within a relative 1e-9; an unknown mass agrees with any.
    """
    old_rate = float(last["rate_hz"])
    if abs(float(rate_hz) - old_rate) > 1e-9 * old_rate:
        return f"rate {float(rate_hz):g} Hz disagrees with the session's {old_rate:g} Hz"
    old_mass = float(last.get("mass_kg", float("nan")))
    if mass_kg is not None and np.isfinite(old_mass) and abs(float(mass_kg) - old_mass) > 1e-9 * old_mass:
        return f"mass {float(mass_kg):g} kg disagrees with the session's {old_mass:g} kg"
    old = json.loads(last["channel_order"])
    if sorted(channels) != sorted(old):
        return f"channels {','.join(channels)} disagree with the session's ({','.join(old)})"
    return None


def last_capture_attrs(path: Path) -> dict[str, Any] | None:
    """Attributes of the last capture of an existing session file (None: no file or no capture)."""
    from station.storage import _decode, _open

    if not Path(path).exists():
        return None
    with _open(path) as f:
        caps = f["captures"]
        if len(caps) == 0:
            return None
        return {k: _decode(v) for k, v in caps[sorted(caps.keys())[-1]].attrs.items()}


def same_session_check(path: Path, new_session: bool = False, verify: bool = True) -> Check:
    """A :data:`Check` refusing a record that disagrees with the file's last capture.

    Rate (relative 1e-9), mass (when both are known, relative 1e-9) and the channel names
    must agree; with ``new_session`` the record starts a new session in the file instead
    (its ``session_index`` is one more than the last capture's); with ``verify`` False the
    record joins the last capture's session unchecked (the later records of a ``--new-session``).
    """

    def check(f: h5py.File, new: Mapping[str, Any]) -> Mapping[str, Any] | None:
        caps = f["captures"]
        if len(caps) == 0:
            return None
        last = caps[sorted(caps.keys())[-1]].attrs
        session = int(last.get("session_index", 0))
        if new_session:
            return {"session_index": session + 1}
        if not verify:
            return {"session_index": session}
        problem = disagreement(last, float(new["rate_hz"]), new.get("mass_kg"), list(new["channels"]))
        if problem is not None:
            raise InputFileError(f"{new.get('source', 'record')}: {problem} in {path} (capture {len(caps) - 1}); "
                                 "use --new-session to store it as a new session")
        return {"session_index": session}

    return check
