"""EDDI over several records: one least-squares problem from every training segment.

:func:`eddi.identify.identify` fits one free response. Diagnosis fits on several captures
(or on the parts of one ring-down left after an amplitude band is held out), so here the
rows of both phases are stacked over *segments* (contiguous free-response pieces):

* phase one: one row per half cycle of every segment, the energy lost over it
  ``T(gamma_i-1) - T(gamma_i) = sum_j b_j integral v B_j dt`` (paper Eq. 7), weighted by the
  inverse of its noise standard deviation (the ``"relative"`` weighting of
  :mod:`eddi.phase_one`);
* phase two (potential route): at every sample of every segment, ``V(x) = E - T`` with
  ``E`` re-anchored on ``T(gamma_i)`` at each crossing of that segment, regressed on the
  potentials of the stiffness functions, rows weighted by their noise.

Terms may be text terms (:mod:`eddi.terms`) or any :class:`Basis`: a damping function
``B(x, v)``, or a stiffness function ``K(x)`` with its potential ``integral_0^x K``. That is
how mechanisms that text terms cannot write enter natively, e.g. contact beyond a gap
(:func:`gap_basis`: ``K = sign(x) max(|x| - g, 0)``, ``V = max(|x| - g, 0)^2 / 2``) or
regularised dry friction (:func:`tanh_basis`).

A part of the model can be *fixed* (kept with its coefficients, :func:`model_bases`): its
dissipation is removed from the phase-one rows and its potential from the phase-two rows,
and only the free bases are fitted.

Energy antiderivatives are cached per segment and basis, so refitting with one more basis
(or over another fold that shares segments) costs only the new columns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Hashable, Sequence

import numpy as np

from eddi.energy import (
    cumulative_energy, integrated_term, kinetic_energy, noise_level, rate_interpolant, zero_crossings,
)
from eddi.errors import IdentificationError, TermError
from eddi.model import EquationOfMotion
from eddi.phase_one import scaled_lstsq
from eddi.terms import parse_term

#: Relative accuracy of a clean half-cycle energy balance (as :mod:`eddi.phase_one`).
RELATIVE_ACCURACY = 1e-6


@dataclass(frozen=True)
class Basis:
    """One candidate function of the equation of motion.

    Attributes
    ----------
    text : str
        Unique name (a text term, or a description such as ``gap(0.0005)``).
    force : callable
        ``force(x, v) -> ndarray, shape (n,)``: ``B(x, v)`` or ``K(x)`` (unit coefficient).
    potential : callable or None
        For a stiffness function: ``potential(x) = integral_0^x K(s) ds``; None for damping.
    cache : bool
        Keep its energy antiderivatives in :class:`SegmentEnergy` (False for bases tried
        once, such as points of a shape search).

    A damping basis may also depend on the history of ``x`` (a filter of the segment, such
    as the force of a hidden mode): ``force`` then receives the whole contiguous segment.
    """

    text: str
    force: Callable[[np.ndarray, np.ndarray], np.ndarray] = field(repr=False)
    potential: Callable[[np.ndarray], np.ndarray] | None = field(default=None, repr=False)
    cache: bool = True


def term_basis(text: str) -> Basis:
    """A text term (:mod:`eddi.terms`) as a basis (with its potential when it is free of ``v``)."""
    term = parse_term(text)

    def force(x: np.ndarray, v: np.ndarray) -> np.ndarray:
        return term(x, v)

    if term.depends_on_v:
        return Basis(term.text, force, None)

    def pot(x: np.ndarray) -> np.ndarray:
        return integrated_term(term, x)

    return Basis(term.text, force, pot)


def gap_basis(gap_m: float) -> Basis:
    """Contact beyond a gap: ``K = sign(x) max(|x| - g, 0)``, ``V = max(|x| - g, 0)^2 / 2``.

    Parameters
    ----------
    gap_m : float
        Gap ``g`` >= 0 [m].
    """
    g = float(gap_m)

    def force(x: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.sign(x) * np.maximum(np.abs(x) - g, 0.0)

    def pot(x: np.ndarray) -> np.ndarray:
        return 0.5 * np.maximum(np.abs(x) - g, 0.0) ** 2
    return Basis(f"gap({g:.9g})", force, pot)


def tanh_basis(velocity_scale: float) -> Basis:
    """Dry friction regularised for the integrator: ``B = tanh(v / v_s)``.

    Parameters
    ----------
    velocity_scale : float
        ``v_s`` > 0 [m/s], well below the velocities that matter.
    """
    vs = float(velocity_scale)

    def force(x: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.tanh(np.asarray(v, float) / vs)
    return Basis(f"tanh(v/{vs:.6g})", force)


def model_bases(eom: EquationOfMotion, x_range: tuple[float, float]) -> tuple[Basis, Basis]:
    """A model's internal force as one fixed damping and one fixed stiffness basis.

    The damping part is ``R(x, v) - R(x, 0)`` and the stiffness part ``R(x, 0)`` (``R``:
    :meth:`EquationOfMotion.restoring_force`; every damping term and dissipative effect
    vanishes at ``v = 0``). The potential is integrated numerically on a fine grid of
    ``x_range``.

    Parameters
    ----------
    eom : EquationOfMotion
    x_range : (float, float)
        Range of the coordinate the potential is needed on (widened by 10 %).

    Returns
    -------
    damping, stiffness : Basis
    """
    lo, hi = float(min(x_range[0], 0.0)), float(max(x_range[1], 0.0))
    pad = 0.1 * max(hi - lo, 1e-12)
    grid = np.linspace(lo - pad, hi + pad, 4001)
    k = eom.restoring_force(grid, np.zeros_like(grid))
    cum = np.concatenate(([0.0], np.cumsum(0.5 * (k[1:] + k[:-1]) * np.diff(grid))))
    cum = cum - np.interp(0.0, grid, cum)

    def damp(x: np.ndarray, v: np.ndarray) -> np.ndarray:
        return eom.restoring_force(x, v) - eom.restoring_force(x, np.zeros_like(np.asarray(x, float)))

    def stiff(x: np.ndarray, v: np.ndarray) -> np.ndarray:
        return eom.restoring_force(x, np.zeros_like(np.asarray(x, float)))

    def pot(x: np.ndarray) -> np.ndarray:
        return np.interp(x, grid, cum)
    tag = f"model@{id(eom):x}"
    return Basis(f"{tag}:damping", damp), Basis(f"{tag}:stiffness", stiff, pot)


@dataclass(frozen=True)
class Segment:
    """A contiguous piece of free response.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
    x, v : ndarray, shape (n,)
    a : ndarray, shape (n,) or None
        Acceleration (sharpens ``v`` at the crossings).
    key : hashable
        Identifies the segment in caches (e.g. ``(record, start, stop)``).
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray | None = None
    key: Hashable = None


