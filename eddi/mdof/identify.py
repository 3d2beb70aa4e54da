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
   with drift-filtered equations (:func:`eddi.mdof.equations._design`) and, with a force, as lumped masses,
   springs and dashpots (:mod:`eddi.mdof.lumped`); of the candidates whose models reproduce the
   training records (mean simulated nrmse) within the noise floor of the best, the one with the
   fewest coefficients is kept (:mod:`eddi.mdof.candidates`).
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
   ``q_i''`` is dropped and the equation refitted (sequential thresholding). In modal
   coordinates the identification is also run with the lower prunes of :data:`PRUNE_LADDER`
   (a weak coupling near internal resonance exchanges energy through forces of the order of the
   damping force), and the candidate rule keeps the sparsest whose model reproduces the
   training records within the noise floor (:func:`_prune_ladder`).
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

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from eddi.threads import one_blas_thread
from eddi.errors import IdentificationError
from eddi.mdof.candidates import choose_candidate
from eddi.mdof.coordinates import (EXTRA_MODE_SHARE, RESIDUE_SPREAD_MAX, UNEXPLAINED_TAIL, choose_coordinates,
                                   linear_modes, modal_evidence, residue_masses)
from eddi.mdof.equations import (BAND_FRACTION, ERA_TOLERANCE, FILTERED_NOTE, PREFILTER_PASSES, EquationFit,
                                 Library, default_library, era_stiffness, fit_all, fit_equation)
from eddi.mdof.linear import linear_growth_rate, receptance, restore_quasi_static
from eddi.mdof.masses import masses_and_inputs
from eddi.mdof.modal import LinearModes
from eddi.mdof.model import MdofModel
from eddi.mdof.records import ChannelRecord
from eddi.mdof.signals import HIGHPASS_HZ

__all__ = ["ChannelRecord", "EquationFit", "Library", "MdofIdentification", "default_library", "fit_equation",
           "identify_mdof", "linear_modes", "modal_evidence", "choose_coordinates", "linear_growth_rate",
           "receptance", "restore_quasi_static", "EXTRA_MODE_SHARE", "RESIDUE_SPREAD_MAX", "UNEXPLAINED_TAIL",
           "FILTERED_NOTE", "PREFILTER_PASSES"]


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
    form_error : float
        The smallest training nrmse the lumped form reached over the variants it tried (rows'
        starts, slow band), NaN otherwise: :mod:`eddi.mdof.candidates` judges the form by it.
    training_nrmse : float
        ``model``'s training nrmse on the records it was identified from
        (:func:`eddi.mdof.candidates.training_error`) when the identification simulated it, NaN
        otherwise (the candidate choice then simulates it).
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
    form_error: float = math.nan
    training_nrmse: float = math.nan


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
        ``"lumped"``: masses joined by springs and dashpots (:mod:`eddi.mdof.lumped`; with
        ``coupling`` not True, no nonlinear element between two masses); ``"auto"``
        (with coupling and a force) also fits that and keeps the candidate whose model
        reproduces the training records best.
    coupling : bool or "linear"
        Include coupling terms (False: uncoupled modes, the baseline of diagnosis in modal
        coordinates; ``"linear"``: linear coupling only, its baseline in physical ones).
    tail_fraction : float
        Linear modal analysis uses the record after the envelope falls below this fraction.
    max_freq_hz : float, optional
    prune : float
        Relative force below which a term is dropped (in modal coordinates with coupling terms,
        also :data:`PRUNE_LADDER` times it, the candidate rule choosing; the prune kept is named
        in the notes).
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

        return identify_lumped(records, channels, driving_point, prune=prune, tail_fraction=tail_fraction,
                               couplings=coupling is True)
    chosen = _identify_twice(records, *args, coordinates, *opts)
    if coordinates != "auto" or coupling is not True or len(channels) < 2:
        ladder = _prune_ladder(records, args, chosen, coordinates, opts) if coupling is True else [chosen]
        if len(ladder) == 1:
            return chosen
        choice = choose_candidate(ladder, [_candidate_name(c) for c in ladder], records)
        keep = ladder[choice.index]
        return replace(keep, notes=tuple(dict.fromkeys(keep.notes + (choice.note,))))
    # both coordinate systems describe a coupled structure exactly with a complete library; they
    # differ in conditioning. Keep the one whose model reproduces the training records better.
    candidates = [chosen]
    if chosen.coordinates == "modal":
        try:
            candidates.append(_identify_twice(records, *args, "physical", *opts))
        except IdentificationError:
            pass
    try:  # the same with phase two on drift-filtered equations (:func:`eddi.mdof.equations._design`)
        candidates.append(_identify_twice(records, *args, "physical", *opts, prefilter=True))
    except IdentificationError:
        pass
    refused = ""
    if any(r.force is not None for r in records):
        from eddi.mdof.physical import identify_lumped  # it builds on this module

        try:  # masses joined by springs and dashpots (the channels at the masses)
            candidates.append(identify_lumped(records, channels, driving_point, prune=prune,
                                              tail_fraction=tail_fraction))
        except (IdentificationError, np.linalg.LinAlgError, ValueError) as exc:
            # said, not silent (session 15: a three-mass chain's lumped candidate refused for masses
            # of ~1e-5 kg, and nothing in the notes told why the modal model was delivered)
            why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            refused = "warning: " + (why if why.startswith("lumped candidate refused") else
                                     f"lumped candidate refused: {why}")
    choice = choose_candidate(candidates, [_candidate_name(c) for c in candidates], records)
    if choice.index == 0 and len(ladder := _prune_ladder(records, args, chosen, coordinates, opts)) > 1:
        candidates += ladder[1:]  # modal coordinates kept: their lower prunes too (only then: cost)
        choice = choose_candidate(candidates, [_candidate_name(c) for c in candidates], records, known=choice.own)
    keep = candidates[choice.index]
    if refused:  # in the model's own notes too (its JSON), not only the diagnosis'
        keep = replace(keep, model=keep.model.model_copy(update={"notes": f"{keep.model.notes}; {refused}"}))
    return replace(keep, notes=tuple(dict.fromkeys(keep.notes + (choice.note,) + ((refused,) if refused else ())
                                                   + _era_note(chosen.modes, channels))),
                   modal_basis=chosen.modal_basis, unresolved=chosen.unresolved)


