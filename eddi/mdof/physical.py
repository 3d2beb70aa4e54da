"""The lumped-element fit (:mod:`eddi.mdof.lumped`) as an :class:`MdofIdentification`.

The elements are written out as monomials of the physical coordinates (a cubic spring between
masses 1 and 2 is ``k3 (x1 - x2)^3``: ``x1^3, x1^2*x2, x1*x2^2, x2^3`` in both equations with
tied coefficients), so the model is an ordinary version-2 equation-of-motion model: it
simulates, validates, refines and loads in the rig like any other.

No I/O.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from eddi.errors import IdentificationError
from eddi.threads import one_blas_thread
from eddi.mdof.identify import (ChannelRecord, EquationFit, MdofIdentification, linear_modes,
                                restore_quasi_static)
from eddi.mdof.candidates import records_floor, training_error
from eddi.mdof.lumped import (NONLINEAR_KINDS, PREFILTER_RATIO, Element, LumpedFit, candidate_elements, driven_mass,
                              element_terms, fit_lumped)
from eddi.mdof.massprior import prior_weights, records_prior, refusal_note
from eddi.mdof.mechanisms import mechanism_note
from eddi.mdof.model import MdofModel
from eddi.mdof.slowband import KNOTS_PER_CUTOFF, restore_slow_band

#: Rows start this many periods of the column filter's cut-off after the free window's start.
#: The frequencies move by a few 0.01 % with the start (measured, 45 dB: two-mass chain best at
#: 0.6, the 1:3 system at 1.5 periods), and a ring-down of 100 cycles turns 0.05 % into a visible
#: phase error; so only starts whose model reproduces the training records within the noise
#: floor of the best are eligible, and of those the one that determines the cubic springs best
#: (:func:`_informative`) is kept. Session 8 kept the smallest training error among 0.6, 1.0,
#: 1.5: a weak cubic spring (3 % of the coupling force) then came out +2.9 % on average, because
#: the later starts drop the large-amplitude cycles the cubic shows in and the training error
#: hardly sees a 3 % change of it (``bench_mdof.py --coupling-anatomy``). Session 9: 0 and 0.3
#: added (the earliest rows carry the most information on the cubic: its ci95 4.9-7.8 % from 0
#: against 13-73 % from 0.6 on the 3 % chains).
SETTLE_CHOICES = (0.0, 0.3, 0.6, 1.0, 1.5)
#: Slow bases tried (knots per period of the cut-off ``f_c``; 4 spans the band to about ``f_c``, 8
#: to about ``2 f_c``, half the lowest mode): the one whose model reproduces the training records
#: best is kept (:func:`_pick`). Session 10: on three-mass chains at 45 dB the displacement's
#: noise (accelerometer noise integrated twice, strongest just above ``f_c``) biased the cubic
#: springs low as errors in the variables (own chain with two cubic couplings: -8.4 / -2.7 % with
#: 4 knots, -3.0 / +0.3 % with 8; noise-free 0.05 / 0.1 % with 4); the restored band takes the
#: noise's slow part out with the quasi-static one. 4 stays a choice: 8 was worse on the energy
#: sink (session 6).
SLOW_KNOTS = (KNOTS_PER_CUTOFF, 2.0 * KNOTS_PER_CUTOFF)
#: Rounds of quasi-static restoration and rescaling of the driven mass (it converges in two).
RESCALE_ROUNDS = 2
#: Rounds of the instrumental-variable refit (:func:`_iv_fit`): instruments from the model kept so
#: far, then from the first refit's model.
IV_ROUNDS = 2


@one_blas_thread()
def identify_lumped(records: Sequence[ChannelRecord], channels: Sequence[str], driving_point: str, *,
                    prune: float = 3e-3, tail_fraction: float = 0.2, slow_band: bool = True,
                    instruments: bool = True, couplings: bool = True, mass_prior: bool = True) -> MdofIdentification:
    """Masses, springs and dashpots between the measured masses and the ground (no mass given).

    Parameters
    ----------
    records : sequence of ChannelRecord
        One channel per mass (displacement, velocity, acceleration), force at the driving point.
    channels : sequence of str
    driving_point : str
    prune : float
    tail_fraction : float
        For the linear modes reported beside the model (ERA on the tail).
    slow_band : bool
        Also refit the kept elements with the slow band of the displacement restored
        (:mod:`eddi.mdof.slowband`); kept when it reproduces the training records better.
    instruments : bool
        Also refit the kept elements with instrumental variables from the kept model's simulation
        (:func:`_iv_fit`) where the kept fit is above twice the records' noise floor; kept when it
        reproduces the training records better by more than the floor.
    couplings : bool
        False: dashpots and linear springs only (no cubic spring is a candidate, none is put back):
        the linear lumped baseline of diagnosis (:func:`station.mdof_folds._lumped_baseline`).
    mass_prior : bool
        With a force and as many modes as channels, also fit every rows' start with the masses
        regularised by those the driving-point residues expect (:mod:`eddi.mdof.massprior`); the
        variants are judged alike (training nrmse, then the cubic springs' intervals). False: the
        rows' fits alone (session 15's fit).
    """
    channels = tuple(channels)
    candidates = [e for e in candidate_elements(len(channels)) if couplings or e.kind in LINEAR_KINDS]
    d = channels.index(driving_point)
    n = len(channels)
    floor = records_floor(records)
    modes = linear_modes(records, tail_fraction=tail_fraction, driving_point=d)
    expected = records_prior(records, modes) if mass_prior else None
    tried, settles, helds, priors, refused = [], {}, {}, {}, []
    for settle in SETTLE_CHOICES:
        plain = _fit(records, n, d, prune, settle, candidates)
        variants = [(plain, None, "")]
        if expected is not None:  # the same rows with the masses the residues expect (eddi.mdof.massprior)
            prior = prior_weights(expected, plain, d)
            variants.append((_fit(records, n, d, prune, settle, candidates, prior=prior), prior,
                             ", masses regularised by the residues' expectation"))
        for fit0, prior, how in variants:
            if not np.all(np.asarray(fit0.masses) > 0):
                refused.append(f"{settle:g} periods{', regularised' if prior is not None else ''}: "
                               + " / ".join(f"{m:.3g}" for m in fit0.masses) + " kg")
                continue
            got = _scored(lambda: fit0, records, channels, driving_point, d)
            err, fit, held, back = _undetermined_back(records, got[0], got[1], n, d, prune, settle, floor, channels,
                                                      driving_point, prior=prior)
            tried.append((err, fit, f"rows from {settle:g} periods of the column filter after the blow{how}{back}"))
            settles[id(fit)], helds[id(fit)], priors[id(fit)] = settle, held, prior
    if not tried:
        raise IdentificationError(refusal_note(refused, expected))
    err, fit, rows_note = _pick(tried, floor)
    settle = settles[id(fit)]
    ctx = _Context(records, n, d, prune, settle, floor, channels, driving_point, couplings, slow_band, instruments,
                   priors[id(fit)])
    err, fit, rows_note, slow_note, form_error = _stages(ctx, err, fit, rows_note, helds[id(fit)])
    form_error = min([t[0] for t in tried] + [form_error])
    model = lumped_model(fit, channels, driving_point, d, len(records))
    notes = [f"lumped elements: {', '.join(f'{e.label} {c:.4g}' for e, c in fit.constants.items())} "
             f"({rows_note}{slow_note})"]
    if expected is not None:
        notes.append(expected.note() + "; fitted " + " / ".join(f"{m:.3g}" for m in fit.masses) + " kg")
    if refused:
        notes.append(f"lumped variants refused for a non-positive mass (rows from {'; '.join(refused)})")
    if all(r.force is None for r in records):
        notes.append("no force: every mass per unit driven mass")
    eqs = tuple(_equation(model, fit, i) for i in range(n))
    # ``err`` is ``model``'s training nrmse (:func:`_scored` built the same model from ``fit``)
    return MdofIdentification(model, modes, "physical", eqs, 0.0, tuple(notes), True, lumped=fit,
                              form_error=float(form_error), training_nrmse=float(err))


@dataclass(frozen=True)
class _Context:
    """What the stages of :func:`identify_lumped` after the rows' fit share."""

    records: Sequence[ChannelRecord]
    n: int
    d: int
    prune: float
    settle: float
    floor: float
    channels: tuple[str, ...]
    driving_point: str
    couplings: bool
    slow_band: bool
    instruments: bool
    prior: tuple | None = None


