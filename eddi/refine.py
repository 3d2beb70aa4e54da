"""Optional output-error refinement of an identified equation of motion.

EDDI's two phases are *equation-error* estimates: each balances energies (or forces) sample
by sample or half cycle by half cycle, so measurement noise enters every row directly. An
*output-error* fit instead simulates the model and compares the simulated response with the
measured one over the whole record: a small error of a stiffness coefficient shifts the
phase a little more every cycle and a small damping error bends the whole decay envelope,
so a long ring-down constrains both far more tightly than any single cycle does.

:func:`refine_output_error` starts from the EDDI estimate (which is close enough for the
non-convex output-error problem to converge to the right minimum) and minimises, with
:func:`eddi.lsq.least_squares` (MINPACK's Levenberg-Marquardt in numpy),

    sum_k (y_sim(t_k; b, k, x0, v0) - y_meas(t_k))^2

over the damping and stiffness coefficients and the initial state ``(x0, v0)`` of the free
response, where ``y`` is the signal the sensor measured: the acceleration for an
accelerometer (white sensor noise: this is then the maximum-likelihood fit), the rate for a
vibrometer, the coordinate for a displacement sensor (default: ``a`` when given, else ``x``). The window grows in stages
(1/8, 1/2, all of the record) so that the phase error of the starting model never exceeds
a fraction of a cycle.

Cost. A densely sampled record (19.2 kHz for a 4 Hz oscillator: thousands of samples per
cycle) is compared as block means of ``block`` samples (:func:`block_means`, ``block`` set
by :func:`block_size` so that a block spans at most 0.2 rad of the fastest local
oscillation): with white sensor noise the block means carry the same information about a
signal whose band lies far below ``1 / (block dt)``, and every simulation runs on the grid
of the blocks' centres (``1 / block`` of the cost). The Jacobian of every
Levenberg-Marquardt step, and of the intervals below, comes from the forward sensitivity
equations integrated with the response (:mod:`eddi.sensitivity`: one pass at ~2x the cost
of a simulation, instead of one simulation per parameter); models with effects or
``sign`` terms use forward differences. On the 45 s, 19.2 kHz record of
``benchmarks/bench_identify_speed.py`` the refinement with term selection went from ~250
whole-window simulations (~15 s) to ~35 passes on 14k block means (<1 s).

Where the pieces are: this module fits and packages (:func:`refine_output_error`,
:func:`confidence_intervals`, :func:`bounded_intervals`, :class:`Refinement`); the problem
of one record (its parameters, simulations, Jacobian and covariance) is
:class:`eddi.output_error.OutputErrorProblem`; the block means and RK4 steps it compares on
are :mod:`eddi.refine_grid` (their names are importable from here too); the term selection
is :mod:`eddi.selection`.

This is an explicit option (``identify(..., refine=True)``), not part of the paper's method:
the EDDI estimate before refinement is kept in :attr:`eddi.identify.IdentifiedModel.unrefined`.

Evidence for each term (``select=True``)
----------------------------------------
At the optimum the output-error fit is a nonlinear least-squares problem with white sensor
noise, so the coefficients' covariance is ``s^2 (J^T J)^-1`` (``J``: the Jacobian of the
simulated signal, ``s^2 = RSS / (n - p)``, over the block means): :attr:`Refinement.ci95`
is ``1.96`` standard errors. Residuals that are not white (a DAQ's decimation filter, a
drifting bias) widen it by a sandwich over the response's band
(:func:`eddi.intervals.noise_covariance_of_fit`); a DAQ's sampling kernel, when told, is part of the model
(:func:`eddi.intervals.sampling_curvature`). Terms are then removed one at a time, the one with the smallest ``|c| / se`` first,
each removal refitted and kept only when it lowers the Bayesian information criterion
``BIC = n ln(RSS / n) + p ln(N)`` (``n`` block means, ``N`` samples: the likelihood ratio of
two nested fits is the same on block means as on the samples, and the penalty stays that of
the samples, so blocking does not change which terms are kept; when the least significant
term has ``(c / se)^2 > 4 ln N`` its removal would raise the BIC by ~``3 ln N`` (Wald), and the
elimination stops without refitting); the linear stiffness ``x`` and the last damping term stay.
When that backward path stalls (an ill-conditioned library on a short record), a forward path
from ``x`` and ``v`` is tried as well (:mod:`eddi.selection`).
:attr:`Refinement.dropped` says, per term removed, the BIC change and the coefficient it had.
:func:`confidence_intervals` gives the same covariance for a model that is not refitted
(only its initial state is fitted).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from eddi.errors import SignalError, TooShortToRefine
from eddi.intervals import integration_shift, measured_kernel_margin
from eddi.model import EquationOfMotion
from eddi.output_error import DIRECT_NRMSE, NUISANCE, STAGES, OutputErrorProblem
from eddi.secant_jacobian import switching_model
from eddi.refine_grid import (  # noqa: F401 - re-exported: the grid's rules, importable from here as before
    BLOCK_H_OMEGA, LOCAL_H_OMEGA, MIN_BLOCKS, block_means, block_size, local_substeps, smooth_model,
)

#: The problem class under its name before the split into modules.
_OutputError = OutputErrorProblem

__all__ = ["BLOCK_H_OMEGA", "LOCAL_H_OMEGA", "MIN_BLOCKS", "NUISANCE", "Refinement", "block_means", "block_size",
           "bounded_intervals", "confidence_intervals", "local_substeps", "refine_output_error", "smooth_model"]


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
        Fitted initial state at the centre of the first block (the window start when
        ``block`` is 1).
    evaluations : int
        Simulations asked for (all stages, Jacobians included; one asked for again at the
        point just simulated is served from memory, bit for bit the same, and counted).
    samples : int
        Samples in the whole window.
    block : int
        Samples per block mean compared (1: every sample; see :func:`block_size`).
    unselected, unselected_ci95 : dict of str to dict of str to float
        The output-error fit of every starting term before the selection: coefficients and
        their 95 % half widths (what :func:`bounded_intervals` bounds another estimate with).
    ci95 : dict of str to dict of str to float
        ``{"damping": {term: half width}, "stiffness": {...}}`` of the 95 % confidence
        intervals of the returned coefficients (empty when not computed).
    dropped : dict of str to str
        Terms removed by the selection, and why (empty without ``select``).
    kernel_margin, unselected_kernel_margin : dict of str to dict of str to float
        Asked for with ``kernel_known=False``: how far an unstated sampling kernel can move the
        returned (the unselected) coefficients, as the record bounds it
        (:func:`eddi.intervals.measured_kernel_margin`); empty when not computed or negligible.
    kernel_estimate : tuple of float, optional
        The record's own estimate of its sampling kernel, in means over a sample interval, and
        its standard error (0 for point samples, 1 for interval means).
    ci95_given_selection : dict of str to dict of str to float
        When the selection dropped terms: the half widths as if the dropped terms were known to be
        absent (the covariance of the selected model). ``ci95`` is then per coefficient the wider
        of these and :func:`bounded_intervals` from the fit of every term (``unselected``): two
        terms the record barely tells apart (``x^2*v`` and ``v^3``, whose losses per cycle both
        grow like the amplitude cubed) trade off, and the survivor carries the dropped one's
        share outside its conditional interval (session 12: +27-35 %, 6-17 standard errors).
        Empty when nothing was dropped or the fit of every term sits in another minimum.
    """

    channel: str
    nrmse_before: float
    nrmse_after: float
    x0: float
    v0: float
    evaluations: int
    samples: int
    ci95: dict[str, dict[str, float]] = field(default_factory=dict)
    dropped: dict[str, str] = field(default_factory=dict)
    block: int = 1
    unselected: dict[str, dict[str, float]] = field(default_factory=dict)
    unselected_ci95: dict[str, dict[str, float]] = field(default_factory=dict)
    kernel_margin: dict[str, dict[str, float]] = field(default_factory=dict)
    unselected_kernel_margin: dict[str, dict[str, float]] = field(default_factory=dict)
    kernel_estimate: tuple[float, float] | None = None
    ci95_given_selection: dict[str, dict[str, float]] = field(default_factory=dict)


