"""Universal File Format dataset 58 export of captures (force and response time series).

Modal-analysis tools (pyuff, SDyPy, ME'scope, Simcenter Testlab...) read UFF58 *function at
nodal DOF* records. Each exported channel becomes one record:

============  ======================================================================
field         value
============  ======================================================================
func_type     1 (time response)
id1           ``"<file stem> capture <i> <channel>"``
id2           quantity and unit (``"force [N]"``)
load_case_id  capture index (0-based, as in the HDF5 file)
rsp_node/dir  the channel's ``node`` / ``direction`` (bench config, +X=1 +Y=2 +Z=3, negative
              reversed); 1 / +1 when the file has none (single point, single direction)
ref_node/dir  the force channel's node / direction (the driving point); 1 / +1 by default
abscissa      time [s] from the first sample, even spacing 1 / rate (spec type 17)
ordinate      SI values; spec type 13 force, 12 acceleration, 11 velocity, 8 displacement
============  ======================================================================

Records are written with :func:`pyuff.prepare_58` and :meth:`pyuff.UFF.write_sets`, binary
(float64) by default, ASCII on request.
"""

from __future__ import annotations

import contextlib
import errno
import os
from pathlib import Path
from typing import Iterable

import numpy as np
import pyuff

from station.errors import InputFileError, StationError
from station.storage import check_values, iter_captures, list_captures, pretrigger_known

#: UFF specific data type of each quantity (UFF58 record 8/9, field 1).
SPEC_DATA_TYPE: dict[str, int] = {"force": 13, "acceleration": 12, "velocity": 11, "displacement": 8}
#: Length and force exponents of each quantity's unit (record 9, fields 2-3).
UNIT_EXPONENTS: dict[str, tuple[int, int]] = {"force": (0, 1), "acceleration": (1, 0), "velocity": (1, 0), "displacement": (1, 0)}
_TIME = 17
#: UFF direction code of each bench-config direction.
DIRECTION_CODES: dict[str, int] = {"+X": 1, "+Y": 2, "+Z": 3, "-X": -1, "-Y": -2, "-Z": -3}


def _node_dir(attrs: dict) -> tuple[int, int]:
    """UFF node and direction of a channel (1, +1 when the file has none)."""
    node = int(attrs.get("node", 1))
    return node, DIRECTION_CODES.get(str(attrs.get("direction", "+X")), 1)


def export_uff58(
    h5_path: str | os.PathLike[str],
    out_path: str | os.PathLike[str],
    captures: Iterable[int] | None = None,
    quantities: tuple[str, ...] = ("force", "acceleration"),
    binary: bool = True,
) -> int:
    """Write the force and acceleration series of captures to a UFF58 file.

    Parameters
    ----------
    h5_path : str or Path
        Session file (:mod:`station.storage`).
    out_path : str or Path
        UFF file to create (replaced if present).
    captures : iterable of int, optional
        0-based capture indices; all captures when None.
    quantities : tuple of str
        Quantities to export (channels of other quantities are skipped).
    binary : bool
        Binary float64 records (exact) or ASCII (11 significant digits).

    Returns
    -------
    int
        Records written.

    Raises
    ------
    InputFileError
        A capture with missing samples, or no channel to export.
    """
    src = Path(h5_path)
    indices = list(captures) if captures is not None else [c.index for c in list_captures(src)]
    sets = []
    for cap in iter_captures(src, indices):  # one capture in memory at a time (plus the records)
        if cap.dropped_samples:
            raise InputFileError(f"capture {cap.index} of {src}: {cap.dropped_samples} samples missing; UFF58 needs a complete record")
        forces = [c for c in cap.channels.values() if c.info.quantity == "force"]
        ref_node, ref_dir = _node_dir(forces[0].attrs) if forces else (1, 1)
        for name, ch in cap.channels.items():
            q = ch.info.quantity
            if q not in quantities or q not in SPEC_DATA_TYPE:
                continue
            check_values(ch.si, f"capture {cap.index} of {src}: channel {name!r}")  # as every reader refuses
            length_exp, force_exp = UNIT_EXPONENTS[q]
            sets.append(
                pyuff.prepare_58(
                    binary=1 if binary else 0,
                    id1=f"{src.stem} capture {cap.index} {name}",
                    id2=f"{q} [{ch.info.unit}]",
                    id3=f"rate {cap.rate_hz:.17g} Hz, pretrigger "
                        + (f"{cap.pretrigger_samples} samples" if pretrigger_known(cap.attrs, cap.pretrigger_samples)
                           else "unknown"),
                    id4=str(cap.notes)[:80] or "NONE",
                    id5=str(cap.device.get("model", "")) or "NONE",
                    func_type=1,
                    load_case_id=cap.index,
                    rsp_ent_name=name,
                    rsp_node=_node_dir(ch.attrs)[0],
                    rsp_dir=_node_dir(ch.attrs)[1],
                    ref_ent_name="force",
                    ref_node=ref_node,
                    ref_dir=ref_dir,
                    abscissa_spacing=1,
                    abscissa_spec_data_type=_TIME,
                    abscissa_axis_units_lab="s",
                    ordinate_spec_data_type=SPEC_DATA_TYPE[q],
                    ordinate_len_unit_exp=length_exp,
                    ordinate_force_unit_exp=force_exp,
                    ordinate_axis_units_lab=ch.info.unit,
                    orddenom_spec_data_type=0,
                    data=np.asarray(ch.si, dtype=np.float64),
                    x=cap.t,
                )
            )
    if not sets:
        raise InputFileError(f"{src}: no {' or '.join(quantities)} channel to export")
    out = Path(out_path)
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")  # written beside, then renamed: never half a file
    try:
        tmp.unlink(missing_ok=True)
        pyuff.UFF(str(tmp)).write_sets(sets, mode="add")
        os.replace(tmp, out)
    except Exception as exc:  # noqa: BLE001 - pyuff wraps a full disk's OSError in a bare Exception
        with contextlib.suppress(OSError):  # a read-only folder refuses even this
            tmp.unlink(missing_ok=True)
        cause = exc if isinstance(exc, OSError) else exc.__context__
        if not isinstance(cause, OSError):
            raise
        what = "disk full" if cause.errno == errno.ENOSPC else (cause.strerror or str(cause))
        raise StationError(f"cannot write {out}: {what}") from None
    return len(sets)