def _stages(ctx: _Context, err: float, fit: LumpedFit, rows_note: str, held: frozenset = frozenset()
            ) -> tuple[float, LumpedFit, str, str, float]:
    """Weak cubics put back, the slow band restored, instrumental variables (:func:`identify_lumped`'s
    notes), from the rows' fit ``fit`` (training nrmse ``err``); ``held``: elements never dropped.
    Returns the training nrmse, the fit, the rows' note, the stages' note and the least training
    nrmse any stage reached."""
    records, n, d, prune, settle, floor = ctx.records, ctx.n, ctx.d, ctx.prune, ctx.settle, ctx.floor
    channels, driving_point = ctx.channels, ctx.driving_point
    err, fit, ground_note = ground_springs(ctx, err, fit, held)
    err, fit, held, damp_note = weak_dashpots(ctx, err, fit, held)
    damp_note = ground_note + damp_note
    err, fit, keep, slow_note = _weak_cubics(records, err, fit, n, d, prune, settle, floor, channels, driving_point,
                                             ctx.couplings, held, ctx.prior)
    slow_note = damp_note + slow_note
    form_error = err
    if ctx.slow_band:
        slows = []
        for knots in SLOW_KNOTS:
            got = _scored(lambda: _slow_fit(records, fit, n, d, prune, knots, keep, ctx.prior), records, channels,
                          driving_point, d)
            if got is not None:
                slows.append(got + (knots,))
        for err_slow, slow, (before, after), knots in slows:
            form_error = min(form_error, err_slow)
            slow_note += (f"; slow band restored to {knots / 4:g} f_c (force balance {np.sqrt(before):.3g} -> "
                          f"{np.sqrt(after):.3g} of the inertia RMS; training nrmse {err_slow:.3g})")
        restored = [(e, f, f"rows from the blow, slow band restored to {k / 4:g} f_c") for e, f, _c, k in slows]
        kept = _pick([(err, fit, rows_note)] + restored, floor, frozenset(t[2] for t in restored))
        slow_note += f"; prefiltered {err:.3g}; kept: {kept[2]}" if slows else ""
        err, fit, rows_note = kept
    # the instruments cost variance (the noise is not averaged away as in least squares): their
    # fit is kept only where the bias it removes shows in the training records beyond the noise
    # floor, so it is not tried where the kept fit is within twice the floor (no model reproduces
    # the records much better than the floor: the true one leaves about the floor)
    if ctx.instruments and any(r.force is not None for r in records) and err > 2.0 * floor:
        got = _scored(lambda: _iv_fit(records, fit, n, d, prune, settle, keep, ctx.prior), records, channels,
                      driving_point, d)
        if got is not None:
            form_error = min(form_error, got[0])
            slow_note += f"; instrumental variables: training nrmse {got[0]:.3g}"
            if got[0] + floor < err:
                err, fit = got[0], got[1]
                rows_note = f"rows from {settle:g} periods, instrumental variables from the simulated model"
    return err, fit, rows_note, slow_note, form_error


