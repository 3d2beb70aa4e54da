"""Optional output-error refinement of an identified equation of motion.

EDDI's two phases are *equation-error* estimates: each balances energies (or forces) sample
by sample or half cycle by half cycle, so measurement noise enters every row directly. An
*output-error* fit instead simulates the model and compares the simulated response with the
measured one over the whole record: a small error of a stiffness coefficient shifts the
phase a little more every cycle and a small damping error bends the whole decay envelope,
so a long ring-down constrains both far more tightly than any single cycle does.

:func:`refine_output_error` starts from the EDDI estimate (which is close enough for the
non-convex output-error problem to converge to the right minimum) and minimises, with
:func:`scipy.optimize.least_squares`,

    sum_k (y_sim(t_k; b, k, x0, v0) - y_meas(t_k))^2

over the damping and stiffness coefficients and the initial state ``(x0, v0)`` of the free
response, where ``y`` is the signal the sensor measured: the acceleration for an
accelerometer (white sensor noise: this is then the maximum-likelihood fit), the rate for a
vibrometer, the coordinate for a displacement sensor (default: ``a`` when given, else ``x``). The window grows in stages
(1/8, 1/2, all of the record) so that the phase error of the starting model never exceeds
a fraction of a cycle.

This is an explicit option (``identify(..., refine=True)``), not part of the paper's method:
the EDDI estimate before refinement is kept in :attr:`eddi.identify.IdentifiedModel.unrefined`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eddi.errors import IdentificationError, SignalError
from eddi.model import EquationOfMotion
from eddi.simulate import auto_substeps, simulate
from eddi.terms import evaluate

#: Fractions of the record fitted in successive stages.
STAGES = (0.125, 0.5, 1.0)


@dataclass(frozen=True)
class Refinement:
    """What the output-error refinement did.

    Attributes
    ----------
    channel : str
        ``"a"``, ``"v"`` or ``"x"``: the measured signal the simulation was fitted to.
    nrmse_before, nrmse_after : float
        ``||y_sim - y|| / ||y||`` over the whole window, EDDI estimate and refined.
    x0, v0 : float
        Fitted initial state at the window start.
    evaluations : int
        Simulations run (all stages, Jacobians included).
    samples : int
        Samples in the whole window.
    """

    channel: str
    nrmse_before: float
    nrmse_after: float
    x0: float
    v0: float
    evaluations: int
    samples: int


def refine_output_error(
    eom: EquationOfMotion,
    t: np.ndarray,
    x: np.ndarray,
    v: np.ndarray,
    a: np.ndarray | None = None,
    *,
    channel: str | None = None,
    max_nfev: int = 60,
) -> tuple[EquationOfMotion, Refinement]:
    """Refine the coefficients of ``eom`` by fitting its free response to the measurement.

    Parameters
    ----------
    eom : EquationOfMotion
        Starting model (from EDDI); its terms are kept, their coefficients refined.
    t : ndarray, shape (n,), [s]
        Uniform times of a free response (no external force).
    x, v : ndarray, shape (n,)
        Measured coordinate and rate (``x[0], v[0]`` start the fit of the initial state).
    a : ndarray, shape (n,), optional
        Measured acceleration.
    channel : {"a", "v", "x"}, optional
        The signal to fit (the one the sensor measured); default ``"a"`` when ``a`` is
        given, else ``"x"``.
    max_nfev : int
        Limit per stage, as :func:`scipy.optimize.least_squares` counts for ``method="lm"``
        (a stage usually converges, by ``ftol``, in 3-5 iterations).

    Returns
    -------
    eom : EquationOfMotion
        Refined model (same terms, mass and effects).
    info : Refinement

    Raises
    ------
    IdentificationError
        If the window is too short (fewer than 64 samples).
    SignalError
        If ``channel`` is unknown, or ``"a"`` without ``a``.
    """
    from scipy.optimize import least_squares  # local: scipy.optimize only when refining

    t = np.asarray(t, dtype=float)
    n = t.size
    if n < 64:
        raise IdentificationError(f"output-error refinement needs >= 64 samples, got {n}")
    x = np.asarray(x, dtype=float)
    v = np.asarray(v, dtype=float)
    if channel is None:
        channel = "a" if a is not None else "x"
    if channel not in ("a", "v", "x") or (channel == "a" and a is None):
        raise SignalError(f"refinement channel must be 'a' (with a given), 'v' or 'x'; got {channel!r}"
                          + (" without a" if channel == "a" else ""))
    y = {"a": a, "v": v, "x": x}[channel]
    y = np.asarray(y, dtype=float)
    d_terms, k_terms = eom.damping_terms(), eom.stiffness_terms()
    names = [("damping", tm.text) for tm in d_terms] + [("stiffness", tm.text) for tm in k_terms]
    c0 = np.array([eom.damping[tm.text] for tm in d_terms] + [eom.stiffness[tm.text] for tm in k_terms])
    # parameter scales: the coefficient itself, or (for ~0 coefficients) the value whose term
    # would reach 1e-3 of the peak inertial force
    f_scale = eom.mass * float(np.max(np.abs(y if channel == "a" else np.gradient(v, t))))
    peak = np.max(np.abs(evaluate(d_terms + k_terms, x, v)), axis=0) if names else np.zeros(0)
    floor = 1e-3 * f_scale / np.where(peak > 0, peak, 1.0)
    scale = np.concatenate((np.maximum(np.abs(c0), floor),
                            [max(float(np.max(np.abs(x))), 1e-300), max(float(np.max(np.abs(v))), 1e-300)]))
    substeps = auto_substeps(eom, float(t[1] - t[0]), float(np.max(np.abs(x))), float(np.max(np.abs(v))))
    counter = [0]

    def model_of(p: np.ndarray) -> EquationOfMotion:
        c = p[:-2] * scale[:-2]
        damping = {name: float(ci) for (group, name), ci in zip(names, c) if group == "damping"}
        stiffness = {name: float(ci) for (group, name), ci in zip(names, c) if group == "stiffness"}
        return eom.model_copy(update={"damping": damping, "stiffness": stiffness})

    def simulated(p: np.ndarray, stop: int) -> np.ndarray:
        counter[0] += 1
        sim = simulate(model_of(p), t[:stop] - t[0], x0=float(p[-2] * scale[-2]),
                       v0=float(p[-1] * scale[-1]), substeps=substeps)
        out = sim.a if channel == "a" else sim.v if channel == "v" else sim.x
        if sim.diverged or not np.all(np.isfinite(out)):
            return np.full(stop, 1e6 * float(np.max(np.abs(y))))
        return out

    p = np.concatenate((c0, [x[0], v[0]])) / scale
    norm = float(np.linalg.norm(y)) or 1.0
    before = float(np.linalg.norm(simulated(p, n) - y)) / norm
    for frac in STAGES:
        stop = max(64, int(round(frac * n)))
        sol = least_squares(lambda q, s=stop: simulated(q, s) - y[:s], p, method="lm",
                            x_scale=1.0, max_nfev=max_nfev)
        p = sol.x
    after = float(np.linalg.norm(simulated(p, n) - y)) / norm
    if not after <= before:  # never return a worse fit than the start
        p = np.concatenate((c0, [x[0], v[0]])) / scale
        after = before
    refined = model_of(p)
    refined = refined.model_copy(update={"notes": (eom.notes + "; " if eom.notes else "")
                                         + f"refined by output error on {channel}"})
    return refined, Refinement(channel=channel, nrmse_before=before, nrmse_after=after,
                               x0=float(p[-2] * scale[-2]), v0=float(p[-1] * scale[-1]),
                               evaluations=counter[0], samples=n)