#: Fewest samples an output-error fit is tried on. Its stages start over the first 64 compared
#: values (``max(64, ...)``: every stage is the whole record on a shorter one), which once was
#: also the least record refined: a 256 Hz, 18.7 Hz ring-down of 56 samples (4 cycles, 13.7
#: samples a cycle) was then refused (``station diagnose``: no verdict). What a fit needs is
#: more compared values than parameters (:data:`VALUES_PER_PARAMETER`).
MIN_SAMPLES = 16
#: Compared values a fitted parameter (coefficients and the initial state) needs at least.
VALUES_PER_PARAMETER = 4


def _check(t: np.ndarray, x: np.ndarray, v: np.ndarray, a: np.ndarray | None,
           channel: str | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, str]:
    t = np.asarray(t, dtype=float)
    n = t.size
    if n < MIN_SAMPLES:
        raise TooShortToRefine(f"output-error refinement needs >= {MIN_SAMPLES} samples, got {n}")
    x = np.asarray(x, dtype=float)
    v = np.asarray(v, dtype=float)
    if channel is None:
        channel = "a" if a is not None else "x"
    if channel not in ("a", "v", "x") or (channel == "a" and a is None):
        raise SignalError(f"refinement channel must be 'a' (with a given), 'v' or 'x'; got {channel!r}"
                          + (" without a" if channel == "a" else ""))
    y = np.asarray({"a": a, "v": v, "x": x}[channel], dtype=float)
    return t, x, v, y, channel