def ground_springs(ctx: _Context, err: float, fit: LumpedFit, held: frozenset = frozenset()
                   ) -> tuple[float, LumpedFit, str]:
    """Ground springs the training records do not demand, dropped (a linear one with its cubic; a
    cubic one without a linear spring at its mass alone).

    Why (session 15, a 1 / 0.5 / 2 kg chain struck at mass 2, 50 dB, no ground spring at mass 2):
    the rows' fit kept k(0-2) 1.95e5 N/m (and k3(0-2)) and mass 1 came out 39 % low. While the
    unstruck mass 1 moves little, a ground spring at the struck mass and its link springs are nearly
    one column: the spring stands in for part of the link, and the masses follow. A ground spring is
    kept only when the data demand it: the refit without it (and its cubic) loses training error,
    in quadrature ``sqrt(e_without^2 - e_with^2)``, beyond the records' noise floor. Otherwise the
    refit without it is kept (the least demanded first, repeated). One so demanded whose 95 %
    interval holds zero is kept and said ("kept though undetermined"), the rule of
    :func:`_undetermined_back`: dropping it on the interval alone took the same chain's training
    nrmse from 0.242 to 0.414 (k(0-3) 9.4e3 +- 1.7e4 N/m, none in the truth). A true ground spring
    carries the static load of its mass: without it the mass's frequency or its whole mode moves,
    and the training records show that far above the floor (a true 5e5 N/m one at the struck mass
    of the same chain: kept, ``tests/eddi/test_mdof_ground_spring.py``).
    Returns the error, the fit and a note."""
    records, n, d = ctx.records, ctx.n, ctx.d
    note = ""
    while True:
        weak, needed = [], ""
        for e in [e for e in fit.constants if e.a == 0 and (e.kind == "k" or (
                e.kind == "k3" and Element("k", 0, e.b) not in fit.constants))]:
            drop = {e, Element("k3", 0, e.b)}
            elements = [x for x in fit.constants if x not in drop]
            got = _scored(lambda: _fit(records, n, d, ctx.prune, ctx.settle, elements, prior=ctx.prior,
                                       keep=frozenset(held) & set(elements)), records, ctx.channels,
                          ctx.driving_point, d)
            if got is None or not np.isfinite(got[0]):
                continue
            removes = float(np.sqrt(max(got[0] ** 2 - err**2, 0.0)))
            if not removes > ctx.floor:
                weak.append((removes, e, got))
            elif not abs(fit.constants[e]) > fit.ci95.get(e, np.inf):
                needed += (f"; {e.label} {fit.constants[e]:.3g} +- {fit.ci95.get(e, np.inf):.2g} kept though undetermined: "
                         f"the training records need it ({removes:.3g} in quadrature, floor {ctx.floor:.3g})")
        if not weak:
            return err, fit, note + needed
        removes, e, got = min(weak, key=lambda t: t[0])
        note += (f"; {e.label} {fit.constants[e]:.3g} +- {fit.ci95.get(e, np.inf):.2g} dropped: not demanded by the "
                 f"training records (it removes {removes:.3g} in quadrature, floor {ctx.floor:.3g}; training nrmse "
                 f"{err:.3g} -> {got[0]:.3g})")
        err, fit = got[0], got[1]


