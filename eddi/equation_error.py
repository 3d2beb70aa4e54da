"""The equation-error fit of a model's terms on one conditioned record (a contender the pipeline judges).

:func:`equation_error_fit`: linear least squares of ``F - m a`` on the model's damping and
stiffness terms over the record's free-response window (column-scaled,
:func:`eddi.phase_one.scaled_lstsq`). It is what :mod:`eddi.diagnosis` calls the
"equation-error baseline" (there pooled over a fold's training records), fitted here on the
pipeline's fit record alone.

Why the pipeline needs it (session 15, docs/diagnosis.md "Session 15: the baseline the
pipeline keeps"): on light, stiff systems moved by 1e-5..1e-4 m the terms ``x``, ``x^3``,
``x^5`` are nearly collinear over one record's amplitude range. EDDI's estimate and the
output-error refinement that starts from it can then fit the fit record with high-order
coefficients of opposite signs (``x^4`` -2.8e15, ``x^5`` -1.2e19 on a 15.7 g, 42 Hz blind
set) that predict the other captures, at other amplitudes, twice as badly as the plain
equation-error fit of the same terms. With held-out records the pipeline keeps whichever of
the three predicts them best (:func:`eddi.refinement_choice.judge_refinement`).
"""

from __future__ import annotations

import numpy as np

from eddi.conditioning import ConditionedSignal
from eddi.errors import ModelError
from eddi.model import EquationOfMotion
from eddi.phase_one import scaled_lstsq

#: At most this many rows (every k-th sample of the window; the records are sampled far above
#: the motion's band, so the dropped rows repeat the kept ones), as the diagnosis' fit.
MAX_ROWS = 20000


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
    w0, w1 = cond.window
    step = max(1, (w1 - w0) // MAX_ROWS)
    sl = slice(w0, w1, step)
    x, v, a = cond.x[sl], cond.v[sl], cond.a[sl]
    terms = eom.damping_terms() + eom.stiffness_terms()
    if x.size <= 2 * len(terms) or not terms:
        return None
    y = -eom.mass * a
    if cond.force is not None:
        y = y + cond.force[sl]
    cols = np.column_stack([t(x, v) for t in terms])
    coef, _ = scaled_lstsq(cols, y)
    if not np.all(np.isfinite(coef)):
        return None
    nd = len(eom.damping)
    try:
        return eom.model_copy(update={
            "damping": {t: float(c) for t, c in zip(eom.damping, coef[:nd])},
            "stiffness": {t: float(c) for t, c in zip(eom.stiffness, coef[nd:])}})
    except ModelError:
        return None
