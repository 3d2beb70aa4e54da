"""Coupled nonlinear equations of motion from several channels: EDDI per coordinate.

Input: conditioned records (displacement, velocity and acceleration of every response channel,
and the impact force at the driving point). Steps:

1. **Linear modes** (:func:`eddi.mdof.modal.era`) from the low-amplitude tail of the records.
2. **Coordinates.** ``modal`` when the tail shows as many modes as there are channels with
   well-separated shapes (``cond(Psi) <= max_shape_condition``) or fewer modes that span the
   measured motion (projection residual below ``span_tolerance``): ``q = pinv(Psi) y``.
   Otherwise (also when the tail needs more oscillating poles than there are channels)
   ``physical`` (one coordinate per channel): the motion has a part no linear mode
   describes (a nonlinear energy sink has no linear stiffness, hence no linear mode). With
   ``coordinates="auto"`` the modal choice is also fitted in physical coordinates and
   dropped when the physical equations close (force balance) twice as well; with coupling
   terms the identification is then also run in physical coordinates, in physical coordinates
   with drift-filtered equations (:func:`_design`) and, with a force, as lumped masses,
   springs and dashpots (:mod:`eddi.mdof.lumped`); the candidate whose model reproduces the
   training records best (mean simulated nrmse) is kept.
3. **Per coordinate, EDDI with coupling terms** (per unit mass). Library of equation ``i``:
   damping ``v_1..v_n``; own stiffness ``x_i, x_i^3``; coupling stiffness ``x_j`` and every cubic
   monomial but ``x_i^3``. *Phase one* (paper Eq. 7) at the zero crossings ``gamma_k`` of
   ``q_i``, where the coordinate's own potential is zero:
   ``sum_j b_j int v_i D_j dt + sum_c theta_c int v_i C_c dt = T_i(gamma_k-1) - T_i(gamma_k)``:
   the energy a coordinate loses per half cycle is what it dissipates plus what it gives to
   the others through the coupling terms (its own stiffness returns what it stores). Rows are
   half cycles, each divided by ``T_i`` at its start; all records stacked. *Phase two*:
   ``K_i(q) = -q_i'' - B_i`` sample by sample, fitted with the own and coupling stiffness terms.
   When a coordinate exchanges more energy than it dissipates (physical coordinates joined by
   a stiff spring), phase one cannot resolve the small damping, and damping and stiffness are
   fitted together on the force balance.
4. **Sparsity.** A term whose force (RMS over the data) is below ``prune`` times the RMS of
   ``q_i''`` is dropped and the equation refitted (sequential thresholding).
5. **Input and masses** (:mod:`eddi.mdof.masses`). Over the impact, ``q_i'' + B_i + K_i = g_i F`` gives the force per
   unit mass ``g_i`` by least squares. Modal coordinates: the force enters equation ``i`` as
   ``psi_di F`` (``d`` the driving point) so the modal mass is ``m_i = psi_di / g_i``, the
   driving-point residue route: no mass needs to be given. Physical coordinates: the driven
   mass is ``1 / g_d``; every other mass follows from reciprocity of the coupling springs (a
   potential term ``theta x_i^a x_j^b`` appears as ``a theta / m_i`` in equation ``i`` and
   ``b theta / m_j`` in equation ``j``).
6. **Slow response.** The drift high-pass of the conditioning removed the slow response to
   the impact; the first model's linear receptance restores it
   (:func:`restore_quasi_static`) and the identification runs a second time.

No I/O: arrays in, frozen results out.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from eddi.threads import one_blas_thread
from eddi.energy import cumulative_energy, rate_interpolant, zero_crossings
from eddi.errors import IdentificationError
from eddi.mdof.early import era_windows
from eddi.mdof.modal import LinearModes
from eddi.mdof.intervals import JACKKNIFE_BLOCKS, block_jackknife_ci95
from eddi.mdof.masses import masses_and_inputs
from eddi.mdof.model import MdofModel
from eddi.mdof.signals import HIGHPASS_HZ, highpass, quasi_static
from eddi.mdof.terms import MultiTerm, monomial, parse_multi_term
from eddi.phase_one import scaled_lstsq


#: Passes of the drift high-pass over phase two's columns when ``prefilter`` (:func:`_design`).
#: Not always on: measured (``bench_mdof_error_budget.py``) it lowers the two-mass chain's
#: worst coefficient in physical coordinates from 6.3 to 3.6 % but raises the 1:3 system's in
#: modal ones from 12 to 36 %; ``coordinates="auto"`` fits both and keeps the better predictor.
PREFILTER_PASSES = 1
FILTERED_NOTE = "phase two on drift-filtered equations (columns and force through the drift high-pass)"


@dataclass(frozen=True)
class ChannelRecord:
    """One conditioned multi-channel record.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
    x, v, a : ndarray, shape (n_channels, n)
        Displacement [m], velocity [m/s], acceleration [m/s^2] of every response channel.
    force : ndarray, shape (n,), [N], or None
        Impact force at the driving point (zero outside the impact).
    impact : (int, int)
        ``[start, end)`` of the impact (``(0, 0)`` without force).
    window : (int, int)
        Free-response window ``[start, stop)``.
    noise : ndarray, shape (n_channels,)
        Noise RMS of each channel's displacement [m] (sets the zero-crossing dead band).
    label : str
    highpass_hz : float
        Cut-off of the zero-phase drift high-pass ``x`` and ``v`` went through [Hz].
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    force: np.ndarray | None
    impact: tuple[int, int]
    window: tuple[int, int]
    noise: np.ndarray
    label: str = ""
    highpass_hz: float = HIGHPASS_HZ


