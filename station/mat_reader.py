"""Reading a record from a MATLAB file (``.mat``: version 5 through scipy.io, 7.3 through h5py).

A lab's scripts save a ring-down as variables: ``t`` (or ``time``), ``force``, ``acc`` (or
``acceleration``, ``vel``, ...), or a sample rate (``fs``, ``Fs``, ``rate``, ``sample_rate``
[Hz]) or step (``dt`` [s]) instead of a time vector. Names are read as a CSV header's
(:func:`station.csv_header.column_name`: the same spellings; values in SI, as MATLAB has no
units); a matrix of one quantity with one column per sensor (``acc`` of n x 3) is three sensors
``acc1..acc3``. The variables of one struct (``rec.t``, ``rec.acc``) are one record:
``FILE.mat:rec`` chooses it (a file of one struct, or of plain variables, needs no choice).
Variables that name no quantity (notes, settings) are left out and listed in the metadata
(``ignored``). A DAQ that saves raw converter counts saves each channel's scale beside it: a
variable ``<name>_scale`` (or ``_gain``, ``_factor``) and optionally ``<name>_offset`` turns the
channel into ``raw * scale + offset`` (the NI / LabVIEW convention; listed in the metadata as
``scaled``); a channel of integer counts with no scale is refused (its unit is unknown: read as
SI it gave a 6x wrong mass and a cubic 100 % off on a blind record). Refusals are one line, as for a CSV (:func:`station.readers.checked_measurement`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import numpy as np

from station.csv_header import column_name
from station.errors import InputFileError

#: Scalar variables that give the sample rate [Hz] or step [s] when there is no time vector.
RATE_NAMES = ("fs", "rate", "sample_rate", "sampling_rate", "samplerate", "sampling_frequency")
STEP_NAMES = ("dt", "ts", "sample_time")
#: Suffixes of a channel's scale (multiplied) and offset (added after) for raw counts.
SCALE_SUFFIXES = ("_scale", "_gain", "_factor")
OFFSET_SUFFIXES = ("_offset",)


def _load(path: Path) -> dict[str, Any]:
    import h5py
    import scipy.io

    if h5py.is_hdf5(str(path)):  # version 7.3 (MATLAB writes a 512-byte user block before the HDF5)
        return _load_v73(path)
    try:
        raw = scipy.io.loadmat(str(path), squeeze_me=True, simplify_cells=True)
        return {k: v for k, v in raw.items() if not k.startswith("__")}
    except NotImplementedError:  # version 7.3: an HDF5 file
        return _load_v73(path)
    except Exception as exc:  # scipy's MatReadError (an Exception), ValueError, OSError...: one line
        first = str(exc).splitlines()[0][:100] if str(exc) else type(exc).__name__
        raise InputFileError(f"{path}: not a readable MATLAB file ({first})") from None


def _load_v73(path: Path) -> dict[str, Any]:
    import h5py

    def walk(group: Any) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for k, v in group.items():
            if k.startswith("#"):
                continue
            out[k] = walk(v) if isinstance(v, h5py.Group) else np.asarray(v[()])
        return out

    try:
        with h5py.File(path, "r") as fh:
            return walk(fh)
    except (OSError, KeyError, TypeError, ValueError) as exc:
        raise InputFileError(f"{path}: not a readable MATLAB file ({exc})") from None


def _record_vars(data: Mapping[str, Any], capture: str | None, path: Path) -> tuple[str, Mapping[str, Any]]:
    structs = {k: v for k, v in data.items() if isinstance(v, dict)}
    if capture is not None:
        if capture not in structs:
            raise InputFileError(f"{path}: no struct {capture!r}; the file holds "
                                 f"{', '.join(sorted(structs)) or 'no struct'}")
        return f"{path}:{capture}", structs[capture]
    plain = {k: v for k, v in data.items() if not isinstance(v, dict)}
    if any(_quantity(k) for k in plain):
        return str(path), plain
    if len(structs) == 1:
        (name, rec), = structs.items()
        return f"{path}:{name}", rec
    if structs:
        raise InputFileError(f"{path}: {len(structs)} structs ({', '.join(sorted(structs))}); choose one as "
                             f"{path.name}:NAME")
    raise InputFileError(f"{path}: no variable names a time, force or response channel (found "
                         f"{', '.join(sorted(data)) or 'nothing'})")


def _quantity(name: str) -> str | None:
    """The channel a variable names; one-letter names other than ``t`` name none in a MATLAB
    file (``x``, ``d``, ``a`` are as often loop data as displacement or acceleration)."""
    if len(name) == 1 and name.lower() != "t":
        return None
    try:
        return column_name(name, "")[0]
    except InputFileError:
        return None


def _scalar(value: Any, key: str, where: str) -> float:
    """A sample rate or step variable as a number: MATLAB keeps scalars as 1 x 1 matrices (a
    -v7.3 file read through h5py gives ``[[500.]]``, which numpy 2 will not turn into a float)."""
    arr = np.asarray(value)
    if arr.dtype.kind not in "iuf" or arr.size != 1:
        what = f"{arr.size} values" if arr.dtype.kind in "iuf" else f"a {arr.dtype.kind!r}-kind value"
        raise InputFileError(f"{where}: variable {key!r} should be one number (the sample rate [Hz] or "
                             f"step [s]); it holds {what}")
    return float(arr.reshape(-1)[0])


def _scaled(key: str, arr: np.ndarray, lower: Mapping[str, Any], where: str, scaled: list[str]) -> np.ndarray:
    """``arr`` (variable ``key``) in SI: ``raw * scale + offset`` when the record holds the
    channel's scale (module notes); integer counts without one are refused."""
    scale_key = next((key.lower() + s for s in SCALE_SUFFIXES if key.lower() + s in lower), None)
    offset_key = next((key.lower() + s for s in OFFSET_SUFFIXES if key.lower() + s in lower), None)
    if scale_key is None and offset_key is None:
        if arr.dtype.kind in "iu":
            raise InputFileError(f"{where}: variable {key!r} holds integer counts ({arr.dtype}) and the file gives "
                                 f"no scale for them ({key}_scale, {key}_gain or {key}_factor [SI unit per count]): "
                                 "its unit is unknown; save it in SI or with its scale")
        return arr.astype(np.float64)
    scale = _scalar(lower[scale_key], scale_key, where) if scale_key else 1.0
    offset = _scalar(lower[offset_key], offset_key, where) if offset_key else 0.0
    if not (np.isfinite(scale) and np.isfinite(offset)) or scale == 0.0:
        raise InputFileError(f"{where}: the scale of {key!r} ({scale_key or offset_key}) is {scale:g}: expected a finite, "
                             "non-zero number [SI unit per count]")
    scaled.extend(k for k in (scale_key, offset_key) if k)
    return arr.astype(np.float64) * scale + offset


