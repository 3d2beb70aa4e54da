"""The equation-error least squares: the rows, the solve, and a model's terms refitted on one record.

One module owns the equation-error fit (session 16; it was written twice, here and in
:mod:`eddi.diagnosis.extend`): :func:`rows` (regressors of the terms and the target
``F - m a`` over chosen samples), :func:`solve` (column-scaled least squares,
:func:`eddi.phase_one.scaled_lstsq`), :func:`window_rows` (every k-th sample of a window, at
most :data:`MAX_ROWS`), :func:`thin_masks` (the same for masks over several records) and
:class:`Projector` (one QR of the terms' columns shared by many extra blocks: a mechanism's
shapes). :func:`equation_error_fit` is the pipeline's contender; the diagnosis fits its folds'
contender with :func:`fit_coefficients` on the same rows, and its pooled fits and mechanisms'
extensions with :class:`Projector`.

Why the pipeline needs the contender (session 15, docs/diagnosis.md "Session 15: the baseline
the pipeline keeps"): on light, stiff systems moved by 1e-5..1e-4 m the terms ``x``, ``x^3``,
``x^5`` are nearly collinear over one record's amplitude range. EDDI's estimate and the
output-error refinement that starts from it can then fit the fit record with high-order
coefficients of opposite signs (``x^4`` -2.8e15, ``x^5`` -1.2e19 on a 15.7 g, 42 Hz blind
set) that predict the other captures, at other amplitudes, twice as badly as the plain
equation-error fit of the same terms. With held-out records the pipeline keeps whichever of
the three predicts them best (:func:`eddi.refinement_choice.judge_refinement`).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from eddi.conditioning import ConditionedSignal
from eddi.errors import ModelError
from eddi.model import EquationOfMotion
from eddi.phase_one import scaled_lstsq
from eddi.terms import Term, evaluate

#: At most this many rows (every k-th sample; the records are sampled far above the motion's
#: band, so the dropped rows repeat the kept ones).
MAX_ROWS = 20000


def window_rows(w0: int, w1: int) -> slice:
    """Every k-th sample of ``[w0, w1)``, ``k = max(1, (w1 - w0) // MAX_ROWS)`` (the one-record fit's rows)."""
    return slice(w0, w1, max(1, (w1 - w0) // MAX_ROWS))


def thin_masks(masks: Sequence[np.ndarray], max_rows: int = MAX_ROWS) -> list[np.ndarray]:
    """Every k-th True sample of each mask (the same k for all), at most ``max_rows`` in all."""
    total = int(sum(int(np.count_nonzero(m)) for m in masks))
    step = max(1, -(-total // max(1, max_rows)))
    if step == 1:
        return list(masks)
    out = []
    for m in masks:
        idx = np.flatnonzero(m)[::step]
        t = np.zeros_like(m)
        t[idx] = True
        out.append(t)
    return out


def rows(terms: Sequence[Term], x: np.ndarray, v: np.ndarray, a: np.ndarray, force: np.ndarray | None,
         mass: float) -> tuple[np.ndarray, np.ndarray]:
    """The regressors of ``terms`` (one column each) and the target ``F - m a`` (``F`` zero when None)."""
    y = -mass * a
    if force is not None:
        y = y + force
    cols = evaluate(list(terms), x, v) if terms else np.zeros((x.size, 0))
    return cols, y


def solve(cols: np.ndarray, y: np.ndarray) -> np.ndarray | None:
    """Least squares of ``y`` on ``cols`` with unit-norm columns (None when not finite)."""
    coef, _ = scaled_lstsq(cols, y)
    return coef if np.all(np.isfinite(coef)) else None


def fit_coefficients(terms: Sequence[Term], x: np.ndarray, v: np.ndarray, a: np.ndarray,
                     force: np.ndarray | None, mass: float) -> np.ndarray | None:
    """The coefficients of ``terms`` by equation error on the given samples (None: fewer than two
    rows per term, no terms, or not finite)."""
    if x.size <= 2 * len(terms) or not terms:
        return None
    return solve(*rows(terms, x, v, a, force, mass))


def equation_error_fit(eom: EquationOfMotion, cond: ConditionedSignal) -> EquationOfMotion | None:
    """``eom``'s terms refitted by equation error on ``cond``'s free-response window.

    Parameters
    ----------
    eom : EquationOfMotion
        Supplies the mass and the terms (its coefficients are not used); no effects.
    cond : ConditionedSignal
        The record; the measured force enters the rows when there is one (zero otherwise).

    Returns
    -------
    EquationOfMotion or None
        None when ``eom`` carries effects, the window holds fewer rows than terms, or the
        solution is not finite.
    """
    if eom.effects:
        return None
    sl = window_rows(*cond.window)
    force = cond.force[sl] if cond.force is not None else None
    terms = eom.damping_terms() + eom.stiffness_terms()
    coef = fit_coefficients(terms, cond.x[sl], cond.v[sl], cond.a[sl], force, eom.mass)
    if coef is None:
        return None
    return with_coefficients(eom, coef)


def with_coefficients(eom: EquationOfMotion, coef: np.ndarray) -> EquationOfMotion | None:
    """``eom`` with its damping then stiffness coefficients replaced by ``coef`` (None: not a valid model)."""
    nd = len(eom.damping)
    try:
        return eom.model_copy(update={
            "damping": {t: float(c) for t, c in zip(eom.damping, coef[:nd])},
            "stiffness": {t: float(c) for t, c in zip(eom.stiffness, coef[nd:])}})
    except ModelError:
        return None


class Projector:
    """Least squares of ``y`` on ``[a0, e]`` for many extra blocks ``e``, sharing one QR of ``a0``
    (columns scaled by their root mean square)."""

    def __init__(self, a0: np.ndarray, y: np.ndarray) -> None:
        self.y = y
        self.scale = col_scale(a0)
        if a0.shape[1]:
            self.q, self.r = np.linalg.qr(a0 / self.scale)
            self.r0 = y - self.q @ (self.q.T @ y)
        else:
            self.q = np.zeros((y.size, 0))
            self.r = np.zeros((0, 0))
            self.r0 = y

    def base(self, y: np.ndarray | None = None) -> np.ndarray:
        yy = self.y if y is None else y
        if self.q.shape[1] == 0:
            return np.zeros(0)
        return np.linalg.solve(self.r, self.q.T @ yy) / self.scale

    def fit(self, e: np.ndarray) -> tuple[np.ndarray, float]:
        """Coefficients of ``e`` and the residual sum of squares (base block projected out)."""
        se = col_scale(e)
        es = e / se
        ep = es - self.q @ (self.q.T @ es)
        if ep.shape[1] == 1:
            # one column (most mechanisms' shapes): the least squares in closed form (LAPACK's
            # SVD solver took ~1 ms a shape on 2e4 rows, ~15 % of the candidates' fold fits)
            col = ep[:, 0]
            nn = float(col @ col)
            c = np.array([float(col @ self.r0) / nn if nn > 0 else 0.0])
        else:
            c, *_ = np.linalg.lstsq(ep, self.r0, rcond=None)
        res = self.r0 - ep @ c
        return c / se, float(res @ res)

    def base_given(self, e: np.ndarray, c: np.ndarray) -> np.ndarray:
        """Coefficients of the base block once those of ``e`` are fixed to ``c``."""
        return self.base(self.y - e @ c)


def col_scale(a: np.ndarray) -> np.ndarray:
    """Root mean square of each column (1 where it is zero or not finite)."""
    scale = np.sqrt(np.mean(a * a, axis=0)) if a.shape[0] else np.ones(a.shape[1])
    scale[~(scale > 0)] = 1.0
    return scale
