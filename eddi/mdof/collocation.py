"""Which response channel the records say the hammer hit: the signs of every channel's residues.

Physics: a force ``F`` at point ``d`` leaves at channel ``c`` the acceleration
``a_c = Re sum_r R_rc e^(lambda_r t)`` whose modal constant (residue of the force-to-response
FRF) is ``A_rc = phi_dr phi_cr / m_r``. At the driving point (``c = d``) every mode's constant
is ``phi_dr^2 / m_r > 0`` (collocated: the FRF's poles and zeros alternate); off it, the
constant has the sign of ``phi_dr phi_cr``, and some mode has opposite entries at ``c`` and
``d`` (the shapes are orthogonal through the mass matrix), so some constant is negative. In
the time domain the struck point accelerates with the force at once, a point behind a spring
later (:func:`blow_lead`); the warning needs both to agree.

:func:`channel_constants` fits ``A_rc`` for every channel, mode and record with the poles of
the linear modes and the measured force (as the driving-point residue masses do,
:func:`eddi.mdof.early.residue_masses`, which uses only the declared channel); the sign does not
depend on which channel was declared. :func:`collocation` reads them: a channel is
contradicted when a mode's constant there is clearly negative (below ``-SIGNIFICANT`` of the
largest constant over modes and channels, in every record), collocated when no constant is
clearly negative and the strongest mode's constant is clearly positive there (a mode near a
node of the driving point leaves a small constant of either sign: not read).

No I/O.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from eddi.mdof.early import RESIDUE_PERIODS, _early_poles
from eddi.mdof.modal import LinearModes
from eddi.mdof.records import ChannelRecord

#: A modal constant counts (its sign is read) when its magnitude, in every record, is at least
#: this share of the largest constant of that record over modes and channels. Below it a mode
#: is near a node of the channel or of the driving point, and noise decides the sign.
SIGNIFICANT = 0.05


@dataclass(frozen=True)
class Collocation:
    """Per-channel evidence of the driving point.

    Attributes
    ----------
    constants : ndarray, shape (n_channels, r)
        Median over the records of each modal constant ``phi_d phi_c / m`` [1/kg], relative to
        the largest magnitude (sign kept).
    negative : tuple of tuple of int
        Per channel, the modes (0-based, ascending frequency) whose constant is clearly negative.
    collocated : tuple of bool
        Per channel: no clearly negative constant, no median below ``-SIGNIFICANT``, and the
        strongest mode's constant clearly positive (a channel that barely moves is no candidate).
    frequencies_hz : ndarray, shape (r,)
    lead : ndarray, shape (n_channels,)
        Median over the records of each channel's acceleration during the blow projected on the
        force, relative to the channel's peak after it (:func:`blow_lead`); empty when not computed.
    """

    constants: np.ndarray
    negative: tuple[tuple[int, ...], ...]
    collocated: tuple[bool, ...]
    frequencies_hz: np.ndarray
    lead: np.ndarray = field(default_factory=lambda: np.zeros(0))


def channel_constants(modes: LinearModes, records: Sequence[ChannelRecord],
                      periods: float = RESIDUE_PERIODS) -> np.ndarray:
    """Modal constants ``phi_d phi_c / m`` [1/kg] of every record, mode and channel, shape
    (n_records, r, n_channels) (records without a force or a usable early window left out)."""
    f_hz, zeta = np.asarray(modes.frequencies_hz, float), np.asarray(modes.damping_ratios, float)
    lam = -zeta * 2 * np.pi * f_hz / np.sqrt(np.maximum(1 - zeta**2, 1e-12)) + 2j * np.pi * f_hz
    out = []
    if lam.size == 0:
        return np.zeros((0, 0, 0))
    for r in records:
        if r.force is None:
            continue
        rate = 1.0 / float(r.t[1] - r.t[0])
        start = r.window[0]
        stop = min(r.window[1], start + int(periods * rate / float(np.min(f_hz))))
        on = np.flatnonzero(r.force)
        if on.size == 0 or stop - start < 4 * lam.size:
            continue
        t = np.arange(stop - start) / rate
        lam_k, res = _early_poles(lam, t, r.a[:, start:stop])
        tau = (np.arange(on[0], on[-1] + 1) - start) / rate
        phi = np.exp(-np.outer(lam_k, tau)) @ r.force[on[0]:on[-1] + 1] / rate  # the pulse at the pole
        p = -1j * lam_k**2 * phi / lam_k.imag
        out.append((np.conj(p)[:, None] * res).real / (np.abs(p) ** 2)[:, None])
    return np.array(out) if out else np.zeros((0, lam.size, records[0].a.shape[0]))


def blow_lead(records: Sequence[ChannelRecord]) -> np.ndarray:
    """Per channel, the median over the records of ``<a_c, F> / (|F| sqrt(n) max|a_c|)`` over the
    ``n`` samples of the blow (``max`` over the free window): the struck mass accelerates with
    the force at once, a mass behind a spring only later (a delayed, smaller start). Measured on
    lumped chains of 2-3 masses: 0.63-10.8 at the struck channel, at most 0.095 elsewhere; the
    rig's energy sink struck at the sink 0.10 at both (empty without a force)."""
    out = []
    for r in records:
        on = np.flatnonzero(r.force) if r.force is not None else np.zeros(0, int)
        if on.size == 0:
            continue
        f = r.force[on[0]:on[-1] + 1]
        peak = np.max(np.abs(r.a[:, r.window[0]:r.window[1]]), axis=1)
        out.append((r.a[:, on[0]:on[-1] + 1] @ f) / (np.linalg.norm(f) * np.sqrt(f.size) * np.maximum(peak, 1e-300)))
    return np.median(out, axis=0) if out else np.zeros(0)