def weak_dashpots(ctx: _Context, err: float, fit: LumpedFit, held: frozenset = frozenset()
                  ) -> tuple[float, LumpedFit, frozenset, str]:
    """Dashpots the force rule pruned, put back where the simulated training records show them.

    Why: :func:`eddi.mdof.lumped.fit_lumped` drops an element whose force is under ``prune`` (3e-3)
    of the inertia force, and a dashpot's force is ``2 zeta`` of it at most: a light dashpot
    between two masses (a Rayleigh share ``beta k``) sits under that rule, yet over a ring-down of
    ``N`` cycles it sets the decay (``exp(-2 pi N zeta)``). Session 15 (``bench_mdof_target.py
    --seed 5``, chain-5-5: 0.75 + 0.49 kg, 10 / 25 Hz, 4 s): c(1-2) 0.114 N s/m (0.15 % of the
    inertia force) was dropped; c(0-1) and c(0-2) stood in for it and the lumped fit reproduced its
    training records at 0.090 (the true model 0.006), so the modal candidate (0.026) was delivered,
    a coupling coefficient 9 % off, the channels 2-3x the truth's held out. Put back: 0.0056, every
    constant within 3 % of the truth. The test is :func:`_weak_cubics`' (the training error it
    removes in quadrature exceeds the records' floor), and the dashpot must be passive and
    determined (its 95 % interval excludes zero). One at a time, the best first, while the error
    is above the floor. Returns the error, the fit, ``held`` with the dashpots kept, and a note."""
    records, n, d = ctx.records, ctx.n, ctx.d

    def tries(fit: LumpedFit, keep: set) -> list:
        out = []
        for cand in [e for e in candidate_elements(n) if e.kind == "c" and e not in fit.constants]:
            elements, hold = list(fit.constants) + [cand], frozenset(keep | {cand})
            got = _scored(lambda: _fit(records, n, d, ctx.prune, ctx.settle, elements, prior=ctx.prior, keep=hold),
                          records, ctx.channels, ctx.driving_point, d)
            if got is None or not np.isfinite(got[0]) or cand not in got[1].constants:
                continue
            c = got[1].constants[cand]
            if c > 0 and abs(c) > got[1].ci95.get(cand, np.inf):
                out.append((cand, got))
        return out

    return _put_back(err, fit, set(held), ctx.floor, tries, "kept though its force is under the pruning rule")


def _weak_cubics(records: Sequence[ChannelRecord], err: float, fit: LumpedFit, n: int, d: int, prune: float,
                 settle: float, floor: float, channels: tuple[str, ...], driving_point: str,
                 couplings: bool = True, held: frozenset = frozenset(), prior: tuple | None = None
                 ) -> tuple[float, LumpedFit, frozenset, str]:
    """Cubic springs the force rule pruned, put back where the simulated training records show them.

    Why: :func:`fit_lumped` drops an element whose force is under ``prune`` of the inertia force;
    a weak cubic coupling on lightly damped records (under 1 % of its spring's force at the
    blows trained on) passes that rule and is dropped, yet its effect on the frequency grows in
    phase over the many cycles of a ring-down (session 11: a 16 + 5 kg chain trained on its three
    small blows pruned it; the linear model predicted the held-out large blow at 0.049, the true
    one at 0.004). The test is the training records' own error: each cubic spring of a linear
    spring kept (``k3`` between the same nodes) is refitted in and kept when the error it removes,
    in quadrature (``sqrt(e_without^2 - e_with^2)``), exceeds the records' noise floor (what noise
    alone leaves; a cubic fitted to the noise of a linear chain removes far less) and, between two
    masses, its 95 % interval excludes zero (:func:`_determined`). One at a time, the largest
    first, until none passes. ``held``: elements already kept (:func:`_undetermined_back`). Returns
    the error, the fit, the elements kept (``held`` and the cubics) and a note.
    """
    def tries(fit: LumpedFit, keep: set) -> list:
        out = []
        for e in list(fit.constants):
            cubic = Element("k3", e.a, e.b)
            if e.kind != "k" or cubic in fit.constants or not couplings:
                continue
            elements, hold = list(fit.constants) + [cubic], frozenset(keep | {cubic})
            got = _scored(lambda: _fit(records, n, d, prune, settle, elements, prior=prior, keep=hold),
                          records, channels, driving_point, d)
            if got is not None and np.isfinite(got[0]) and _determined(got[1], cubic):
                out.append((cubic, got))
        return out

    return _put_back(err, fit, set(held), floor, tries, "kept though weak")


