"""The Jacobian of a switching model's free response, for its 95 % intervals.

A model with a ``sign`` factor (``sign(v)``: Coulomb friction) switches its force at every
reversal. The fit's RK4 (:mod:`eddi.sensitivity`, :mod:`eddi.simulate`) does not locate the
switch inside a step: whenever a tiny change of a parameter moves one stage's ``v`` across
zero, the simulated response jumps by ``~h^2 F_c / m`` and keeps the jump as a phase offset
for the rest of the record. A forward difference of ``1e-6`` of a coefficient (or MINPACK's
``1.5e-8``) divides that jump by the step: on a Coulomb record of session 12's coarse
benchmark (``benchmarks/bench_ci_coverage_coarse.py``, seed 1 record 14: 17.6 samples a cycle,
46 dB, the response stopping in the friction band after 56 cycles) the ``x`` column came out
``~650 sign(v)`` (a time shift) where the response's own sensitivity is ``~40``: ``J^T J``
of ``k1`` ~60x too large, its interval 1.7e-7 of ``k1`` wide while the estimate was 6.6e-6 off
(z 74; 4 of 19 Coulomb draws z 87-3345, the records whose response sticks before the record
ends: the friction is then strong against the late amplitudes, so the jumps are large).

:func:`secant_jacobian` takes central secants over one standard error of each parameter
instead: the scale on which the interval is a claim (the sum of squares rising by ~1 there),
and one on which the switching jumps average out. A first pass at :data:`SECANT_START` (0.1 %
of a coefficient, of the initial state's amplitude) gives the standard errors, the second
takes its secants over 1, 2 and 4 of them (:data:`SECANT_SCALES`), per parameter the smallest.
Cost: ``8 p`` simulations without sensitivities (``p`` parameters, ~7): on a coarse record of
1000 samples a millisecond or two each.
"""

from __future__ import annotations

import math

import numpy as np

from eddi.model import EquationOfMotion

#: The scaled step of the first pass (a fraction of each coefficient, of ``x0``, ``v0``'s
#: amplitude, of 1e-3 of the signal for the offset).
SECANT_START = 1e-3
#: The secants of the second pass, in standard errors of the first. Whether a secant straddles a
#: switch's jump is chance: on seed 1 record 0 of ``--family stick`` ``k1``'s standard error from
#: secants over 0.25-8 of them was 2.4-3.2e-5 except 7.4e-6 over one. A jump adds to a column, so
#: per parameter the column of the smallest norm is kept.
SECANT_SCALES = (1.0, 2.0, 4.0)


def switching_model(eom: EquationOfMotion) -> bool:
    """True when a term of ``eom`` has a ``sign`` factor (its force jumps at ``v = 0`` or ``x = 0``)."""
    return any(tm.exponents[4] % 2 == 1 or tm.exponents[5] % 2 == 1
               for tm in eom.damping_terms() + eom.stiffness_terms())


def _central(prob, p: np.ndarray, h: np.ndarray, stop: int) -> tuple[np.ndarray, np.ndarray]:
    """Central secants of the compared values over ``p +- h``, and which columns are good
    (no simulation diverged)."""
    cols = np.zeros((stop, p.size))
    good = np.ones(p.size, dtype=bool)
    for k in range(p.size):
        sims = []
        for sgn in (1.0, -1.0):
            q = p.copy()
            q[k] += sgn * h[k]
            sims.append(prob.simulated(q, stop))
            good[k] &= not prob.diverged
        if good[k]:
            cols[:, k] = (sims[0] - sims[1]) / (2.0 * h[k])
    return cols, good


def _white_se(prob, p: np.ndarray, jac: np.ndarray, stop: int) -> np.ndarray:
    """``s sqrt(diag((J^T J)^-1))`` in scaled units (``inf`` where a column is zero)."""
    r = prob.residual(p, stop)
    s2 = float(r @ r) / max(1, stop - p.size)
    jtj = jac.T @ jac
    se = np.sqrt(np.clip(s2 * np.diag(np.linalg.pinv(jtj)), 0.0, None))
    se[~(np.diag(jtj) > 0)] = math.inf
    return se


def secant_jacobian(prob, p: np.ndarray, stop: int | None = None) -> np.ndarray:
    """Jacobian of the compared values of ``prob`` (:class:`eddi.output_error.OutputErrorProblem`)
    at ``p`` by central secants over one standard error of each parameter (see the module notes).

    Parameters
    ----------
    prob : OutputErrorProblem
    p : ndarray, shape (k,)
        Scaled parameters (active coefficients, then the nuisance ones).
    stop : int, optional
        Compared values (default: all).

    Returns
    -------
    ndarray, shape (stop, k)
        In the scaled units of ``p``. A column whose secant over its standard error diverges
        keeps the first pass's; one that diverges there too is zero (no information).
    """
    n = prob.n if stop is None else stop
    h0 = np.full(p.size, SECANT_START)
    jac, good0 = _central(prob, p, h0, n)
    se = _white_se(prob, p, jac, n)
    h = np.where(np.isfinite(se) & (se > 0) & good0, se, h0)
    norm = np.where(good0, np.linalg.norm(jac, axis=0), np.inf)
    for scale in SECANT_SCALES:
        cols, good = _central(prob, p, scale * h, n)
        size = np.where(good, np.linalg.norm(cols, axis=0), np.inf)
        better = size < norm  # a switch's jump only adds to a column: the smallest is the least touched
        jac[:, better] = cols[:, better]
        norm = np.minimum(norm, size)
    prob.residual(p, n)  # leave the problem at p (its diverged flag), as a Jacobian call does
    return jac
