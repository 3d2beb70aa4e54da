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
    from scipy.optimize import least_squares

    x0, v0 = float(x[s]), float(v[s])
    if not (x_scale and v_scale):
        return x0, v0
    n = max(8, int(STATE_FRACTION * (e - s)))
    g = zero_crossings(t[s:s + n], x[s:s + n], v[s:s + n], hysteresis=0.05 * x_scale)
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
        sol = least_squares(res, [x0 / x_scale, v0 / v_scale], method="lm", xtol=1e-8, max_nfev=60)
    except (ValueError, ArithmeticError, EddiError):
        return x0, v0
    if not (sol.success and np.all(np.isfinite(sol.x)) and sol.cost <= 0.5 * float(np.sum(res(
            np.array([x0 / x_scale, v0 / v_scale])) ** 2))):
        return x0, v0
    return float(sol.x[0] * x_scale), float(sol.x[1] * v_scale)