def _fit_in_stages(prob: OutputErrorProblem, max_nfev: int,
                   norm: float) -> tuple[np.ndarray, float, float, np.ndarray | None]:
    """Levenberg-Marquardt over growing windows (:data:`STAGES`) from the problem's start.

    Returns the parameters, the nrmse (over ``norm``) before and after, and the Jacobian at
    the returned parameters when the last fit evaluated it there (else None). A start worse
    after than before is returned as it was.
    """
    n = prob.n
    p = prob.p0.copy()
    before = float(np.linalg.norm(prob.residual(p, n))) / norm
    sol = None
    # a start already within a fraction of a radian of the record over the whole window is in
    # the whole window's basin: the growing stages are for starts that would slip a cycle
    for frac in (STAGES if before > DIRECT_NRMSE else STAGES[-1:]):
        sol = prob.fit(p, max(64, int(round(frac * n))), max_nfev)
        p = sol.x
    after = float(np.linalg.norm(prob.residual(p, n))) / norm
    if not after <= before:  # never return a worse fit than the start
        p, after, sol = prob.p0.copy(), before, None
    # the Jacobian at the optimum: least_squares evaluated it there (the last stage is the whole window);
    # not a switching model's (MINPACK's tiny step divides the switches' jumps: eddi.secant_jacobian)
    jac = (sol.jac if sol is not None and sol.jac.shape == (n, p.size) and not switching_model(prob.model_of(p))
           else None)
    return p, before, after, jac