class SegmentEnergy:
    """Energies of one segment: crossings, ``T(gamma_i)``, noise, cached antiderivatives.

    Parameters
    ----------
    seg : Segment
    mass : float
        Mass or inertia, > 0.
    noise : "auto" or (sigma_x, sigma_v)
        Noise on ``x`` and ``v``; ``"auto"`` estimates it from the segment
        (:func:`eddi.energy.noise_level`).

    Raises
    ------
    IdentificationError
        Fewer than 3 zero crossings in the segment.
    """

    def __init__(self, seg: Segment, mass: float, noise: str | tuple[float, float] = "auto") -> None:
        self.seg = seg
        self.mass = float(mass)
        if isinstance(noise, str):
            self.noise_x, self.noise_v = noise_level(seg.x), noise_level(seg.v)
        else:
            self.noise_x, self.noise_v = float(noise[0]), float(noise[1])
        t, x, v = seg.t, seg.x, seg.v
        self.gamma = zero_crossings(t, x, v, hysteresis=4.0 * self.noise_x)
        if self.gamma.size < 3:
            raise IdentificationError(f"segment {seg.key!r} has {self.gamma.size} zero crossings; need 3")
        self.t_gamma = kinetic_energy(self.mass, rate_interpolant(t, v, seg.a)(self.gamma))
        vg = np.sqrt(2.0 * self.t_gamma / self.mass)
        var = ((self.mass * self.noise_v) ** 2 * (vg[:-1] ** 2 + vg[1:] ** 2)
               + 0.5 * (self.mass * self.noise_v**2) ** 2)
        self.row_weight = 1.0 / np.maximum(np.sqrt((RELATIVE_ACCURACY * self.t_gamma[:-1]) ** 2 + var),
                                           1e-300)
        self.i0 = int(np.searchsorted(t, self.gamma[0], side="left"))
        self.i1 = int(np.searchsorted(t, self.gamma[-1], side="right"))
        self.kinetic = kinetic_energy(self.mass, v[self.i0:self.i1])
        self._cache: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    @property
    def half_cycles(self) -> int:
        return int(self.gamma.size - 1)

    def antiderivative(self, basis: Basis) -> tuple[np.ndarray, np.ndarray]:
        """``integral v B dt`` from the segment start at the crossings and at ``t[i0:i1]``."""
        got = self._cache.get(basis.text)
        if got is None:
            s = self.seg
            anti = cumulative_energy(s.t, s.v * basis.force(s.x, s.v))
            got = (anti(self.gamma), anti(s.t[self.i0:self.i1]))
            if basis.cache:
                self._cache[basis.text] = got
        return got

    def prepare(self, bases: Sequence[Basis]) -> None:
        """Compute the antiderivatives of several cacheable bases at once (one spline solve
        with one column per basis instead of one solve each; the values are the same)."""
        todo = [b for b in bases if b.cache and b.text not in self._cache]
        todo = list({b.text: b for b in todo}.values())
        if len(todo) < 2:
            return
        s = self.seg
        power = np.column_stack([s.v * b.force(s.x, s.v) for b in todo])
        anti = cumulative_energy(s.t, power)
        ag, at = anti(self.gamma), anti(s.t[self.i0:self.i1])
        for j, b in enumerate(todo):
            self._cache[b.text] = (ag[:, j], at[:, j])

    def dissipation(self, bases: Sequence[Basis], coef: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Modelled dissipation antiderivative ``sum_j c_j A_j`` at the crossings and samples."""
        dg = np.zeros(self.gamma.size)
        dt = np.zeros(self.i1 - self.i0)
        for b, c in zip(bases, coef):
            ag, at = self.antiderivative(b)
            dg = dg + c * ag
            dt = dt + c * at
        return dg, dt

    def mechanical(self, d_gamma: np.ndarray, d_ts: np.ndarray) -> np.ndarray:
        """``E(t)`` re-anchored on ``T(gamma_i)`` at every crossing (as :mod:`eddi.phase_one`)."""
        ts = self.seg.t[self.i0:self.i1]
        g, tg = self.gamma, self.t_gamma
        i = np.clip(np.searchsorted(g, ts, side="right") - 1, 0, g.size - 2)
        forward = tg[i] - (d_ts - d_gamma[i])
        backward = tg[i + 1] + (d_gamma[i + 1] - d_ts)
        lam = np.clip((ts - g[i]) / (g[i + 1] - g[i]), 0.0, 1.0)
        return (1.0 - lam) * forward + lam * backward


@dataclass(frozen=True)
class PotentialRows:
    """Weighted phase-two rows of several segments (potential route).

    Attributes
    ----------
    x : ndarray, shape (k,)
        Coordinate at the rows.
    potential : ndarray, shape (k,), [J]
        ``V = E - T`` minus the potential of any fixed stiffness.
    weight : ndarray, shape (k,)
        Inverse noise standard deviation of each row [1/J].
    """

    x: np.ndarray
    potential: np.ndarray
    weight: np.ndarray


@dataclass(frozen=True)
class ManyFit:
    """Result of :func:`identify_many`.

    Attributes
    ----------
    damping, stiffness : dict of str to float
        Coefficients of the free bases, by :attr:`Basis.text`.
    half_cycles : int
        Phase-one rows (half cycles over all segments).
    samples : int
        Phase-two rows.
    phase_one_residual, phase_two_residual : float
        Weighted RMS misfit of each phase (in units of the noise: ~1 when the model
        explains the data to the noise).
    """

    damping: dict[str, float]
    stiffness: dict[str, float]
    half_cycles: int
    samples: int
    phase_one_residual: float
    phase_two_residual: float


def phase_one_many(energies: Sequence[SegmentEnergy], damping: Sequence[Basis],
                   fixed: Basis | None = None) -> tuple[np.ndarray, float]:
    """Damping coefficients from the half-cycle energy losses of every segment.

    Parameters
    ----------
    energies : sequence of SegmentEnergy
    damping : sequence of Basis
        Free damping bases.
    fixed : Basis, optional
        A damping function with coefficient 1 (kept; its dissipation is removed from the rows).

    Returns
    -------
    coef : ndarray, shape (len(damping),)
    residual : float
        Weighted RMS misfit (in noise standard deviations).

    Raises
    ------
    IdentificationError
        Fewer half cycles than free bases.
    """
    rows, rhs = [], []
    for e in energies:
        e.prepare(list(damping) + ([fixed] if fixed is not None else []))
        dr = -np.diff(e.t_gamma)
        if fixed is not None:
            dr = dr - np.diff(e.antiderivative(fixed)[0])
        cols = [np.diff(e.antiderivative(b)[0]) for b in damping]
        rows.append((np.column_stack(cols) if cols else np.zeros((dr.size, 0))) * e.row_weight[:, None])
        rhs.append(dr * e.row_weight)
    a = np.vstack(rows)
    y = np.concatenate(rhs)
    if not damping:
        return np.zeros(0), float(np.sqrt(np.mean(y**2)))
    if a.shape[0] < a.shape[1]:
        raise IdentificationError(f"{a.shape[0]} half cycles for {a.shape[1]} damping terms")
    coef, _ = scaled_lstsq(a, y)
    return coef, float(np.sqrt(np.mean((a @ coef - y) ** 2)))


def row_step(energies: Sequence[SegmentEnergy], max_rows: int) -> int:
    """Every how many samples :func:`potential_rows` keeps a row (the same for every segment)."""
    total = sum(e.i1 - e.i0 for e in energies)
    return max(1, int(math.ceil(total / max(max_rows, 1))))


def potential_rows(energies: Sequence[SegmentEnergy], damping: Sequence[Basis], coef: np.ndarray, *,
                   fixed_damping: Basis | None = None, fixed_stiffness: Basis | None = None,
                   max_rows: int = 60000, energy_floor: float = 1e-6) -> PotentialRows:
    """Phase-two rows ``V = E - T`` of every segment, for a damping model.

    Parameters
    ----------
    energies : sequence of SegmentEnergy
    damping : sequence of Basis
    coef : ndarray, shape (len(damping),)
        Damping coefficients (from :func:`phase_one_many`).
    fixed_damping, fixed_stiffness : Basis, optional
        Kept parts of the model (coefficient 1): the first adds to the dissipation, the
        potential of the second is subtracted from the rows.
    max_rows : int
        Rows kept in all (every k-th sample of each segment, the same k for all).
    energy_floor : float
        Smallest energy in the row weights, relative to each segment's ``T(gamma_0)``.

    Returns
    -------
    PotentialRows
    """
    step = row_step(energies, max_rows)
    xs, ps, ws = [], [], []
    bases = list(damping) + ([fixed_damping] if fixed_damping is not None else [])
    cs = np.concatenate([np.asarray(coef, float), [1.0] if fixed_damping is not None else []])
    for e in energies:
        dg, dt = e.dissipation(bases, cs)
        energy = e.mechanical(dg, dt)[::step]
        x = e.seg.x[e.i0:e.i1][::step]
        v = e.seg.v[e.i0:e.i1][::step]
        pot = energy - e.kinetic[::step]
        if fixed_stiffness is not None:
            assert fixed_stiffness.potential is not None
            pot = pot - fixed_stiffness.potential(x)
        scale = np.maximum(energy, energy_floor * float(e.t_gamma[0]))
        if e.noise_v > 0:
            sd = e.mass * e.noise_v * np.sqrt(v**2 + 2.0 * np.abs(energy) / e.mass)
            scale = np.sqrt((RELATIVE_ACCURACY * scale) ** 2 + sd**2)
        xs.append(x)
        ps.append(pot)
        ws.append(1.0 / np.maximum(scale, 1e-300))
    return PotentialRows(np.concatenate(xs), np.concatenate(ps), np.concatenate(ws))


def stiffness_columns(rows: PotentialRows, stiffness: Sequence[Basis]) -> np.ndarray:
    """Weighted potential columns, shape (k, len(stiffness))."""
    cols = []
    for b in stiffness:
        if b.potential is None:
            raise TermError(f"stiffness basis {b.text!r} has no potential (does it depend on v?)")
        cols.append(b.potential(rows.x) * rows.weight)
    return np.column_stack(cols) if cols else np.zeros((rows.x.size, 0))


def phase_two_many(rows: PotentialRows, stiffness: Sequence[Basis]) -> tuple[np.ndarray, float]:
    """Stiffness coefficients from phase-two rows.

    Returns
    -------
    coef : ndarray, shape (len(stiffness),)
    residual : float
        Weighted RMS misfit.
    """
    a = stiffness_columns(rows, stiffness)
    y = rows.potential * rows.weight
    if a.shape[1] == 0:
        return np.zeros(0), float(np.sqrt(np.mean(y**2)))
    coef, _ = scaled_lstsq(a, y)
    return coef, float(np.sqrt(np.mean((a @ coef - y) ** 2)))


def identify_many(
    segments: Sequence[Segment | SegmentEnergy],
    mass: float,
    *,
    damping: Sequence[str | Basis],
    stiffness: Sequence[str | Basis],
    fixed: EquationOfMotion | None = None,
    noise: str | tuple[float, float] = "auto",
    max_rows: int = 60000,
) -> ManyFit:
    """Fit damping and stiffness with EDDI on several free-response segments at once.

    Parameters
    ----------
    segments : sequence of Segment or SegmentEnergy
        Free-response pieces (each with at least 3 zero crossings); prepared
        :class:`SegmentEnergy` objects are reused with their caches.
    mass : float
        Mass or inertia, > 0.
    damping, stiffness : sequence of str or Basis
        Free bases (text terms are converted by :func:`term_basis`).
    fixed : EquationOfMotion, optional
        A kept model part (its coefficients are not refitted; :func:`model_bases`).
    noise : "auto" or (sigma_x, sigma_v)
        For segments given as :class:`Segment`.
    max_rows : int
        Phase-two rows kept (see :func:`potential_rows`).

    Returns
    -------
    ManyFit

    Raises
    ------
    IdentificationError
        No segment, or too few crossings.
    TermError
        A bad term, or a stiffness basis without potential.
    """
    if not segments:
        raise IdentificationError("no segments to identify from")
    energies = [s if isinstance(s, SegmentEnergy) else SegmentEnergy(s, mass, noise) for s in segments]
    d = [b if isinstance(b, Basis) else term_basis(b) for b in damping]
    k = [b if isinstance(b, Basis) else term_basis(b) for b in stiffness]
    fd = fs = None
    if fixed is not None:
        lo = min(float(np.min(e.seg.x)) for e in energies)
        hi = max(float(np.max(e.seg.x)) for e in energies)
        fd, fs = model_bases(fixed, (lo, hi))
    b, r1 = phase_one_many(energies, d, fd)
    rows = potential_rows(energies, d, b, fixed_damping=fd, fixed_stiffness=fs, max_rows=max_rows)
    kc, r2 = phase_two_many(rows, k)
    return ManyFit(damping={bb.text: float(c) for bb, c in zip(d, b)},
                   stiffness={bb.text: float(c) for bb, c in zip(k, kc)},
                   half_cycles=sum(e.half_cycles for e in energies), samples=int(rows.x.size),
                   phase_one_residual=r1, phase_two_residual=r2)