def _era_note(modes: LinearModes, channels: tuple[str, ...]) -> tuple[str, ...]:
    """What the notes say when the linear modes came from some channels only
    (:func:`eddi.mdof.early.era_windows`' fallback for an essentially nonlinear attachment)."""
    if not modes.pole_channels:
        return ()
    return (f"ERA on every channel found no pole stable over the model orders; the linear modes come from "
            f"{', '.join(channels[c] for c in modes.pole_channels)} alone (a channel with no linear mode of its own, "
            "e.g. an essentially nonlinear attachment, glides with amplitude)",)


#: Lower prunes (times ``prune``) also tried in modal coordinates (:func:`_prune_ladder`).
PRUNE_LADDER = (1.0 / 3.0, 1.0 / 30.0)


def _prune_ladder(records: Sequence[ChannelRecord], args: tuple, chosen: MdofIdentification, coordinates: str,
                  opts: tuple) -> list[MdofIdentification]:
    """``chosen`` and, in modal coordinates with coupling terms, the same identification with the
    prunes of :data:`PRUNE_LADDER` (the candidate rule then keeps the fewest coefficients that
    reproduce the training records within the noise floor).

    Why: a modal coordinate of a lightly damped pair near internal resonance exchanges energy
    through coupling monomials whose forces are 0.1-0.3 % of its inertia force, of the order of its
    damping force (0.3 % damping: 0.6 %). The fixed prune (3e-3 of the inertia force) dropped them:
    session 9's near-1:2 pair left 0.035 held out (floor 0.003) after its shapes were fixed, 0.005
    with prune 1e-4. A lower prune for every record keeps spurious monomials on an uncoupled pair
    (noise and shape error: forces up to 0.4 %, and the work they do per half cycle was up to 17 %
    of the dissipated energy, as large as real couplings'), so neither force nor exchanged energy
    per term tells them apart; the simulated training records do (session 10, docs/multi-dof.md).
    """
    if chosen.coordinates != "modal" or coordinates not in ("auto", "modal") or len(args[0]) < 2:
        return [chosen]
    coupling, tail_fraction, max_freq_hz, prune, highpass_hz = opts
    out = [chosen]
    for factor in PRUNE_LADDER:
        try:
            got = _identify_twice(records, *args, "modal", coupling, tail_fraction, max_freq_hz, prune * factor,
                                  highpass_hz)
        except IdentificationError:
            continue
        out.append(replace(got, notes=got.notes + (f"prune {prune * factor:.2g}",)))
    return out