def _put_back(err: float, fit: LumpedFit, keep: set, floor: float, tries, why: str
              ) -> tuple[float, LumpedFit, frozenset, str]:
    """Elements put back one at a time, the one whose refit removes the most training error (in
    quadrature, ``sqrt(e_without^2 - e_with^2)``) first, while that exceeds the records' noise
    floor. ``tries(fit, keep)`` lists ``(element, (error, fit, ...))`` refits that may be kept
    (:func:`weak_dashpots`, :func:`_weak_cubics`). Returns the error, the fit, ``keep`` with the
    elements kept, and a note."""
    note = ""
    while err > floor:  # else nothing can pass: the error an element removes is at most ``err``
        scored = [(float(np.sqrt(max(err**2 - got[0] ** 2, 0.0))), got, e) for e, got in tries(fit, keep)]
        if not scored:
            break
        removed, (err_c, fit_c), e = max(scored, key=lambda t: t[0])
        if not removed > floor:
            break
        note += (f"; {e.label} {why}: training nrmse {err:.3g} -> {err_c:.3g} "
                 f"({removed:.3g} in quadrature, floor {floor:.3g})")
        err, fit = err_c, fit_c
        keep.add(e)
    return err, fit, frozenset(keep), note


#: Element kinds of the linear lumped baseline (``couplings=False``).
LINEAR_KINDS = ("c", "k")


def _undetermined_back(records: Sequence[ChannelRecord], err: float, fit: LumpedFit, n: int, d: int, prune: float,
                       settle: float, floor: float, channels: tuple[str, ...], driving_point: str, *,
                       prior: tuple | None = None) -> tuple[float, LumpedFit, frozenset, str]:
    """The couplings :func:`fit_lumped` dropped as undetermined (interval holding zero), put back
    when the refit without them loses training error beyond the floor: the refit that keeps them
    (never dropped) reproduces the training records better by more than the records' floor, in
    quadrature (``sqrt(e_without^2 - e_with^2) > floor``, as :func:`_weak_cubics`). Kept, such a
    coupling stays undetermined: the model predicts with it and nothing names it
    (:func:`eddi.mdof.verdict.undetermined_coupling`, the ``determined`` flag of
    :mod:`eddi.mdof.mechanisms`).

    Why (session 13, l1-14 of ``bench_mdof_lumped.py --seed 1``: 31.4 + 6.1 kg, a true cubic spring
    between the masses at 17 % of the link's force, 35 dB): the drop rule took out the true k3(1-2)
    (+2.2e15 +- 5e15 N/m^3 on main before it), a quadratic spring stood in for it, and the training
    error rose 0.038 -> 0.051; on its rows from the blow the refit without k3(1-2) and k2(1-2) left
    0.106, with them 0.046 (floor 0.017). Returns the error, the fit, the couplings kept and a note."""
    back = tuple(e for e in fit.undetermined if e not in fit.constants)
    if not back or not err > floor:
        return err, fit, frozenset(), ""
    held = frozenset(back)
    got = _scored(lambda: _fit(records, n, d, prune, settle, list(fit.constants) + list(back), prior=prior,
                               keep=held), records, channels, driving_point, d)
    if got is None or not np.isfinite(got[0]):
        return err, fit, frozenset(), ""
    removed = float(np.sqrt(max(err**2 - got[0] ** 2, 0.0)))
    if not removed > floor:
        return err, fit, frozenset(), ""
    return got[0], got[1], held, (f"; {', '.join(e.label for e in back)} kept though undetermined: the training "
                                  f"records need it (training nrmse {err:.3g} -> {got[0]:.3g}, {removed:.3g} in "
                                  f"quadrature, floor {floor:.3g})")