def read_mat(path: str | Path, capture: str | None = None) -> Any:
    """Read one record of a MATLAB file as a :class:`station.readers.Measurement` (module notes).

    Raises
    ------
    InputFileError
        Not a MATLAB file, no response variable, vectors of different lengths, no time and no
        rate, several structs and none chosen, and every refusal of a CSV's values.
    """
    from station.readers import checked_measurement

    path = Path(path)
    where, rec = _record_vars(_load(path), capture, path)
    lower = {k.lower(): v for k, v in rec.items()}
    cols: dict[str, np.ndarray] = {}
    ignored: list[str] = []
    scaled: list[str] = []
    for key, value in rec.items():
        name = _quantity(key)
        arr = np.asarray(value) if not isinstance(value, (dict, str)) else None
        if name is None or arr is None or arr.dtype.kind not in "iuf" or arr.size < 2:
            if key.lower() not in RATE_NAMES + STEP_NAMES:
                ignored.append(key)
            continue
        arr = arr.astype(np.float64) if name == "t" else _scaled(key, arr, lower, where, scaled)
        if arr.ndim == 2 and min(arr.shape) > 1 and name != "t":  # one column per sensor
            cols_of = arr if arr.shape[0] >= arr.shape[1] else arr.T
            for j in range(cols_of.shape[1]):
                cols[f"{name}{j + 1}"] = np.ascontiguousarray(cols_of[:, j])
        elif arr.ndim <= 2:
            cols[name] = np.ascontiguousarray(arr.ravel())
        else:
            raise InputFileError(f"{where}: variable {key!r} has {arr.ndim} dimensions; expected a vector")
    if not any(n != "t" and n != "force" for n in cols):
        raise InputFileError(f"{where}: no response variable (acc, vel or disp; found {', '.join(rec) or 'nothing'})")
    sizes = {n: c.size for n, c in cols.items()}
    if len(set(sizes.values())) > 1:
        raise InputFileError(f"{where}: vectors of different lengths ({', '.join(f'{n} {k}' for n, k in sizes.items())})")
    n = next(iter(sizes.values()))
    if "t" not in cols:
        rate = next((_scalar(lower[k], k, where) for k in RATE_NAMES if k in lower), None)
        step = next((_scalar(lower[k], k, where) for k in STEP_NAMES if k in lower), None)
        if rate is None and step is not None and step > 0:
            rate = 1.0 / step
        if rate is None or not np.isfinite(rate) or rate <= 0:
            raise InputFileError(f"{where}: no time vector (t, time) and no sample rate (fs, rate) or step (dt)")
        cols = {"t": np.arange(n) / rate, **cols}
    ignored = [k for k in ignored if k.lower() not in scaled]
    meta = {"format": "mat", "variables": list(cols), "ignored": ignored, "scaled": scaled}
    return checked_measurement(cols, where, lambda i: f"sample {i}", lambda i: f"from sample {i}", meta)