@dataclass(frozen=True)
class Library:
    """Candidate terms of one equation: damping, own stiffness and coupling stiffness."""

    damping: tuple[str, ...]
    own: tuple[str, ...]
    coupling: tuple[str, ...]


def default_library(i: int, n: int, coupling: bool | str = True) -> Library:
    """The library of equation ``i`` (0-based) of ``n`` (see the module docstring).

    ``coupling``: True, every coupling term; ``"linear"``, only the linear ones (``x_j``, ``v_j``:
    physical coordinates joined by linear springs, no nonlinear coupling); False, none.
    """
    damping = tuple(monomial({j: 1}, n, rate=True) for j in range(n))
    own = (monomial({i: 1}, n), monomial({i: 3}, n))
    if not coupling or n == 1:
        return Library((monomial({i: 1}, n, rate=True),), own, ())
    cpl = [monomial({j: 1}, n) for j in range(n) if j != i]
    if coupling == "linear":
        return Library(damping, own, tuple(cpl))
    for combo in itertools.combinations_with_replacement(range(n), 3):
        powers: dict[int, int] = {}
        for j in combo:
            powers[j] = powers.get(j, 0) + 1
        if powers != {i: 3}:
            cpl.append(monomial(powers, n))
    return Library(damping, own, tuple(dict.fromkeys(cpl)))