def collocation(modes: LinearModes, records: Sequence[ChannelRecord], significant: float = SIGNIFICANT
                ) -> Collocation | None:
    """The per-channel evidence (module docstring); None without a force or modes."""
    a = channel_constants(modes, records)
    if a.size == 0:
        return None
    scale = np.max(np.abs(a), axis=(1, 2), keepdims=True)
    rel = a / np.maximum(scale, 1e-300)  # (records, modes, channels)
    neg = np.all(rel < -significant, axis=0)  # clearly negative in every record
    pos = np.all(rel > significant, axis=0)
    med = np.median(rel, axis=0)
    strongest = int(np.argmax(np.max(np.abs(med), axis=1)))  # the mode the blow excites most
    n_ch = a.shape[2]
    negative = tuple(tuple(int(k) for k in np.flatnonzero(neg[:, c])) for c in range(n_ch))
    collocated = tuple(bool(not neg[:, c].any() and np.all(med[:, c] > -significant) and pos[strongest, c])
                       for c in range(n_ch))
    return Collocation(constants=np.median(rel, axis=0).T, negative=negative, collocated=collocated,
                       frequencies_hz=np.asarray(modes.frequencies_hz, float), lead=blow_lead(records))


#: How a driving point taken by default is described in the warning.
DEFAULTED = "the default (the first response channel; no --driving-point or bench config given)"


def driving_point_warning(col: Collocation | None, names: Sequence[str], declared: str,
                          how: str = "declared") -> str | None:
    """The warning when the records contradict the declared driving point and point to another
    channel (exactly one other collocated channel); None otherwise (silence when they agree, or
    when they single out no channel). ``how``: how the driving point was chosen (``"declared"``,
    :data:`DEFAULTED`, ``"the model's"``)."""
    if col is None or declared not in names:
        return None
    d = list(names).index(declared)
    others = [c for c in range(len(names)) if c != d and col.collocated[c]]
    if not col.negative[d] or col.collocated[d] or len(others) != 1:
        return None
    c = others[0]
    if col.lead.size == len(names) and not col.lead[c] > col.lead[d]:  # the blow's start disagrees
        return None
    modes = ", ".join(f"mode {k + 1} ({col.frequencies_hz[k]:.4g} Hz, {col.constants[d, k]:+.2f})"
                      for k in col.negative[d])
    moves = " and it moves with the force during the blow" if col.lead.size == len(names) else ""
    return (f"the records point to {names[c]} as the driving point (all residues positive there{moves}; {declared}, "
            f"{how}, has a negative residue for {modes}, which a collocated sensor cannot have): "
            f"check --driving-point")


def check_driving_point(modes: LinearModes, records: Sequence[ChannelRecord], names: Sequence[str], declared: str,
                        how: str = "declared") -> list[str]:
    """``[warning]`` when the records contradict ``declared`` and point to one other channel
    (:func:`driving_point_warning`), else ``[]``."""
    w = driving_point_warning(collocation(modes, records), names, declared, how)
    return [w] if w else []