def _candidate_name(ident: MdofIdentification) -> str:
    """``modal coordinates``, ``physical coordinates`` or ``lumped elements`` (for notes), with the
    prune when it is not the default's."""
    if ident.model.notes.startswith("identified by eddi.mdof.lumped"):
        return "lumped elements"
    prune = next((n for n in ident.notes if n.startswith("prune ")), "")
    return (f"{ident.coordinates} coordinates" + (", filtered equations" if FILTERED_NOTE in ident.notes else "")
            + (f", {prune}" if prune else ""))


def _identify_twice(records: Sequence[ChannelRecord], channels: tuple[str, ...], driving_point: str, d: int,
                    coordinates: str, coupling: bool | str, tail_fraction: float, max_freq_hz: float | None,
                    prune: float, highpass_hz: float | None, *, prefilter: bool = False) -> MdofIdentification:
    """One identification, then (with a force and ``highpass_hz``) a second on restored records.

    ``prefilter``: phase two on drift-filtered columns (:func:`eddi.mdof.equations._design`), said in the notes.
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


def _identify_once(records: Sequence[ChannelRecord], channels: tuple[str, ...], driving_point: str, d: int,
                   coordinates: str, coupling: bool | str, tail_fraction: float, max_freq_hz: float | None,
                   prune: float, *, prefilter: bool = False) -> MdofIdentification:
    modes = linear_modes(records, tail_fraction=tail_fraction, max_freq_hz=max_freq_hz, driving_point=d)
    kind, tmat, span = choose_coordinates(records, modes, coordinates=coordinates)
    bands = (BAND_FRACTION * modes.frequencies_hz if BAND_FRACTION > 0 and kind == "modal"
             and tmat.shape[1] == modes.frequencies_hz.size else None)  # :func:`eddi.mdof.equations.own_band`
    fits = fit_all(records, tmat, coupling, prune, prefilter, bands=bands)
    notes_pre: list[str] = list(_era_note(modes, channels))
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
        phys = fit_all(records, np.eye(tmat.shape[0]), coupling, prune, prefilter)
        r_modal = float(np.mean([f.force_residual for f in fits]))
        r_phys = float(np.mean([f.force_residual for f in phys]))
        if r_phys < 0.5 * r_modal:
            notes_pre.append(f"modal equations close to {100 * r_modal:.2g} %, physical ones to "
                             f"{100 * r_phys:.2g} %: physical coordinates kept")
            kind, tmat, fits = "physical", np.eye(tmat.shape[0]), phys
    if kind == "modal" and tmat.shape[1] == modes.frequencies_hz.size:
        pins = era_stiffness(fits, modes.frequencies_hz, modes.damping_ratios)
        if any(p is not None for p in pins):  # a fit's small-amplitude frequency off the tail's
            fits = fit_all(records, tmat, coupling, prune, prefilter, k_lin=pins, bands=bands)
            notes_pre.append("linear stiffness from the tail's modes (ERA) for mode(s) "
                             + ", ".join(str(i + 1) for i, p in enumerate(pins) if p is not None)
                             + f": their fits' own departed by more than {100 * ERA_TOLERANCE:g} %")
    n = tmat.shape[1]
    proj = np.linalg.pinv(tmat)
    amp = np.sqrt(np.mean(np.hstack([proj @ r.x[:, r.window[0]:r.window[1]] for r in records]) ** 2, axis=1))
    masses, inputs, notes = masses_and_inputs(kind, fits, tmat, d, n, amp,
                                              residue_masses(modes, tmat) if kind == "modal" else None)
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