@dataclass(frozen=True)
class EquationFit:
    """What EDDI found for one coordinate (per unit mass).

    Attributes
    ----------
    damping, stiffness : dict of str to float
        Per-unit-mass coefficients kept after pruning.
    input_gain : float
        ``g_i`` [1/kg]: force at the driving point per unit mass of this coordinate.
    energy_residual : float
        RMS relative misfit of the phase-one half-cycle energy balance.
    exchanged_fraction : float
        Energy given to (or taken from) the other coordinates through coupling terms over
        the half cycles, relative to the energy dissipated (phase one).
    half_cycles : int
    force_residual : float
        RMS of the force balance ``q_i'' + B_i + K_i`` over the free windows relative to the
        RMS of ``q_i''``.
    stiffness_ci95 : dict of str to float
        Half-width of the 95 % interval of each stiffness coefficient (per unit mass), from a
        delete-one-block jackknife of the stiffness fit (:func:`eddi.mdof.intervals.block_jackknife_ci95`).
    """

    damping: dict[str, float]
    stiffness: dict[str, float]
    input_gain: float
    energy_residual: float
    exchanged_fraction: float
    half_cycles: int
    force_residual: float = math.nan
    stiffness_ci95: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class MdofIdentification:
    """Result of :func:`identify_mdof`.

    Attributes
    ----------
    model : MdofModel
    modes : LinearModes
        From the low-amplitude tail.
    coordinates : str
        ``"modal"`` or ``"physical"``.
    equations : tuple of EquationFit
    span_residual : float
        Part of the measured displacement (RMS, relative) the linear mode shapes do not span.
    notes : tuple of str
    modal_basis : bool
        False when the tail's linear modes are no modal basis of the motion (more oscillating
        poles than channels, shapes that do not span it or are ill-conditioned): a motion no
        linear mode describes, the ``missing_mode`` of diagnosis (positive evidence only:
        :func:`modal_evidence`).
    unresolved : bool
        True when the coordinates are physical because the tail resolves fewer modes than
        channels (or shapes too alike) with no evidence of a missing one: diagnosis then says
        ``unexplained`` rather than naming a cause the modes cannot support.
    lumped : LumpedFit or None
        The element fit (:mod:`eddi.mdof.lumped`) when the model is the lumped-element
        candidate (for :func:`eddi.mdof.refine.refine_lumped`).
    """

    model: MdofModel
    modes: LinearModes
    coordinates: str
    equations: tuple[EquationFit, ...]
    span_residual: float
    notes: tuple[str, ...] = field(default_factory=tuple)
    modal_basis: bool = True
    unresolved: bool = False
    lumped: Any = None


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


def linear_modes(records: Sequence[ChannelRecord], *, tail_fraction: float = 0.2,
                 max_freq_hz: float | None = None, driving_point: int = 0) -> LinearModes:
    """ERA on the low-amplitude tail of the measured accelerations of every record, plus the modes
    only earlier windows hold (:func:`eddi.mdof.early.era_windows`)."""
    rate = 1.0 / float(records[0].t[1] - records[0].t[0])
    forces = None
    if all(r.force is not None and r.impact[1] > r.impact[0] for r in records):
        forces = []
        for r in records:
            f = np.zeros_like(r.force)
            f[r.impact[0]:r.impact[1]] = r.force[r.impact[0]:r.impact[1]]
            forces.append(f)
    return era_windows([(r.a, r.window[0], r.window[1]) for r in records], rate, tail_fraction=tail_fraction,
                       max_freq_hz=max_freq_hz or 0.2 * rate, driving_point=driving_point, forces=forces)


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


def _terms(texts: Sequence[str], n: int) -> list[MultiTerm]:
    return [parse_multi_term(t, n) for t in texts]