def _determined(fit: LumpedFit, e: Element) -> bool:
    """False for a coupling between masses whose 95 % interval holds zero (not put back: the rule of
    :func:`eddi.mdof.lumped.undetermined_couplings`; session 13, c2-3 of ``bench_mdof_wide.py
    --seed 2``: a cubic spring across a nearly rigid link was put back for the training error it
    removed, 0.0253 -> 0.0178, and the diagnosis named a coupling that is not there)."""
    c = fit.constants.get(e, 0.0)
    return not e.coupling or abs(c) > fit.ci95.get(e, np.inf)


def _informative(fit: LumpedFit) -> float:
    """Sum of the squared relative 95 % half-widths of the nonlinear elements (cubic, quadratic
    springs, cubic dampers; of every constant when there is none): smaller means the rows determine the nonlinear elements better."""
    keys = [e for e in fit.constants if e.kind in NONLINEAR_KINDS] or list(fit.constants)
    return float(sum((fit.ci95.get(e, np.inf) / max(abs(fit.constants[e]), 1e-300)) ** 2 for e in keys))


def _pick(tried: list[tuple[float, LumpedFit, str]], floor: float, preferred: frozenset = frozenset()
          ) -> tuple[float, LumpedFit, str]:
    """Of ``(training nrmse, fit, note)`` those within ``floor`` of the best training nrmse; of
    them the one that determines the cubic springs best (:func:`_informative`). A tie there (to
    1e-9 relative) goes to the notes in ``preferred``, then to the lower training nrmse.

    Why the tie: a slow-band fit's intervals are floored at the relative widths of the fit it
    started from (:func:`_slow_fit`), so where its own are narrower it ties with that fit, and
    the last bit of the two sums decided (session 12: a solve equal to rounding flipped a
    16 + 5 kg chain's cubic from the restored fit, -3.6 %, to the prefiltered one, -19 %)."""
    best = min(t[0] for t in tried)
    fair = [t for t in tried if t[0] <= best + floor] if np.isfinite(best) else tried
    info = [_informative(t[1]) for t in fair]
    top = min(info)
    tied = [t for t, v in zip(fair, info) if v <= top + 1e-9 * abs(top)]
    return min(tied, key=lambda t: (t[2] not in preferred, t[0]))


def _rows(records: Sequence[ChannelRecord], settle_periods: float) -> list[tuple]:
    """:func:`fit_lumped`'s record tuples, rows from ``settle_periods`` of the column filter's
    cut-off after the free window's start."""
    full = []
    for r in records:
        rate = 1.0 / float(r.t[1] - r.t[0])
        settle = int(settle_periods * rate / (PREFILTER_RATIO * r.highpass_hz))
        full.append((r.x, r.v, r.a, r.force, (min(r.window[0] + settle, r.window[1] - 1), r.window[1]), rate,
                     r.highpass_hz))
    return full


def _fit(records: Sequence[ChannelRecord], n: int, d: int, prune: float, settle_periods: float,
         elements: list[Element] | None = None, *, prior: tuple | None = None, keep: frozenset = frozenset()
         ) -> LumpedFit:
    """:func:`fit_lumped` on the records' free windows after the filter settles (``elements``: its
    candidates, default every one; ``prior``: its ``mass_prior``), scaled by the pulse of the records
    restored from its own receptance (module docstring of :mod:`eddi.mdof.lumped`)."""
    return _rescaled(fit_lumped(_rows(records, settle_periods), _pulses(records), n, d, prune=prune,
                                elements=None if elements is None else list(elements), keep=keep,
                                mass_prior=prior), records, n, d)


def _scored(fit_fn, records: Sequence[ChannelRecord], channels: tuple[str, ...], driving_point: str, d: int):
    """``(training nrmse, fit[, extra])`` of the fit ``fit_fn()`` returns (a fit or ``(fit, extra)``),
    None when its masses are not all positive (no model: a variant the noise has thrown off, e.g.
    rows on a light driven mass whose displacement is mostly integrated noise)."""
    got = fit_fn()
    fit, extra = (got, None) if isinstance(got, LumpedFit) else (got[0], got[1:])
    if not np.all(np.asarray(fit.masses) > 0):
        return None
    err = training_error(lumped_model(fit, channels, driving_point, d, len(records)), records)
    return (err, fit) if extra is None else (err, fit, extra)


