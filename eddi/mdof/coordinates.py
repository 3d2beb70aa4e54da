"""Which coordinates the equations are written in: the tail's linear modes, modal or physical.

Linear modes come from the low-amplitude tail (:func:`linear_modes`); :func:`choose_coordinates`
takes modal coordinates ``q = pinv(Psi) y`` when the shapes are well separated and span the
motion, :func:`modal_evidence` says whether the tail holds motion no linear mode describes, and
:func:`residue_masses` gives each modal coordinate its mass from the driving-point residue where
the records agree.

No I/O.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from eddi.mdof.early import era_windows
from eddi.mdof.modal import LinearModes
from eddi.mdof.records import ChannelRecord
from eddi.mdof.signals import EDGE_PERIODS


#: A mode beyond the channels counts (evidence of a motion no linear mode basis holds) when it
#: carries at least this share of the tails' modal energy.
EXTRA_MODE_SHARE = 0.02
#: A channel whose tail is at least this much unexplained by the linear modes (noise taken
#: off) moves in a way no linear mode describes.
UNEXPLAINED_TAIL = 0.5


def modal_evidence(modes: LinearModes, n_ch: int) -> str:
    """``"basis"``, ``"missing_mode"`` or ``"unresolved"``: what the tail's modes say.

    ``missing_mode`` needs positive evidence: more modes than channels that each carry at least
    :data:`EXTRA_MODE_SHARE` of the tails' energy, or a channel whose tail is at least
    :data:`UNEXPLAINED_TAIL` unexplained. Fewer modes than channels otherwise is
    ``unresolved`` (a mode the records do not resolve above their noise, not a missing one).
    """
    share = modes.energy_share if modes.energy_share.size == modes.frequencies_hz.size else \
        np.ones(modes.frequencies_hz.size)
    strong = int(np.sum(share >= EXTRA_MODE_SHARE))
    unexplained = float(np.max(modes.unexplained)) if modes.unexplained.size else 0.0
    if strong > n_ch or unexplained >= UNEXPLAINED_TAIL:
        return "missing_mode"
    if modes.frequencies_hz.size < n_ch:
        return "unresolved"
    return "basis"


#: The last :func:`linear_modes` call: its records' arrays (compared by identity) and settings,
#: and its result. One identification asks for the modes of the same records up to eleven times
#: (every candidate, and again on the records with the quasi-static part restored, which changes
#: ``x`` and ``v`` but not the accelerations and force ERA reads): 5 s of a 35 s fold, session 10.
_LAST: list = []


def linear_modes(records: Sequence[ChannelRecord], *, tail_fraction: float = 0.2,
                 max_freq_hz: float | None = None, driving_point: int = 0) -> LinearModes:
    """ERA on the low-amplitude tail of the measured accelerations of every record, plus the modes
    only earlier windows hold (:func:`eddi.mdof.early.era_windows`). The same records' arrays and
    settings as the last call: its result again (the same computation)."""
    key = (tuple((r.window, r.impact, r.highpass_hz, r.t.size, float(r.t[1] - r.t[0])) for r in records),
           tail_fraction, max_freq_hz, driving_point)
    arrays = [(r.a, r.force) for r in records]
    if _LAST and _LAST[0] == key and len(_LAST[1]) == len(arrays) and all(
            a is b and f is g for (a, f), (b, g) in zip(arrays, _LAST[1])):
        return _LAST[2]
    modes = _linear_modes(records, tail_fraction=tail_fraction, max_freq_hz=max_freq_hz, driving_point=driving_point)
    _LAST[:] = [key, arrays, modes]
    return modes


def _linear_modes(records: Sequence[ChannelRecord], *, tail_fraction: float, max_freq_hz: float | None,
                  driving_point: int) -> LinearModes:
    rate = 1.0 / float(records[0].t[1] - records[0].t[0])
    forces = None
    if all(r.force is not None and r.impact[1] > r.impact[0] for r in records):
        forces = []
        for r in records:
            f = np.zeros_like(r.force)
            f[r.impact[0]:r.impact[1]] = r.force[r.impact[0]:r.impact[1]]
            forces.append(f)
    return era_windows([(r.a, r.window[0], _acc_stop(r, rate)) for r in records], rate, tail_fraction=tail_fraction,
                       max_freq_hz=max_freq_hz or 0.2 * rate, driving_point=driving_point, forces=forces)


def _acc_stop(r: ChannelRecord, rate: float) -> int:
    """End of the free response in the measured accelerations: the record's end where the window
    stops only for the drift filter's end transient (:data:`eddi.mdof.signals.EDGE_PERIODS`: it
    is in ``x`` and ``v``, not in the unfiltered ``a`` ERA reads), else the window's end."""
    edge = r.t.size - int(EDGE_PERIODS * rate / r.highpass_hz)
    return r.t.size if r.window[1] >= edge - 2 else r.window[1]


def choose_coordinates(records: Sequence[ChannelRecord], modes: LinearModes, *, max_shape_condition: float = 8.0,
                       span_tolerance: float = 0.02, coordinates: str = "auto") -> tuple[str, np.ndarray, float]:
    """``("modal" | "physical", T, span_residual)`` with ``y = T q`` (see the module docstring)."""
    n_ch = records[0].x.shape[0]
    psi = modes.shapes
    if psi.shape[1] > n_ch:  # keep the n_ch least damped
        keep = np.sort(np.argsort(modes.damping_ratios)[:n_ch])
        psi = psi[:, keep]
    y = np.hstack([r.x[:, r.window[0]:r.window[1]] for r in records])
    proj = psi @ np.linalg.lstsq(psi, y, rcond=None)[0]
    span = float(np.linalg.norm(y - proj) / max(np.linalg.norm(y), 1e-300))
    if coordinates == "physical":
        return "physical", np.eye(n_ch), span
    cond = float(np.linalg.cond(psi))
    too_many = modal_evidence(modes, n_ch) == "missing_mode"  # motion no n-mode linear basis holds
    if coordinates == "modal" or (cond <= max_shape_condition and span <= span_tolerance and not too_many):
        return "modal", psi, span
    return "physical", np.eye(n_ch), span


#: A modal mass from the driving-point residue is used when the records' residues agree within
#: this (``LinearModes.modal_mass_spread``). Measured (session 8, 45 dB unless stated): linear
#: and weakly nonlinear own pairs (cubic share 0-20 %, 35-45 dB) 0.001-0.064, their residue
#: masses 0.1-6 % off; the rig's two-mass-cubic and internal-1-3 and the held-out grounded cubic
#: 0.16-0.99, residue masses 4-21 % off (the early residue of a nonlinear mode moves with the
#: blow), where the impact fit's were 0.3-8 % off.
RESIDUE_SPREAD_MAX = 0.1


def residue_masses(modes: LinearModes, tmat: np.ndarray) -> np.ndarray | None:
    """The modal mass from the driving-point residue of every modal coordinate (the mode whose
    shape is that column of ``tmat``), NaN where there is none or the records' residues disagree
    by more than :data:`RESIDUE_SPREAD_MAX`; None without a force."""
    n_modes = modes.shapes.shape[1]
    if modes.modal_masses.size != n_modes or modes.modal_mass_spread.size != n_modes:
        return None
    out = np.full(tmat.shape[1], np.nan)
    for i in range(tmat.shape[1]):
        same = [j for j in range(n_modes) if np.allclose(modes.shapes[:, j], tmat[:, i])]
        if same and modes.modal_mass_spread[same[0]] <= RESIDUE_SPREAD_MAX:
            out[i] = modes.modal_masses[same[0]]
    return out


