"""The initial state of a free response, fitted over its first cycles.

A simulation of a free response started from the measured state at one sample inherits that
sample's error: right after a blow sampled by two or three points, the conditioned velocity
there can be several percent off, and an exact model then misses the whole ring-down (a
246 kg, 4.3 Hz null at 512 Hz: the exact model's validation read displacement nrmse 0.16 and
"poor fit"; from the fitted state 0.02). :func:`fitted_state` fits ``(x0, v0)`` so that the
simulation reproduces the measured ``x`` and ``v`` over the first :data:`STATE_CYCLES` cycles
(at most :data:`STATE_FRACTION` of the window), by least squares from the measured state: the
window averages the noise, so the error left is the model's.

Used by :func:`eddi.driven_validation.validate_conditioned` (records with a force but no rest
before the blow) and :func:`eddi.diagnosis.show.simulate_part_xv` (free-response parts).
"""

from __future__ import annotations

import numpy as np

from eddi.energy import zero_crossings
from eddi.errors import EddiError
from eddi.model import EquationOfMotion
from eddi.simulate import free_simulator

#: Cycles of a free response its initial state is fitted over.
STATE_CYCLES = 2
#: ... and at most this fraction of the window.
STATE_FRACTION = 0.25


def fitted_state(eom: EquationOfMotion, t: np.ndarray, x: np.ndarray, v: np.ndarray,
                 force: np.ndarray | None, s: int, e: int, x_scale: float | None,
                 v_scale: float | None) -> tuple[float, float]:
    """Initial state ``(x0 [m], v0 [m/s])`` of the free response ``[s, e)`` of a record.

    Parameters
    ----------
    eom : EquationOfMotion
        The model simulated.
    t, x, v : ndarray
        The record's time [s], displacement [m] and velocity [m/s].
    force : ndarray or None
        Its force [N] (the simulation is driven by what is left of it in the window).
    s, e : int
        The free response's first and one-past-last samples.
    x_scale, v_scale : float or None
        Scales of ``x`` and ``v`` (the peaks over the window); None: the measured state.

    Returns
    -------
    (float, float)
        The fitted state; the measured state at ``s`` when the window holds fewer than
        :data:`STATE_CYCLES` cycles or the fit fails or does not lower the misfit.
    """
    x0, v0 = float(x[s]), float(v[s])
    if not (x_scale and v_scale):
        return x0, v0
    n = max(8, int(STATE_FRACTION * (e - s)))
    g = _first_crossings(t[s:s + n], x[s:s + n], v[s:s + n], 0.05 * x_scale, 2 * STATE_CYCLES + 1)
    if g.size < 2 * STATE_CYCLES + 1:
        return x0, v0
    w = int(np.searchsorted(t[s:s + n], g[2 * STATE_CYCLES])) + 1
    tw = t[s:s + w] - t[s]
    f = force[s:s + w] if force is not None else None
    xm, vm = x[s:s + w], v[s:s + w]
    try:
        run = free_simulator(eom, tw, force=f, x_scale=x_scale, v_scale=v_scale)
    except (ValueError, ArithmeticError, EddiError):
        return x0, v0

    def res(p: np.ndarray) -> np.ndarray:
        xs, vs = run(p[0] * x_scale, p[1] * v_scale)
        out = np.concatenate([(xs - xm) / x_scale, (vs - vm) / v_scale])
        return np.where(np.isfinite(out), out, 10.0)

    try:
        p, cost, ok = levenberg_marquardt(res, np.array([x0 / x_scale, v0 / v_scale]), xtol=1e-8, max_nfev=60)
    except (ValueError, ArithmeticError, EddiError):
        return x0, v0
    if not (ok and np.all(np.isfinite(p)) and cost <= 0.5 * float(np.sum(res(
            np.array([x0 / x_scale, v0 / v_scale])) ** 2))):
        return x0, v0
    return float(p[0] * x_scale), float(p[1] * v_scale)


#: Crossings a window's first prefix is searched for (then prefixes 8 times longer).
_PREFIX = 512


def _first_crossings(t: np.ndarray, x: np.ndarray, v: np.ndarray, band: float, k: int) -> np.ndarray:
    """At least the first ``k`` zero crossings of :func:`eddi.energy.zero_crossings` (dead band
    ``band``), the same numbers, from the shortest prefix (512, 4096, ... samples) that holds
    ``k + 1`` of them: each crossing lies between two exits from the dead band and the search
    is causal, so once a prefix holds a later crossing the earlier ones are final (the whole
    window's crossings cost ~3 ms a window on the double beam's ring-downs, for 5 used)."""
    m = min(t.size, _PREFIX)
    while True:
        g = zero_crossings(t[:m], x[:m], v[:m], hysteresis=band)
        if g.size > k or m >= t.size:
            return g if m >= t.size else g[:k]
        m = min(t.size, 8 * m)


def levenberg_marquardt(res, p0: np.ndarray, xtol: float, max_nfev: int) -> tuple[np.ndarray, float, bool]:
    """``scipy.optimize.least_squares(res, p0, method="lm", xtol=xtol, max_nfev=max_nfev)``'s
    solution, cost and success, the same numbers, without its wrappers.

    The same MINPACK ``lmder`` (through :func:`scipy.optimize.leastsq`) with the same
    forward-difference Jacobian (scipy's ``2-point`` rule: step ``sqrt(eps) max(1, |p|)``
    signed by ``p``, taken from the residual already computed at ``p``), but without the
    Jacobians ``least_squares`` computes and discards (at the start and at the solution: 2-4
    simulations per fit) and its per-call bookkeeping.
    """
    from scipy.optimize import leastsq

    seen: dict[bytes, tuple[np.ndarray, np.ndarray | None]] = {}

    def fun(p: np.ndarray) -> np.ndarray:
        key = p.tobytes()
        if key not in seen:
            seen.clear()  # only the last point is asked for again (its Jacobian)
            seen[key] = (np.atleast_1d(res(p.copy())), None)
        return seen[key][0]

    def jac(p: np.ndarray) -> np.ndarray:
        key = p.tobytes()
        f0 = fun(p)
        got = seen[key][1]
        if got is None:
            h = _RSTEP * ((p >= 0).astype(float) * 2 - 1) * np.maximum(1.0, np.abs(p))
            cols = []
            for i in range(p.size):
                p1 = np.copy(p)
                p1[i] = p[i] + h[i]
                cols.append((np.atleast_1d(res(p1)) - f0) / ((p[i] + h[i]) - p[i]))
            got = np.array(cols).T
            seen[key] = (f0, got)
        return got

    p, _cov, info, _msg, ier = leastsq(fun, np.asarray(p0, dtype=float), Dfun=jac, full_output=True,
                                       ftol=1e-8, xtol=xtol, gtol=1e-8, maxfev=max_nfev, factor=100.0)
    f = info["fvec"]
    return p, float(0.5 * np.dot(f, f)), ier in (1, 2, 3, 4)


#: scipy's relative step of a 2-point forward difference in double precision.
_RSTEP = np.finfo(np.float64).eps ** 0.5