def _slow_fit(records: Sequence[ChannelRecord], start: LumpedFit, n: int, d: int, prune: float,
              knots: float = KNOTS_PER_CUTOFF, keep: frozenset = frozenset(), prior: tuple | None = None
              ) -> tuple[LumpedFit, float, float]:
    """The elements of ``start`` refitted with the slow band restored (:mod:`eddi.mdof.slowband`),
    rows from the blow (with a force: the driven mass and the quasi-static response are in the
    same fit), no prefilter; returns the fit and the force-balance cost before and after."""
    elements = list(start.constants)
    forced = all(r.force is not None and r.impact[1] > r.impact[0] for r in records)
    starts = [r.impact[0] for r in records] if forced else None
    restored, _m, before, after = restore_slow_band(_rows(records, 0.0), elements, start.masses, start.constants,
                                                    n, d, starts=starts, knots_per_cutoff=knots)
    fixed = [replace(r, x=t[0], v=t[1]) for r, t in zip(records, restored)]
    fit = fit_lumped(restored, _pulses(fixed), n, d, elements=elements, prune=prune, prefilter=False, keep=keep,
                     mass_prior=prior)
    # the restored band was estimated from the same rows, and the refit's jackknife takes it as
    # known: its intervals are no narrower (relative) than those of the fit it started from
    # (session 10: restored to 2 f_c, a two-mass chain's cubic read +0.21 % +- 0.06 %)
    ci = {e: max(h, abs(fit.constants[e]) * start.ci95.get(e, 0.0) / max(abs(start.constants.get(e, 0.0)), 1e-300))
          for e, h in fit.ci95.items()}
    fit = LumpedFit(fit.masses, fit.constants, ci, fit.residual)
    return (fit if forced else _rescaled(fit, records, n, d)), before, after


def _iv_fit(records: Sequence[ChannelRecord], start: LumpedFit, n: int, d: int, prune: float, settle: float,
            keep: frozenset = frozenset(), prior: tuple | None = None) -> LumpedFit:
    """The elements of ``start`` refitted with instrumental variables (:func:`fit_lumped`).

    Why: the measured displacement is the accelerometer's signal integrated twice; its noise
    (strongest just above the drift filter's cut-off) is an error in the variables of every
    spring column, and least squares on noisy columns is biased towards zero (session 10: cubic
    springs -8.4 / -2.7 % on a three-mass chain; session 11: a chain struck at a 1 kg mass on a
    stiff ground spring, whose displacement floor is 1.8x the others', lost the lumped candidate,
    training nrmse 0.18 against 0.05 for modal coordinates). The instruments are the states of
    the model fitted so far, simulated over each record from its blow and conditioned as the
    record was (drift high-pass twice on ``x``, once on ``v``): correlated with the true states,
    not with the measurement's noise. Refitted :data:`IV_ROUNDS` times (the instruments of the
    second from the first refit). Returns ``start`` when a simulation diverges.
    """
    fit = start
    for k in range(IV_ROUNDS):
        inst = _instrument_rows(records, fit, n, d, _rows(records, settle))
        if inst is None:
            return start if k == 0 else _rescaled(fit, records, n, d)
        # the quasi-static rescaling after the last round only (the rounds between at the start's
        # driven mass: the instruments' states hardly depend on it; session 11 rescaled every round)
        fit = _scaled_like(fit_lumped(_rows(records, settle), _pulses(records), n, d, elements=list(start.constants),
                                      prune=prune, instruments=inst, keep=keep, mass_prior=prior), start, d)
        if not np.all(fit.masses > 0):  # no model to simulate: the variant is turned down (:func:`_scored`),
            return fit  # not the candidate lost (session 15: a ModelError here refused a chain's lumped fit)
    return _rescaled(fit, records, n, d)


def _scaled_like(fit: LumpedFit, ref: LumpedFit, d: int) -> LumpedFit:
    """``fit`` scaled to ``ref``'s driven mass (masses, constants and intervals alike)."""
    scale = float(ref.masses[d] / fit.masses[d]) if fit.masses[d] != 0 else 1.0
    return LumpedFit(fit.masses * scale, {e: c * scale for e, c in fit.constants.items()},
                     {e: h * scale for e, h in fit.ci95.items()}, fit.residual, fit.undetermined)


