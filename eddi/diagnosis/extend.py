"""Extend: fit the baseline, or the baseline plus one mechanism, on training samples.

``fit="eddi"`` (default): EDDI over all the training parts at once
(:func:`eddi.identify_many.identify_many`'s pieces: phase-one rows are the energy lost over
every half cycle of every training segment, phase-two rows the potential ``E - T``); a
damping mechanism joins phase one, a stiffness mechanism phase two, shape parameters are
found on the training rows. ``fit="equation-error"``: linear least squares of ``F - m a`` on
the terms and the mechanism's regressors. A mechanism that is not a single-coordinate term
(the hidden second mode) is always refitted by equation error.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from scipy import optimize

from eddi.diagnosis.catalogue import Context, Mechanism, MechanismFit, Signal, extend
from eddi.diagnosis.settings import SLOW_ERRORS
from eddi.energy import zero_crossings
from eddi.equation_error import MAX_ROWS as EE_ROWS, Projector, rows as ee_rows, thin_masks
from eddi.errors import IdentificationError, ModelError, SignalError
from eddi.identify_many import (
    Basis, PotentialRows, Segment, SegmentEnergy, model_bases, phase_one_many, phase_two_many,
    potential_rows, stiffness_columns, term_basis,
)
from eddi.model import EquationOfMotion
from eddi.slow_many import corrected, rows_correction
from eddi.terms import parse_terms


@dataclass(frozen=True)
class Setup:
    mass: float
    damping: tuple[str, ...]
    stiffness: tuple[str, ...]
    base: EquationOfMotion | None  # fixed baseline (its coefficients are kept)
    coordinate: str
    fit: str = "eddi"
    #: the pipeline's refined model and the record it was fitted on (-1: none): a fold's
    #: refinement starts from it when that record is wholly training data (name.refined_baseline)
    refine_start: EquationOfMotion | None = None
    refine_start_record: int = -1
    #: take the conditioner's slow errors out of the phase-two rows (eddi.slow_many), as the
    #: pipeline's EDDI (identify) does: set when the folds are judged with EDDI's estimate because
    #: the pipeline rejected its refinement (loop.diagnose)
    slow_errors: bool = False
    #: the equation-error fit of the baseline's terms is a contender of the judged baseline, as the
    #: pipeline judges it beside EDDI and its refinement (eddi.equation_error; set by loop.diagnose
    #: when a pipeline baseline is given; fitter.FoldFitter.refined)
    ee_contender: bool = False


@dataclass(frozen=True)
class Fit:
    eom: EquationOfMotion
    mech: MechanismFit | None
    residual: tuple[np.ndarray, ...]  # per record, NaN outside training samples
    #: the fold's equation-error contender (its terms fitted on the fold's fit record alone,
    #: fitter.FoldFitter.ee_fit_record) or a mechanism added to it (FoldFitter.extend_contender)
    contender: bool = False


def _rows(sigs: Sequence[Signal], masks: Sequence[np.ndarray], setup: Setup) -> tuple[np.ndarray, np.ndarray]:
    """Base regressors and target over the training samples."""
    out, ys = [], []
    terms = parse_terms(list(setup.damping) + list(setup.stiffness)) if setup.base is None else ()
    for s, m in zip(sigs, masks):
        x, v = s.x[m], s.v[m]
        cols, y = ee_rows(terms, x, v, s.a[m], s.force[m], setup.mass)
        if setup.base is not None:
            y = y - setup.base.restoring_force(x, v)
        ys.append(y)
        out.append(cols)
    return np.vstack(out), np.concatenate(ys)


def fit_ee(sigs: Sequence[Signal], masks: Sequence[np.ndarray], setup: Setup,
           mech: Mechanism | None, base_fit: Fit | None = None, columns: dict | None = None,
           context_masks: Sequence[np.ndarray] | None = None, thin: bool = True) -> Fit | None:
    """Fit the baseline (``mech`` None) or the baseline plus one mechanism on training samples.

    Returns None when no physical fit of the mechanism exists. The least squares use every
    k-th training sample (at most :data:`EE_ROWS` rows): the records are sampled far above
    the motion's bandwidth, so the dropped rows repeat the kept ones (the QR and the
    projections of every shape were 2.9 s of a 14.5 s profiled run). ``columns``: a cache of
    the mechanism's regressors shared by the fits on these signals (:func:`_extra`).
    ``context_masks``: the samples the mechanism's shape grid is drawn from (default ``masks``:
    a fit on one record's rows extends a fold that trains on all its training records);
    ``thin=False``: ``masks`` are the rows already (every one is used).
    """
    full = masks
    masks = thin_masks(masks, EE_ROWS) if thin else list(masks)
    a0, y = _rows(sigs, masks, setup)
    proj = Projector(a0, y)
    if mech is None:
        coef = proj.base()
        mfit = None
    else:
        ctx = _context(sigs, full if context_masks is None else context_masks, setup, base_fit)

        def trial(shape: dict[str, float]) -> tuple | None:
            c, ssr = proj.fit(_extra(mech, shape, sigs, masks, setup, columns))
            mf = mech.to_fit(c, shape, setup.mass, setup.stiffness)
            return None if mf is None else (ssr, c, shape, mf)

        best = best_shape(trial, mech.shape_grid(ctx), mech.refine)
        if best is None:
            return None
        coef = proj.base_given(_extra(mech, best[2], sigs, masks, setup, columns), best[1])
        mfit = best[3]
    if setup.base is None:
        nd = len(setup.damping)
        try:
            eom = EquationOfMotion.create(
                mass=setup.mass,
                damping={t: float(c) for t, c in zip(setup.damping, coef[:nd])},
                stiffness={t: float(c) for t, c in zip(setup.stiffness, coef[nd:])},
                coordinate=setup.coordinate,
                notes="fitted by eddi.diagnose (least squares on the equation of motion)")
        except ModelError:
            return None
    else:
        eom = setup.base
    if mfit is not None:
        eom = extend(eom, mfit)
    # residual of this fit on every record (NaN outside training samples)
    residual = []
    for s, m in zip(sigs, full):
        r = np.full(s.x.size, np.nan)
        if mfit is None:
            r[m] = s.force[m] - setup.mass * s.a[m] - eom.restoring_force(s.x[m], s.v[m])
        residual.append(r)
    return Fit(eom=eom, mech=mfit, residual=tuple(residual))


def _extra(mech: Mechanism, shape: dict[str, float], sigs: Sequence[Signal],
           masks: Sequence[np.ndarray], setup: Setup, columns: dict | None = None) -> np.ndarray:
    """The mechanism's regressors for one shape over every record's training rows.

    ``columns`` (a dict shared by the fits on ``sigs``: :class:`eddi.diagnosis.fitter.Fitter`)
    keeps each record's block by mechanism, shape, terms and rows: the folds share most training
    rows (every record but the held-out one, thinned alike) and search the same grid of shapes,
    so the same block was computed once per fold (the hysteresis' path integral and the second
    mode's filter: ~0.5 s of CPU repeated on the double beam). The same numbers either way.
    """
    # a record without training samples adds no rows (a fold's held-out record)
    used = [(i, s, m) for i, (s, m) in enumerate(zip(sigs, masks)) if np.any(m)] or [(0, sigs[0], masks[0])]
    if columns is None:
        return np.vstack([mech.masked_columns(s, shape, setup.stiffness, m) for _, s, m in used])
    blocks = []
    for i, s, m in used:
        key = (mech.name, i, tuple(sorted(shape.items())), tuple(setup.stiffness),
               hashlib.blake2b(np.packbits(m).tobytes(), digest_size=16).digest(), m.size)
        block = columns.get(key)
        if block is None:
            block = columns[key] = mech.masked_columns(s, shape, setup.stiffness, m)
            if len(columns) > COLUMN_BLOCKS:  # the oldest out: a fold reuses the last folds' blocks
                del columns[next(iter(columns))]
        blocks.append(block)
    return np.vstack(blocks)


#: Blocks :func:`_extra` keeps (~20 kB each on the double beam's 2e4 rows; a fold asks for ~900).
COLUMN_BLOCKS = 2000


def _context(sigs: Sequence[Signal], masks: Sequence[np.ndarray], setup: Setup,
             base_fit: Fit | None) -> Context:
    used = [(s, m) for s, m in zip(sigs, masks) if np.any(m)]
    xp = max(float(np.max(np.abs(s.x[m]))) for s, m in used)
    vp = max(float(np.max(np.abs(s.v[m]))) for s, m in used)
    eom = base_fit.eom if base_fit is not None else setup.base
    k1 = eom.linear_stiffness() if eom is not None else 0.0
    f1 = math.sqrt(max(k1, 0.0) / setup.mass) / (2 * math.pi)
    if f1 <= 0:
        f1 = _crossing_frequency(*used[0])
    residual = base_fit.residual if base_fit is not None and base_fit.residual else \
        tuple(np.full(s.x.size, np.nan) for s in sigs)
    return Context(signals=tuple(sigs), masks=tuple(masks), residual=residual, mass=setup.mass,
                   x_peak=xp, v_peak=vp, base_frequency_hz=f1)


def _crossing_frequency(sig: Signal, mask: np.ndarray) -> float:
    idx = np.flatnonzero(mask)
    g = zero_crossings(sig.t[idx], sig.x[idx], sig.v[idx])
    if g.size < 3:
        return 1.0
    return float(1.0 / (2 * np.median(np.diff(g))))


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Contiguous ``[start, stop)`` runs of True in a mask."""
    d = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


class EddiFold:
    """The training segments of one fold, with the baseline's phase one and phase-two rows.

    ``cache`` maps ``(record, start, stop)`` to a prepared :class:`SegmentEnergy`, shared
    over folds so each segment's crossings and energy antiderivatives are computed once.
    """

    def __init__(self, sigs: Sequence[Signal], masks: Sequence[np.ndarray], setup: Setup,
                 cache: dict[tuple[int, int, int], SegmentEnergy | None]) -> None:
        energies: list[SegmentEnergy] = []
        for i, (s, m) in enumerate(zip(sigs, masks)):
            for a, b in runs(m):
                key = (i, a, b)
                if key not in cache:
                    try:
                        cache[key] = SegmentEnergy(Segment(s.t[a:b], s.x[a:b], s.v[a:b], s.a[a:b], key),
                                                   setup.mass)
                    except IdentificationError:
                        cache[key] = None
                e = cache[key]
                if e is not None:
                    energies.append(e)
        if not energies:
            raise SignalError("no training segment has 3 zero crossings")
        self.energies = energies
        self.setup = setup
        self.d = [term_basis(t) for t in setup.damping] if setup.base is None else []
        self.k = [term_basis(t) for t in setup.stiffness] if setup.base is None else []
        self.fd: Basis | None = None
        self.fs: Basis | None = None
        if setup.base is not None:
            lo = min(float(np.min(e.seg.x)) for e in energies)
            hi = max(float(np.max(e.seg.x)) for e in energies)
            self.fd, self.fs = model_bases(setup.base, (lo, hi))
        self._proj0: Projector | None = None
        self.b0, _ = phase_one_many(energies, self.d, self.fd)
        rows0 = potential_rows(energies, self.d, self.b0, fixed_damping=self.fd, fixed_stiffness=self.fs)
        # the conditioner's slow errors, fitted per segment and taken out of every fit's rows
        # (eddi.slow_many; the baseline's and every mechanism's) when the setup asks for it
        self.correction = (rows_correction(energies, self.d, self.k)
                           if SLOW_ERRORS["on"] and setup.slow_errors and self.k else None)
        self.rows0 = corrected(rows0, self.correction)

    def stiffness_fit(self, rows: PotentialRows, extra: Sequence[Basis]) -> tuple[np.ndarray, float]:
        """Stiffness coefficients (baseline terms then ``extra``) and the weighted SSR.

        On the baseline's rows with extra bases (a stiffness mechanism's shapes), the
        baseline columns are factored once per fold and only ``extra`` is projected (the
        refit of every column for every shape was 4.3 s of a 12.6 s profiled run)."""
        if rows is not self.rows0 or not extra:
            coef, res = phase_two_many(rows, list(self.k) + list(extra))
            return coef, res * res * rows.x.size
        if self._proj0 is None:
            self._proj0 = Projector(stiffness_columns(rows, self.k), rows.potential * rows.weight)
        e = stiffness_columns(rows, extra)
        c, ssr = self._proj0.fit(e)
        return np.concatenate([self._proj0.base_given(e, c), c]), ssr

    def model(self, b: np.ndarray, k: np.ndarray) -> EquationOfMotion:
        if self.setup.base is not None:
            return self.setup.base
        st = self.setup
        return EquationOfMotion.create(
            mass=st.mass, damping={t: float(c) for t, c in zip(st.damping, b)},
            stiffness={t: float(c) for t, c in zip(st.stiffness, k)}, coordinate=st.coordinate,
            notes="fitted by eddi.diagnose (EDDI over the training captures)")


def fit_eddi(fold: EddiFold, sigs: Sequence[Signal], masks: Sequence[np.ndarray], setup: Setup,
             mech: Mechanism | None, base_fit: Fit | None = None,
             ee_base: Callable[[], Fit | None] | None = None, columns: dict | None = None) -> Fit | None:
    """EDDI fit of the baseline (``mech`` None) or the baseline plus one mechanism.

    A ``"damping"`` mechanism (friction, drag, the second mode's force, whose power is the
    energy exchanged with the hidden mode) joins the phase-one columns and changes the
    mechanical energy phase two sees; a ``"stiffness"`` one (clearance, even powers) joins
    the phase-two columns. Shape parameters are chosen on the training rows: by the
    phase-one misfit for damping, by the phase-two misfit for stiffness (grid, then
    Nelder-Mead on their logarithms).
    """
    if mech is None:
        k, _ = fold.stiffness_fit(fold.rows0, [])
        try:
            eom = fold.model(fold.b0, k)
        except ModelError:
            return None
        # no residual: the native mechanisms do not look at it, and the second mode (the one
        # that does) is refitted by equation error with its own (fit_ee); computing it cost
        # 2.5 s of a 14.5 s profiled run (bench_diagnose_speed.py --profile)
        return Fit(eom=eom, mech=None, residual=())
    assert base_fit is not None
    if not mech.native:  # second mode: the equation-error refit of baseline terms + mechanism
        ee = Setup(mass=setup.mass, damping=setup.damping, stiffness=setup.stiffness,
                   base=setup.base, coordinate=setup.coordinate, fit="equation-error")
        # the equation-error baseline: its residual spectrum shows the hidden mode
        eb = ee_base() if ee_base is not None else fit_ee(sigs, masks, ee, None)
        return fit_ee(sigs, masks, ee, mech, base_fit=eb, columns=columns) if eb is not None else None
    return _fit_native(fold, sigs, masks, setup, mech, base_fit)


def _fit_native(fold: EddiFold, sigs: Sequence[Signal], masks: Sequence[np.ndarray], setup: Setup,
                mech: Mechanism, base_fit: Fit) -> Fit | None:
    """:func:`fit_eddi` of a mechanism EDDI fits natively (phase one or phase two)."""
    ctx = _context(sigs, masks, setup, base_fit)
    nd, nk = len(fold.d), len(fold.k)
    dt = sigs[0].dt

    def trial(shape: dict[str, float]) -> tuple | None:
        """(misfit, mechanism coefficients, shape, fit, base damping, base stiffness) or None."""
        extra = mech.bases({**shape, "sample_interval_s": dt}, setup.stiffness)
        if mech.native == "damping":
            b, r1 = phase_one_many(fold.energies, list(fold.d) + list(extra), fold.fd)
            mf = mech.to_fit(b[nd:], shape, setup.mass, setup.stiffness)
            return None if mf is None else (r1 * r1, b[nd:], shape, mf, b[:nd], None)
        c, ssr = fold.stiffness_fit(fold.rows0, extra)
        mf = mech.to_fit(c[nk:], shape, setup.mass, setup.stiffness)
        return None if mf is None else (ssr, c[nk:], shape, mf, fold.b0, c[:nk])

    best = best_shape(trial, mech.shape_grid(ctx), mech.refine)
    if best is None:
        return None
    if mech.native == "damping":
        extra = mech.bases({**best[2], "sample_interval_s": dt}, setup.stiffness)
        rows = corrected(potential_rows(fold.energies, list(fold.d) + list(extra),
                                        np.concatenate([best[4], best[1]]), fixed_damping=fold.fd,
                                        fixed_stiffness=fold.fs), fold.correction)
        k, _ = fold.stiffness_fit(rows, [])
    else:
        k = best[5]
    try:
        eom = fold.model(best[4], k)
    except ModelError:
        return None
    return Fit(eom=extend(eom, best[3]), mech=best[3], residual=base_fit.residual)


def best_shape(trial: Callable[[dict[str, float]], tuple | None], grid: Sequence[dict[str, float]],
               keys: Sequence[str]) -> tuple | None:
    """The best trial over a grid of shapes, polished by Nelder-Mead on the logarithms of
    ``keys`` (20 evaluations per key). ``trial(shape)`` returns a tuple whose first item is
    the misfit (lower is better) and third the shape, or None when the shape gives no
    physical fit."""
    best = None
    for shape in grid:
        got = trial(shape)
        if got is not None and (best is None or got[0] < best[0]):
            best = got
    if best is None or not keys:
        return best
    shape0 = dict(best[2])
    p0 = np.log([shape0[k] for k in keys])
    found = [best]
    scale = float(best[0]) if best[0] > 0 else 1.0

    def cost(p: np.ndarray) -> float:
        got = trial({**shape0, **{k: float(np.exp(v)) for k, v in zip(keys, p)}})
        if got is None:
            return 10.0
        if got[0] < found[-1][0]:
            found.append(got)
        return got[0] / scale

    optimize.minimize(cost, p0, method="Nelder-Mead",
                      options={"maxfev": 20 * len(keys), "xatol": 1e-3, "fatol": 1e-6,
                               "initial_simplex": np.vstack([p0] + [p0 + 0.05 * np.eye(len(keys))[i]
                                                                    for i in range(len(keys))])})
    return found[-1]