def _matrix(terms: Sequence[MultiTerm], q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    return np.column_stack([t(q, qd) for t in terms]) if terms else np.zeros((q.shape[1], 0))


def _phase_one_rows(i: int, rec_q: tuple, terms: list[MultiTerm], hysteresis: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Half-cycle rows (dQ, dT, T_start) of equation ``i`` for one record's free window."""
    t, q, qd, qdd = rec_q
    gamma = zero_crossings(t, q[i], qd[i], hysteresis=hysteresis)
    if gamma.size < 3:
        return np.zeros((0, len(terms))), np.zeros(0), np.zeros(0)
    power = qd[i][:, None] * _matrix(terms, q, qd)
    anti = cumulative_energy(t, power)(gamma)
    vg = rate_interpolant(t, qd[i], qdd[i])(gamma)
    kin = 0.5 * vg**2
    return np.diff(anti, axis=0), -np.diff(kin), kin[:-1]


def _design(i: int, data: list[tuple], full: list[tuple] | None, d_terms: list[MultiTerm],
            s_terms: list[MultiTerm]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Phase two's regression ``(D, S, -q_i'', F)`` over the free windows of every record.

    Without ``full``: the columns as measured (``F`` empty). With ``full`` (per record
    ``(q, qd, qdd, force, window, rate_hz, cutoff_hz)`` over the whole record): every column,
    the force among them, passes through the drift high-pass before the windows are cut. The
    conditioned ``x, v`` lack their slow part (below the cut-off), where the nonlinear forces
    put components (``2 f1 - f2``) that the linear terms of the true motion balance; filtered
    alike, both sides of ``q'' + B + K = g F`` lose that band and the equation holds again
    above it (the filtered force is a nuisance column: inside the window it is the filter's
    tail of the impact, not negligible at ``f_c / f_1 = 1/4``).
    """
    if full is None:
        q = np.hstack([r[1] for r in data])
        qd = np.hstack([r[2] for r in data])
        qdd = np.hstack([r[3] for r in data])
        return _matrix(d_terms, q, qd), _matrix(s_terms, q, qd), -qdd[i], np.zeros((qdd.shape[1], 0))
    parts = []
    for q, qd, qdd, force, (s, e), rate, fc in full:
        cols = [_matrix(d_terms, q, qd), _matrix(s_terms, q, qd), -qdd[i][:, None],
                (force if force is not None else np.zeros(q.shape[1]))[:, None]]
        big = highpass(np.hstack(cols).T, rate, fc, PREFILTER_PASSES).T[s:e]
        parts.append(big)
    big = np.vstack(parts)
    nd, ns = len(d_terms), len(s_terms)
    return big[:, :nd], big[:, nd:nd + ns], big[:, nd + ns], big[:, nd + ns + 1:]


def fit_equation(i: int, data: list[tuple], impacts: list[tuple], lib: Library, noise: float,
                 prune: float = 3e-3, max_exchange: float = 1.0, full: list[tuple] | None = None) -> EquationFit:
    """EDDI phases one and two for coordinate ``i`` with coupling terms, then the input gain.

    ``data``: per record ``(t, q, qd, qdd)`` over the free window; ``impacts``: per record
    ``(q, qd, qdd, force)`` over the impact (may be empty). When the energy exchanged through
    the coupling terms exceeds ``max_exchange`` times the energy dissipated, damping and
    stiffness are fitted together on the force balance (phase one cannot separate them).
    ``full``: the whole records, for phase two on drift-filtered columns (:func:`_design`).
    """
    n = data[0][1].shape[0]
    damp, own, cpl = list(lib.damping), list(lib.own), list(lib.coupling)
    blocks = np.concatenate([np.minimum(np.arange(r[1].shape[1]) * JACKKNIFE_BLOCKS // r[1].shape[1],
                                        JACKKNIFE_BLOCKS - 1) + JACKKNIFE_BLOCKS * j for j, r in enumerate(data)])
    rounds = 6
    for _round in range(rounds):
        d_terms, s_terms = _terms(damp, n), _terms(own + cpl, n)
        e_terms = d_terms + _terms(cpl, n)
        rows, rhs, kin0 = [], [], []
        for rec in data:
            dq, dt_, k0 = _phase_one_rows(i, rec, e_terms, 4.0 * noise)
            rows.append(dq)
            rhs.append(dt_)
            kin0.append(k0)
        dq, dr, k0 = np.vstack(rows), np.concatenate(rhs), np.concatenate(kin0)
        if dr.size < len(e_terms) + 1:
            raise IdentificationError(f"coordinate {i + 1}: {dr.size} half cycles for {len(e_terms)} terms; "
                                      "need longer or more records")
        w = 1.0 / np.maximum(k0, 1e-12 * float(k0.max()))
        coef1, _cond = scaled_lstsq(dq * w[:, None], dr * w)
        b = coef1[: len(d_terms)]
        theta = coef1[len(d_terms):]
        # phase two: conservative force sample by sample
        dmat, smat, target, fcol = _design(i, data, full, d_terms, s_terms)
        nf = fcol.shape[1]
        k_force = target - dmat @ b
        k = scaled_lstsq(np.hstack([smat, fcol]), k_force)[0][: smat.shape[1]]
        exchanged = float(np.sum(np.abs(dq[:, len(d_terms):] @ theta))) if theta.size else 0.0
        joint = exchanged > max_exchange * float(np.sum(np.abs(dq[:, : len(d_terms)] @ b)))
        if joint:
            # the coordinate's energy is mostly exchanged, not dissipated (physical coordinates
            # joined by springs): the half-cycle balance cannot resolve the damping; fit damping
            # and stiffness together on the force balance instead
            both, _ = scaled_lstsq(np.hstack([dmat, smat, fcol]), target)
            b, k = both[: len(d_terms)], both[len(d_terms): len(both) - nf]
        scale = float(np.sqrt(np.mean(target ** 2))) or 1.0
        small_d = [t for t, c, col in zip(damp, b, dmat.T) if t != monomial({i: 1}, n, True)
                   and np.sqrt(np.mean((c * col) ** 2)) < prune * scale]
        small_s = [t for t, c, col in zip(own + cpl, k, smat.T) if t != monomial({i: 1}, n)
                   and np.sqrt(np.mean((c * col) ** 2)) < prune * scale]
        if (not small_d and not small_s) or _round == rounds - 1:  # the last round keeps its fit
            break
        damp = [t for t in damp if t not in small_d]
        own = [t for t in own if t not in small_s]
        cpl = [t for t in cpl if t not in small_s]
    nd = len(d_terms)
    ns = smat.shape[1]
    k_ci = block_jackknife_ci95(  # of the final fit
        (lambda rows: scaled_lstsq(np.hstack([dmat, smat, fcol])[rows], target[rows])[0][nd:nd + ns]) if joint
        else (lambda rows: scaled_lstsq(np.hstack([smat, fcol])[rows], k_force[rows])[0][:ns]), blocks)
    dissipated = float(np.sum(np.abs(dq[:, : len(d_terms)] @ b)))
    exchanged = float(np.sum(np.abs(dq[:, len(d_terms):] @ theta))) if theta.size else 0.0
    residual = float(np.sqrt(np.mean(((dq @ coef1 - dr) * w) ** 2)))
    damping = {t: float(c) for t, c in zip(damp, b)}
    stiffness = {t: float(c) for t, c in zip(own + cpl, k)}
    ci95 = {t: float(h) for t, h in zip(own + cpl, k_ci)}
    gain = _input_gain(i, impacts, d_terms, s_terms, b, k)
    q, qd = np.hstack([r[1] for r in data]), np.hstack([r[2] for r in data])
    qdd_i = np.concatenate([r[3][i] for r in data])
    dmat, smat = _matrix(_terms(damp, n), q, qd), _matrix(_terms(own + cpl, n), q, qd)
    force_res = float(np.sqrt(np.mean((qdd_i + dmat @ b + smat @ k) ** 2))
                      / (float(np.sqrt(np.mean(qdd_i ** 2))) or 1.0))
    return EquationFit(damping, stiffness, gain, residual, exchanged / max(dissipated, 1e-300), int(dr.size),
                       force_res, ci95)


def _input_gain(i: int, impacts: list[tuple], d_terms: list[MultiTerm], s_terms: list[MultiTerm],
                b: np.ndarray, k: np.ndarray) -> float:
    """``g_i`` from ``q_i'' + B_i + K_i = g_i F`` over the impacts (0 without force)."""
    num = den = 0.0
    for q, qd, qdd, f in impacts:
        r = qdd[i] + _matrix(d_terms, q, qd) @ b + _matrix(s_terms, q, qd) @ k
        num += float(f @ r)
        den += float(f @ f)
    return num / den if den > 0 else 0.0


@one_blas_thread()
def identify_mdof(records: Sequence[ChannelRecord], channels: Sequence[str], driving_point: str, *,
                  coordinates: str = "auto", coupling: bool | str = True, tail_fraction: float = 0.2,
                  max_freq_hz: float | None = None, prune: float = 3e-3,
                  highpass_hz: float | None = HIGHPASS_HZ) -> MdofIdentification:
    """Identify ``M q'' + B(q, q') + K(q) = u F`` from multi-channel records (module docstring).

    Parameters
    ----------
    records : sequence of ChannelRecord
    channels : sequence of str
        Response channel names, in the order of the rows of ``x``.
    driving_point : str
        The channel at the hammer.
    coordinates : {"auto", "modal", "physical", "lumped"}
        ``"lumped"``: masses joined by springs and dashpots (:mod:`eddi.mdof.lumped`); ``"auto"``
        (with coupling and a force) also fits that and keeps the candidate whose model
        reproduces the training records best.
    coupling : bool or "linear"
        Include coupling terms (False: uncoupled modes, the baseline of diagnosis in modal
        coordinates; ``"linear"``: linear coupling only, its baseline in physical ones).
    tail_fraction : float
        Linear modal analysis uses the record after the envelope falls below this fraction.
    max_freq_hz : float, optional
    prune : float
        Relative force below which a term is dropped.
    highpass_hz : float or None
        Not None: with a force, the identification is run twice, the second time on records
        with the quasi-static response the drift high-pass removed (at each record's
        ``highpass_hz``) restored (:func:`eddi.mdof.signals.quasi_static`, flexibility from
        the first model). None: once.

    Raises
    ------
    IdentificationError
    """
    if not records:
        raise IdentificationError("no records to identify from")
    channels = tuple(channels)
    if driving_point not in channels:
        raise IdentificationError(f"driving point {driving_point!r} is not a channel ({', '.join(channels)})")
    d = channels.index(driving_point)
    args = (channels, driving_point, d)
    opts = (coupling, tail_fraction, max_freq_hz, prune, highpass_hz)
    if coordinates == "lumped":
        from eddi.mdof.physical import identify_lumped  # it builds on this module

        return identify_lumped(records, channels, driving_point, prune=prune, tail_fraction=tail_fraction)
    chosen = _identify_twice(records, *args, coordinates, *opts)
    if coordinates != "auto" or coupling is not True or len(channels) < 2:
        return chosen
    # both coordinate systems describe a coupled structure exactly with a complete library; they
    # differ in conditioning. Keep the one whose model reproduces the training records better.
    candidates = [chosen]
    if chosen.coordinates == "modal":
        try:
            candidates.append(_identify_twice(records, *args, "physical", *opts))
        except IdentificationError:
            pass
    try:  # the same with phase two on drift-filtered equations (:func:`_design`)
        candidates.append(_identify_twice(records, *args, "physical", *opts, prefilter=True))
    except IdentificationError:
        pass
    if any(r.force is not None for r in records):
        from eddi.mdof.physical import identify_lumped  # it builds on this module

        try:  # masses joined by springs and dashpots (the channels at the masses)
            candidates.append(identify_lumped(records, channels, driving_point, prune=prune,
                                              tail_fraction=tail_fraction))
        except (IdentificationError, np.linalg.LinAlgError, ValueError):
            pass
    errors = [_training_error(c, records) for c in candidates]
    best = int(np.argmin(errors))
    names = [_candidate_name(c) for c in candidates]
    note = (f"{names[best]} kept: training nrmse {errors[best]:.3g}"
            + "".join(f"; {nm} {e:.3g}" for k, (nm, e) in enumerate(zip(names, errors)) if k != best))
    keep = candidates[best]
    return replace(keep, notes=tuple(dict.fromkeys(keep.notes + (note,))), modal_basis=chosen.modal_basis,
                   unresolved=chosen.unresolved)


def _candidate_name(ident: MdofIdentification) -> str:
    """``modal coordinates``, ``physical coordinates`` or ``lumped elements`` (for notes)."""
    if ident.model.notes.startswith("identified by eddi.mdof.lumped"):
        return "lumped elements"
    return f"{ident.coordinates} coordinates" + (", filtered equations" if FILTERED_NOTE in ident.notes else "")


def _identify_twice(records: Sequence[ChannelRecord], channels: tuple[str, ...], driving_point: str, d: int,
                    coordinates: str, coupling: bool | str, tail_fraction: float, max_freq_hz: float | None,
                    prune: float, highpass_hz: float | None, *, prefilter: bool = False) -> MdofIdentification:
    """One identification, then (with a force and ``highpass_hz``) a second on restored records.

    ``prefilter``: phase two on drift-filtered columns (:func:`_design`), said in the notes.
    """
    first = _identify_once(records, channels, driving_point, d, coordinates, coupling, tail_fraction,
                           max_freq_hz, prune, prefilter=prefilter)
    if highpass_hz is None or all(r.force is None for r in records):
        second = first
    else:
        fixed = [restore_quasi_static(r, first.model) for r in records]
        second = _identify_once(fixed, channels, driving_point, d, first.coordinates, coupling, tail_fraction,
                                max_freq_hz, prune, prefilter=prefilter)
    extra = (FILTERED_NOTE,) if prefilter else ()
    return replace(second, notes=tuple(dict.fromkeys(first.notes + second.notes + extra)),
                   modal_basis=first.modal_basis, unresolved=first.unresolved)


def _training_error(ident: MdofIdentification, records: Sequence[ChannelRecord]) -> float:
    """Mean per-channel nrmse of the model's simulation of the records (inf when it diverges)."""
    from eddi.mdof.validate import validate_mdof  # validation imports this module

    errs = [validate_mdof(ident.model, r).nrmse for r in records]
    return float(np.mean(errs)) if all(np.isfinite(errs)) else math.inf


def receptance(model: MdofModel):
    """``freqs_hz -> Phi (K - w^2 M + i w C)^-1 u``, shape (n_channels, n_freqs), of the linear terms."""
    m, c, k = model.linear_matrices()
    u = np.asarray(model.input, float)
    phi = model.phi

    def h(freqs_hz: np.ndarray) -> np.ndarray:
        out = np.empty((phi.shape[0], len(freqs_hz)), complex)
        for j, f in enumerate(freqs_hz):
            w = 2 * math.pi * f
            try:
                out[:, j] = phi @ np.linalg.solve(k - w**2 * m + 1j * w * c, u)
            except np.linalg.LinAlgError:
                out[:, j] = 0.0
        return np.nan_to_num(out)

    return h


def restore_quasi_static(r: ChannelRecord, model: MdofModel) -> ChannelRecord:
    """The record with the slow response the drift high-pass removed added back (``model``'s linear part)."""
    if r.force is None:
        return r
    rate = 1.0 / float(r.t[1] - r.t[0])
    xl, vl = quasi_static(r.force, rate, receptance(model), r.highpass_hz)
    return replace(r, x=r.x + xl, v=r.v + vl)


def _identify_once(records: Sequence[ChannelRecord], channels: tuple[str, ...], driving_point: str, d: int,
                   coordinates: str, coupling: bool | str, tail_fraction: float, max_freq_hz: float | None,
                   prune: float, *, prefilter: bool = False) -> MdofIdentification:
    modes = linear_modes(records, tail_fraction=tail_fraction, max_freq_hz=max_freq_hz, driving_point=d)
    kind, tmat, span = choose_coordinates(records, modes, coordinates=coordinates)
    fits = _fit_all(records, tmat, coupling, prune, prefilter)
    notes_pre: list[str] = []
    evidence = modal_evidence(modes, tmat.shape[0])
    basis = not (coordinates == "auto" and kind == "physical" and evidence == "missing_mode")
    unresolved = coordinates == "auto" and kind == "physical" and basis
    if not basis:
        notes_pre.append(f"the tail's {modes.shapes.shape[1]} linear mode(s) for {tmat.shape[0]} channels are not a "
                         f"modal basis of the motion (span residual {100 * span:.1f} %, unexplained tail "
                         f"{100 * float(np.max(modes.unexplained, initial=0.0)):.0f} %): physical coordinates kept")
    elif unresolved:
        notes_pre.append(f"the tail resolves {modes.shapes.shape[1]} linear mode(s) for {tmat.shape[0]} channels "
                         f"(shape condition {np.linalg.cond(modes.shapes):.3g}, span residual {100 * span:.1f} %): "
                         "physical coordinates; a mode the records do not resolve is not a missing mode")
    if coordinates == "auto" and kind == "modal":
        # the tail's modes may not be the structure's (a nonlinear attachment has none):
        # keep the modal coordinates only when their equations close as well as the physical
        phys = _fit_all(records, np.eye(tmat.shape[0]), coupling, prune, prefilter)
        r_modal = float(np.mean([f.force_residual for f in fits]))
        r_phys = float(np.mean([f.force_residual for f in phys]))
        if r_phys < 0.5 * r_modal:
            notes_pre.append(f"modal equations close to {100 * r_modal:.2g} %, physical ones to "
                             f"{100 * r_phys:.2g} %: physical coordinates kept")
            kind, tmat, fits = "physical", np.eye(tmat.shape[0]), phys
    n = tmat.shape[1]
    proj = np.linalg.pinv(tmat)
    amp = np.sqrt(np.mean(np.hstack([proj @ r.x[:, r.window[0]:r.window[1]] for r in records]) ** 2, axis=1))
    masses, inputs, notes = masses_and_inputs(kind, fits, tmat, d, n, amp,
                                              _residue_masses(modes, tmat) if kind == "modal" else None)
    notes = notes_pre + notes
    model = MdofModel.create(
        coordinates=kind, mass=tuple(masses), input=tuple(inputs),
        damping=tuple({t: c * m for t, c in f.damping.items()} for f, m in zip(fits, masses)),
        stiffness=tuple({t: c * m for t, c in f.stiffness.items()} for f, m in zip(fits, masses)),
        stiffness_ci95=tuple({t: h * m for t, h in f.stiffness_ci95.items()} for f, m in zip(fits, masses)),
        channels=channels, shapes=tuple(tuple(float(v) for v in row) for row in tmat),
        driving_point=driving_point,
        notes=f"identified by eddi.mdof from {len(records)} record(s); {kind} coordinates; "
              f"linear modes {', '.join(f'{f:.4g} Hz' for f in modes.frequencies_hz)}")
    growth = linear_growth_rate(model)
    if growth > 0:
        notes.append(f"warning: the identified linear part is unstable (a mode grows at {growth:.3g} 1/s): "
                     "the damping is not determined by these records")
    return MdofIdentification(model, modes, kind, fits, span, tuple(notes), basis, unresolved)


#: A modal mass from the driving-point residue is used when the records' residues agree within
#: this (``LinearModes.modal_mass_spread``). Measured (session 8, 45 dB unless stated): linear
#: and weakly nonlinear own pairs (cubic share 0-20 %, 35-45 dB) 0.001-0.064, their residue
#: masses 0.1-6 % off; the rig's two-mass-cubic and internal-1-3 and the held-out grounded cubic
#: 0.16-0.99, residue masses 4-21 % off (the early residue of a nonlinear mode moves with the
#: blow), where the impact fit's were 0.3-8 % off.
RESIDUE_SPREAD_MAX = 0.1


def _residue_masses(modes: LinearModes, tmat: np.ndarray) -> np.ndarray | None:
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


def linear_growth_rate(model: MdofModel) -> float:
    """Largest real part of the eigenvalues of the model's linear part [1/s] (> 0: unstable)."""
    m, c, k = model.linear_matrices()
    n = model.n_coords
    try:
        a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(m, k), -np.linalg.solve(m, c)]])
        return float(np.max(np.linalg.eigvals(a).real))
    except np.linalg.LinAlgError:
        return math.nan


def _fit_all(records: Sequence[ChannelRecord], tmat: np.ndarray, coupling: bool | str, prune: float,
             prefilter: bool = False) -> tuple[EquationFit, ...]:
    """EDDI per coordinate ``q = pinv(T) y`` over every record."""
    proj = np.linalg.pinv(tmat)
    n = tmat.shape[1]
    data, impacts = [], []
    for r in records:
        s, e = r.window
        data.append((r.t[s:e], proj @ r.x[:, s:e], proj @ r.v[:, s:e], proj @ r.a[:, s:e]))
        if r.force is not None and r.impact[1] > r.impact[0]:
            i0, i1 = r.impact[0], max(r.impact[1], r.window[0]) + 3
            impacts.append((proj @ r.x[:, i0:i1], proj @ r.v[:, i0:i1], proj @ r.a[:, i0:i1], r.force[i0:i1]))
    noise = np.abs(proj) @ np.max([r.noise for r in records], axis=0)
    full = None
    if prefilter:
        full = [(proj @ r.x, proj @ r.v, proj @ r.a, r.force, r.window, 1.0 / float(r.t[1] - r.t[0]),
                 r.highpass_hz) for r in records]
    return tuple(fit_equation(i, data, impacts, default_library(i, n, coupling), float(noise[i]), prune,
                              full=full) for i in range(n))