def _instrument_rows(records: Sequence[ChannelRecord], fit: LumpedFit, n: int, d: int, rows: Sequence[tuple]
                     ) -> list[tuple] | None:
    """``rows`` (:func:`_rows` tuples) with the states of ``fit``'s model simulated over each record,
    conditioned as the records were (None if a simulation diverges)."""
    from eddi.mdof.signals import highpass
    from eddi.mdof.simulate import simulate_mdof
    from eddi.mdof.validate import simulation_start

    channels = tuple(f"c{i}" for i in range(n))
    model = lumped_model(fit, channels, channels[d], d, len(records))
    out = []
    for r, row in zip(records, rows):
        st = simulation_start(model, r)
        sim = simulate_mdof(model, r.t[st.sample:], st.force, x0=st.x0, v0=st.v0, states=st.states)
        if sim.diverged or not np.all(np.isfinite(sim.x)):
            return None
        x, v, a = (np.zeros((n, r.t.size)) for _ in range(3))
        x[:, st.sample:], v[:, st.sample:], a[:, st.sample:] = sim.x, sim.v, sim.a
        rate, fc = row[5], row[6]
        out.append((highpass(x, rate, fc, 2), highpass(v, rate, fc, 1), a) + row[3:])
    return out


def _rescaled(fit: LumpedFit, records: Sequence[ChannelRecord], n: int, d: int) -> LumpedFit:
    """The fit scaled by the driven mass from the pulses, with the quasi-static part restored."""
    # no model without positive masses (:func:`_scored` turns such a fit down; session 13: a mass
    # whose every element was dropped comes out as zero, and the model's validation raised)
    if all(r.force is None for r in records) or not np.all(np.asarray(fit.masses) > 0):
        return fit
    channels = tuple(f"c{i}" for i in range(n))
    for _ in range(RESCALE_ROUNDS):
        model = lumped_model(fit, channels, channels[d], d, len(records))
        unit = 1.0 / fit.masses[d]
        scale = driven_mass(_pulses([restore_quasi_static(r, model) for r in records]), fit.masses * unit,
                            {e: c * unit for e, c in fit.constants.items()}, d) * unit
        fit = LumpedFit(fit.masses * scale, {e: c * scale for e, c in fit.constants.items()},
                        {e: h * scale for e, h in fit.ci95.items()}, fit.residual, fit.undetermined)
    return fit


def _pulses(records: Sequence[ChannelRecord]) -> list[tuple]:
    """``(x, v, a, force)`` over each record's hammer pulse (to the free window's start)."""
    out = []
    for r in records:
        if r.force is not None and r.impact[1] > r.impact[0]:
            i0, i1 = r.impact[0], max(r.impact[1], r.window[0]) + 3
            out.append((r.x[:, i0:i1], r.v[:, i0:i1], r.a[:, i0:i1], r.force[i0:i1]))
    return out


def lumped_model(fit: LumpedFit, channels: tuple[str, ...], driving_point: str, d: int, n_records: int
                 ) -> MdofModel:
    """The fit written as monomials (module docstring), with each monomial's interval."""
    n = len(channels)
    damping: list[dict[str, float]] = [{} for _ in range(n)]
    stiffness: list[dict[str, float]] = [{} for _ in range(n)]
    var: list[dict[str, float]] = [{} for _ in range(n)]
    for e, c in fit.constants.items():
        h = fit.ci95.get(e, np.inf)
        for i, terms in element_terms(e, n).items():
            target = damping[i] if e.on_rate else stiffness[i]
            for t, fac in terms.items():
                target[t] = target.get(t, 0.0) + fac * c
                if not e.on_rate:
                    var[i][t] = var[i].get(t, 0.0) + (fac * h) ** 2
    return MdofModel.create(
        coordinates="physical", mass=tuple(float(m) for m in fit.masses),
        input=tuple(1.0 if i == d else 0.0 for i in range(n)),
        damping=tuple(damping), stiffness=tuple(stiffness),
        stiffness_ci95=tuple({t: float(np.sqrt(s)) for t, s in v.items()} for v in var),
        channels=channels, shapes=tuple(tuple(1.0 if r == c else 0.0 for c in range(n)) for r in range(n)),
        driving_point=driving_point,
        notes=f"identified by eddi.mdof.lumped from {n_records} record(s); physical coordinates, "
              "springs and dashpots between the masses and the ground; nonlinear elements: "
              + mechanism_note(fit.constants, fit.ci95))


def _equation(model: MdofModel, fit: LumpedFit, i: int) -> EquationFit:
    m = model.mass[i]
    return EquationFit({t: c / m for t, c in model.damping[i].items()},
                       {t: c / m for t, c in model.stiffness[i].items()},
                       model.input[i] / m, float("nan"), float("nan"), 0, float(fit.residual[i]),
                       {t: h / m for t, h in model.stiffness_ci95[i].items()})
