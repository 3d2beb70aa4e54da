"""EDDI per coordinate with coupling terms: the library, phases one and two, the input gain.

Equation ``i`` of coordinates ``q`` (modal or physical, per unit mass): damping ``v_1..v_n``,
own stiffness ``x_i, x_i^3``, coupling stiffness ``x_j`` and every cubic monomial but ``x_i^3``
(:func:`default_library`). Phase one balances the energy of each half cycle of ``q_i`` between
its zero crossings, phase two fits the conservative force sample by sample, a sequential
threshold prunes terms, and the impact gives the force per unit mass (:func:`fit_equation`;
the method in :mod:`eddi.mdof.identify`). Each equation is fitted where its coordinate's own
motion lives (:func:`own_span`); a modal fit whose small-amplitude frequency departs from the
tail's takes the tail's linear stiffness (:func:`era_stiffness`); a modal equation's phase two
runs on its own band, above a fraction of its mode's frequency (:func:`own_band`).

No I/O.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from eddi.energy import cumulative_energy, rate_interpolant, zero_crossings
from eddi.errors import IdentificationError
from eddi.mdof.intervals import JACKKNIFE_BLOCKS, jackknife_lstsq_ci95
from eddi.mdof.records import ChannelRecord
from eddi.mdof.signals import highpass
from eddi.mdof.terms import MultiTerm, monomial, parse_multi_term
from eddi.phase_one import scaled_lstsq


#: Passes of the drift high-pass over phase two's columns when ``prefilter`` (:func:`_design`).
#: Not always on: measured (``bench_mdof_error_budget.py``) it lowers the two-mass chain's
#: worst coefficient in physical coordinates from 6.3 to 3.6 % but raises the 1:3 system's in
#: modal ones from 12 to 36 %; ``coordinates="auto"`` fits both and keeps the better predictor.
PREFILTER_PASSES = 1
FILTERED_NOTE = "phase two on drift-filtered equations (columns and force through the drift high-pass)"

#: :func:`own_span`: blocks per free window, the rise over the tail's floor that counts as the
#: coordinate's own motion [dB], the least share of the window kept.
SPAN_BLOCKS = 50
SPAN_DB = 20.0
SPAN_MIN = 0.1
#: :func:`era_stiffness`: the departure of a fit's small-amplitude frequency from the tail's that
#: hands its linear stiffness to the tail (a fixed figure: ERA's own uncertainty is not computed).
ERA_TOLERANCE = 0.03


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
    for rec in full:
        q, qd, qdd, force, (s, e), rate, fc = rec[:7]
        if len(rec) > 7:  # :func:`own_band`: each column filtered once, kept for the prune's later rounds
            parts.append(_banded_columns(rec[7], i, d_terms + s_terms, q, qd, qdd, force, rate, fc)[s:e])
            continue
        cols = [_matrix(d_terms, q, qd), _matrix(s_terms, q, qd), -qdd[i][:, None],
                (force if force is not None else np.zeros(q.shape[1]))[:, None]]
        big = highpass(np.hstack(cols).T, rate, fc, PREFILTER_PASSES).T[s:e]
        parts.append(big)
    big = np.vstack(parts)
    nd, ns = len(d_terms), len(s_terms)
    return big[:, :nd], big[:, nd:nd + ns], big[:, nd + ns], big[:, nd + ns + 1:]


def fit_equation(i: int, data: list[tuple], impacts: list[tuple], lib: Library, noise: float,
                 prune: float = 3e-3, max_exchange: float = 1.0, full: list[tuple] | None = None,
                 k_lin: float | None = None) -> EquationFit:
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
        # fewer half cycles than energy terms (three coordinates: 14 terms; a slow mode on one
        # short training capture has as few): the half-cycle balance cannot resolve them, so
        # damping and stiffness are fitted together on the force balance (sample by sample)
        few = dr.size < len(e_terms) + 1
        if few and not samples_suffice(data, len(e_terms) + len(_terms(own + cpl, n))):
            raise IdentificationError(f"coordinate {i + 1}: {dr.size} half cycles for {len(e_terms)} terms; "
                                      "need longer or more records")
        w = np.ones(dr.size) if few else 1.0 / np.maximum(k0, 1e-12 * float(k0.max()))
        coef1 = np.zeros(len(e_terms)) if few else scaled_lstsq(dq * w[:, None], dr * w)[0]
        b = coef1[: len(d_terms)]
        theta = coef1[len(d_terms):]
        # phase two: conservative force sample by sample
        dmat, smat, target, fcol = _design(i, data, full, d_terms, s_terms)
        nf = fcol.shape[1]
        k_force = target - dmat @ b
        if k_lin is None:
            k = scaled_lstsq(np.hstack([smat, fcol]), k_force)[0][: smat.shape[1]]
        else:  # own linear stiffness given (:func:`fit_all`'s ``k_lin``): the other terms on the rest
            k = np.concatenate([[k_lin], scaled_lstsq(np.hstack([smat[:, 1:], fcol]), k_force - k_lin * smat[:, 0])[0]
                                [: smat.shape[1] - 1]])
        exchanged = float(np.sum(np.abs(dq[:, len(d_terms):] @ theta))) if theta.size else 0.0
        joint = few or exchanged > max_exchange * float(np.sum(np.abs(dq[:, : len(d_terms)] @ b)))
        if joint:
            # the coordinate's energy is mostly exchanged, not dissipated (physical coordinates
            # joined by springs): the half-cycle balance cannot resolve the damping; fit damping
            # and stiffness together on the force balance instead
            if k_lin is None:
                both, _ = scaled_lstsq(np.hstack([dmat, smat, fcol]), target)
                b, k = both[: len(d_terms)], both[len(d_terms): len(both) - nf]
            else:
                both, _ = scaled_lstsq(np.hstack([dmat, smat[:, 1:], fcol]), target - k_lin * smat[:, 0])
                b, k = both[: len(d_terms)], np.concatenate([[k_lin], both[len(d_terms): len(both) - nf]])
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
    k_ci = (jackknife_lstsq_ci95(np.hstack([dmat, smat, fcol]), target, blocks, slice(nd, nd + ns)) if joint
            else jackknife_lstsq_ci95(np.hstack([smat, fcol]), k_force, blocks, slice(0, ns)))  # of the final fit
    dissipated = float(np.sum(np.abs(dq[:, : len(d_terms)] @ b)))
    exchanged = float(np.sum(np.abs(dq[:, len(d_terms):] @ theta))) if theta.size else 0.0
    residual = float(np.sqrt(np.mean(((dq @ coef1 - dr) * w) ** 2))) if dr.size else 0.0
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


def samples_suffice(data: list[tuple], n_terms: int, per_term: int = 10) -> bool:
    """Enough free-window samples for a force-balance fit of ``n_terms`` (``per_term`` each)."""
    return sum(int(r[1].shape[1]) for r in data) >= per_term * n_terms


def _input_gain(i: int, impacts: list[tuple], d_terms: list[MultiTerm], s_terms: list[MultiTerm],
                b: np.ndarray, k: np.ndarray) -> float:
    """``g_i`` from ``q_i'' + B_i + K_i = g_i F`` over the impacts (0 without force)."""
    num = den = 0.0
    for q, qd, qdd, f in impacts:
        r = qdd[i] + _matrix(d_terms, q, qd) @ b + _matrix(s_terms, q, qd) @ k
        num += float(f @ r)
        den += float(f @ f)
    return num / den if den > 0 else 0.0


def fit_all(records: Sequence[ChannelRecord], tmat: np.ndarray, coupling: bool | str, prune: float,
             prefilter: bool = False, k_lin: Sequence[float | None] | None = None,
             bands: Sequence[float] | None = None) -> tuple[EquationFit, ...]:
    """EDDI per coordinate ``q = pinv(T) y`` over every record (``k_lin``: per coordinate, its own
    linear stiffness per unit mass when given, :func:`fit_equation`; ``bands``: per coordinate, the
    cut-off [Hz] of its own band, :func:`own_band`, when not ``prefilter``)."""
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
    out = []
    for i in range(n):
        span = data if full is not None else own_span(i, data)
        band = full
        if full is None and bands is not None and bands[i] > 0:
            band = own_band(records, proj, span, float(bands[i]))
        out.append(fit_equation(i, span, impacts, default_library(i, n, coupling), float(noise[i]), prune,
                                full=band, k_lin=None if k_lin is None else k_lin[i]))
    return tuple(out)


def _banded_columns(cache: dict, i: int, terms: list[MultiTerm], q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                    force: np.ndarray | None, rate: float, fc: float) -> np.ndarray:
    """``[terms..., -q_i'', F]`` over the whole record through the high-pass at ``fc``; each column
    filtered once per record (``cache``, keyed by the term's text) and kept for the prune's later
    rounds (the filter acts on each row alone; the rows filtered together decide together whether
    they start at rest, :func:`eddi.mdof.signals.highpass`). Cost: the modal identification of a
    three-mass chain +22 % CPU (t3c with coupling 0.87 -> 1.06 s; without the cache 1.32 s)."""
    missing = [t for t in terms if t.text not in cache]
    if "-qdd" not in cache:
        extra = [-qdd[i], force if force is not None else np.zeros(q.shape[1])]
    else:
        extra = []
    if missing or extra:
        rows = [t(q, qd) for t in missing] + extra
        out = highpass(np.vstack(rows), rate, fc, PREFILTER_PASSES)
        for t, row in zip(missing, out):
            cache[t.text] = row
        if extra:
            cache["-qdd"], cache["force"] = out[-2], out[-1]
    return np.column_stack([cache[t.text] for t in terms] + [cache["-qdd"], cache["force"]])


#: :func:`own_band`: a modal equation's phase two keeps the band above this fraction of its mode's
#: frequency (0.3 and 0.5 gave the same frequencies within 0.05 %, session 19). **Off by default
#: (0.0)**: at 0.3 the weak modes' frequencies come right (docs/multi-dof.md, session 19) but
#: tests/station/test_mdof_weak_mode_coupling.py's per-mode coupling (t7-up2) is no longer named.
#: Measured in session 20 (s20weak): not the band's physics - on one fold the banded modal candidate
#: keeps one more (spurious) coefficient, the candidate rule then keeps the lumped elements (the true
#: structure, cubic within 2 %), whose light spring is 0.6 % low (mode 2 -0.24 %, the same slow-content
#: bias in physical coordinates): mode 2 held out 2.3x its floor, and the per-mode rule's "no other
#: mode made worse" refuses. The lumped fit's light spring is the next step before this goes on.
BAND_FRACTION = 0.0


def own_band(records: Sequence[ChannelRecord], proj: np.ndarray, span: list[tuple], cutoff_hz: float) -> list[tuple]:
    """Phase two's records for one modal equation (:func:`_design`'s ``full``): the whole records in
    modal coordinates, the columns and the force through a high-pass at ``cutoff_hz`` (a fraction
    :data:`BAND_FRACTION` of the mode's frequency), the rows over the equation's own span.

    Why (session 19, helper s19weak): a fast, weak mode's coordinate ``q_i = P y`` carries, over
    its short span, slow content far below its mode (the first mode leaking through the shapes, the
    drift band's doubly integrated noise): 20-38 % of its RMS on own three-mass chains. The sample
    balance ``k q_i = -q_i'' - B`` reads it as stiffness with almost no acceleration (``(f_1/f_i)^2``
    of it) and pulled ``k`` low: modes 2-3 0.1-4 % low where ERA had 0.05-0.3 %. A zero-phase
    high-pass is linear and time-invariant, so every column filtered alike (the monomials after
    they are formed) keeps the equation exact above the cut-off; the filtered force is a nuisance
    column (inside the window it is the filter's tail of the blow)."""
    out = []
    for r, (t, q, _qd, _qdd) in zip(records, span):
        s = r.window[0]
        out.append((proj @ r.x, proj @ r.v, proj @ r.a, r.force, (s, s + q.shape[1]),
                    1.0 / float(r.t[1] - r.t[0]), cutoff_hz, {}))
    return out


def era_stiffness(fits: Sequence[EquationFit], frequencies_hz: np.ndarray, damping_ratios: np.ndarray,
                  tolerance: float | None = None) -> list[float | None]:
    """Per modal coordinate, the tail's linear stiffness ``w_r^2`` (per unit mass) where the fit's own
    ``sqrt(k)`` departs from it by more than ``tolerance`` (:data:`ERA_TOLERANCE`), else None."""
    tol = ERA_TOLERANCE if tolerance is None else tolerance
    n = len(fits)
    out: list[float | None] = []
    for i, f in enumerate(fits):
        if i >= len(frequencies_hz):
            out.append(None)
            continue
        zeta = float(np.clip(damping_ratios[i], 0.0, 0.9))
        w2 = (2 * np.pi * float(frequencies_hz[i])) ** 2 / (1 - zeta ** 2)
        k = f.stiffness.get(monomial({i: 1}, n), 0.0)
        out.append(w2 if not (k > 0 and abs(np.sqrt(k / w2) - 1) <= tol) else None)
    return out


def own_span(i: int, data: list[tuple]) -> list[tuple]:
    """Each record's free window cut where coordinate ``i``'s own motion has died (:data:`SPAN_DB`).

    A heavily damped mode rings down in a few periods while a light, low one fills the window:
    past its ring-down the coordinate holds only the noise and what small errors of the mode
    shapes leak into it from the others (a 2.5 Hz mode has ~80x the displacement of a 22 Hz one
    at equal acceleration), and phase two's ``k q_i ~ -q_i'' - B`` over those samples pulls the
    stiffness toward theirs. The acceleration ``q_i''``, where the coordinate's own mode
    dominates its leaks, is cut in :data:`SPAN_BLOCKS` blocks; the floor is the median RMS of the
    last fifth; the span ends after the last block above ``SPAN_DB`` over it (never before
    :data:`SPAN_MIN` of the window)."""
    out = []
    for t, q, qd, qdd in data:
        a = qdd[i]
        m = a.size
        edges = np.linspace(0, m, SPAN_BLOCKS + 1).astype(int)
        rms = np.array([np.sqrt(np.mean(a[s:e] ** 2)) if e > s else 0.0 for s, e in zip(edges[:-1], edges[1:])])
        floor = float(np.median(rms[-max(SPAN_BLOCKS // 5, 1):]))
        above = np.flatnonzero(rms > floor * 10 ** (SPAN_DB / 20))
        stop = int(edges[above[-1] + 1]) if above.size else m
        stop = max(stop, int(SPAN_MIN * m))
        out.append((t[:stop], q[:, :stop], qd[:, :stop], qdd[:, :stop]))
    return out