def refine_output_error(
    eom: EquationOfMotion,
    t: np.ndarray,
    x: np.ndarray,
    v: np.ndarray,
    a: np.ndarray | None = None,
    *,
    channel: str | None = None,
    max_nfev: int = 60,
    select: bool = False,
    mapper=None,
    min_gain: float | None = None,
    kernel_var: float = 0.0,
    kernel_known: bool = True,
) -> tuple[EquationOfMotion, Refinement]:
    """Refine the coefficients of ``eom`` by fitting its free response to the measurement.

    Parameters
    ----------
    eom : EquationOfMotion
        Starting model (from EDDI); its terms are kept (unless ``select``), their
        coefficients refined.
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
    select : bool
        Remove terms the data do not support (BIC, see the module notes).
    mapper : callable, optional
        ``mapper(fn, items) -> [fn(item) for item in items]`` for the independent trials of
        the forward term selection (:func:`eddi.selection._forward`), possibly in forked
        processes (:mod:`eddi.diagnosis.mapping`); default: in turn, here. Same result. A
        mapper that forks (``jobs`` > 1) also fits the forward path's start beside the fit of
        every term (:func:`eddi.selection.fit_beside_forward_start`).
    min_gain : float, optional
        End a stage when a Levenberg-Marquardt step lowers the sum of squares by less than
        ``min_gain`` times its mean square per compared value (``RSS / n``: about the noise
        variance once the model fits, so ``min_gain = 1`` stops where a step moves the fit by
        less than one unit of chi-square). Default: run each stage to ``max_nfev`` or to
        rounding (``ftol`` 1e-12), as the identification does.
    kernel_var : float
        Variance of the DAQ's sampling kernel [sample intervals^2] (:func:`eddi.intervals.sampling_curvature`;
        :attr:`eddi.conditioning.ConditionedSignal.sample_kernel_var`): 0 for point samples.
    kernel_known : bool
        False when the record does not state its sampling: the fit then also measures how far
        means over each sample interval would move the coefficients (``Refinement.kernel_margin``).

    Returns
    -------
    eom : EquationOfMotion
        Refined model (same mass and effects; same terms unless ``select``).
    info : Refinement
        With ``ci95`` of the returned coefficients.

    Raises
    ------
    TooShortToRefine
        (an :class:`~eddi.errors.IdentificationError`) If the window is too short (fewer than
        :data:`MIN_SAMPLES` samples, or than :data:`VALUES_PER_PARAMETER` compared values per
        fitted parameter).
    SignalError
        If ``channel`` is unknown, or ``"a"`` without ``a``.
    """
    t, x, v, y, channel = _check(t, x, v, a, channel)
    prob = OutputErrorProblem(eom, t, x, v, y, channel, kernel_var)
    n = prob.n
    if n < VALUES_PER_PARAMETER * prob.p0.size:
        raise TooShortToRefine(f"output-error refinement of {prob.p0.size} parameters needs >= "
                                  f"{VALUES_PER_PARAMETER * prob.p0.size} compared values, got {n}")
    prob.min_gain = None if min_gain is None else float(min_gain)
    norm = float(np.linalg.norm(prob.y)) or 1.0
    if select:
        from eddi.selection import core_start, fit_beside_forward_start, select_terms  # local: it builds on this module
        core_coef = core_start(prob, t, x, v, y)
        # when the mapper forks, the forward selection's start is fitted beside (eddi.selection)
        (p, before, after, jac), start = fit_beside_forward_start(
            prob, lambda: _fit_in_stages(prob, max_nfev, norm), core_coef, max_nfev, mapper)
    else:
        p, before, after, jac = _fit_in_stages(prob, max_nfev, norm)
    half, rss = prob.ci95(p, jac)
    # the fit's own RK4 error, corrected (eddi.intervals.integration_shift)
    shift, spread = integration_shift(prob, p, jac)
    unselected = prob.model_of(_shifted(p, shift))
    unselected_ci = prob.ci_dict(half + spread * prob.scale[prob.active])
    measured = None if kernel_known else measured_kernel_margin(prob, p, half, jac)
    unselected_margin = {} if measured is None else prob.ci_dict(measured[0] * prob.scale[prob.active])
    dropped: dict[str, str] = {}
    if select:
        p, half, dropped = select_terms(prob, p, half, rss, max_nfev, core_coef, mapper, start)
        after = min(after, float(np.linalg.norm(prob.residual(p, n))) / norm)
        if dropped:
            shift, spread = integration_shift(prob, p)
            if not kernel_known:
                measured = measured_kernel_margin(prob, p, half)
    full_optimal = dropped and rss <= _full_fit_tolerance(prob, p)
    p = _shifted(p, shift)
    half = half + spread * prob.scale[prob.active]
    refined = prob.model_of(p).model_copy(update={"notes": (eom.notes + "; " if eom.notes else "")
                                                  + f"refined by output error on {channel}"})
    x0, v0 = prob.state(p)
    full = {"damping": dict(unselected.damping), "stiffness": dict(unselected.stiffness)}
    ci95 = given = prob.ci_dict(half)
    if full_optimal:  # the selection's uncertainty: what the fit with the dropped terms allows
        ci95 = _widest(ci95, bounded_intervals(refined, full, unselected_ci))
    return refined, Refinement(channel=channel, nrmse_before=before, nrmse_after=after, x0=x0, v0=v0,
                               evaluations=prob.count, samples=prob.n_samples, ci95=ci95,
                               ci95_given_selection=given if full_optimal else {},
                               dropped=dropped, block=prob.block, unselected=full,
                               unselected_ci95=unselected_ci,
                               kernel_margin=({} if measured is None
                                              else prob.ci_dict(measured[0] * prob.scale[prob.active])),
                               unselected_kernel_margin=unselected_margin,
                               kernel_estimate=None if measured is None else (measured[1], measured[2]))


def _full_fit_tolerance(prob: OutputErrorProblem, p: np.ndarray) -> float:
    """The largest RSS of the fit of every term that still counts as the optimum of that fuller
    model next to the selected one at ``p``: the selected RSS plus two units of chi-square (the
    fuller model nests the selected one; a fuller fit worse than that sits in another minimum,
    and its intervals say nothing of this one)."""
    r = prob.residual(p, prob.n)
    rss = float(r @ r)
    return rss + 2.0 * rss / max(1, prob.n - p.size)


def _widest(a: dict[str, dict[str, float]], b: dict[str, dict[str, float]]) -> dict[str, dict[str, float]]:
    """Per coefficient the wider of two sets of half widths (``a``'s terms)."""
    return {g: {t: max(h, b.get(g, {}).get(t, h)) for t, h in a[g].items()} for g in a}


def _shifted(p: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """``p`` with its active coefficients moved by ``shift`` (the nuisance parameters kept)."""
    out = p.copy()
    out[: shift.size] += shift
    return out


def confidence_intervals(eom: EquationOfMotion, t: np.ndarray, x: np.ndarray, v: np.ndarray,
                         a: np.ndarray | None = None, *, channel: str | None = None,
                         kernel_var: float = 0.0) -> dict[str, dict[str, float]]:
    """95 % half widths of the coefficients of ``eom`` as they stand (not refitted).

    Only the initial state of the free response is fitted; the covariance is that of the
    output-error problem at ``eom`` (see the module notes), its residual including any bias
    of ``eom``.

    Returns
    -------
    dict
        ``{"damping": {term: half width}, "stiffness": {...}}`` in the coefficients' units.
    """
    t, x, v, y, channel = _check(t, x, v, a, channel)
    prob = OutputErrorProblem(eom, t, x, v, y, channel, kernel_var)
    free = np.zeros(prob.p0.size, dtype=bool)
    free[-NUISANCE:] = True
    p = prob.p0.copy()
    for frac in STAGES:
        p = prob.fit(p, max(64, int(round(frac * prob.n))), 20, free=free).x
    half, _ = prob.ci95(p)
    return prob.ci_dict(half)


def bounded_intervals(eom: EquationOfMotion, reference: dict[str, dict[str, float]],
                      reference_ci95: dict[str, dict[str, float]]) -> dict[str, dict[str, float]]:
    """95 % half widths for an estimate that is not the output-error fit (EDDI's).

    ``|c - c_ref| + h_ref`` per coefficient, where ``c_ref +- h_ref`` is the output-error fit
    of the same terms (:attr:`Refinement.unselected`): whenever the reference interval
    holds the true value, so does this one (triangle inequality), so it covers at least at
    the reference's rate. The output-error covariance evaluated at EDDI's model instead
    (:func:`confidence_intervals`) leaves out EDDI's own error and covered 0-40 % on
    the records where the pipeline kept EDDI's estimate (``benchmarks/bench_ci_coverage.py``).

    Parameters
    ----------
    eom : EquationOfMotion
        The estimate.
    reference, reference_ci95 : dict
        ``{"damping": {term: value}, "stiffness": {...}}`` and the half widths.

    Returns
    -------
    dict
        ``{"damping": {term: half width}, "stiffness": {...}}``; a term the reference lacks
        gets ``inf``.
    """
    out: dict[str, dict[str, float]] = {"damping": {}, "stiffness": {}}
    for group in ("damping", "stiffness"):
        for term, c in getattr(eom, group).items():
            ref = reference.get(group, {}).get(term)
            half = reference_ci95.get(group, {}).get(term)
            out[group][term] = (abs(c - ref) + half) if ref is not None and half is not None else math.inf
    return out
