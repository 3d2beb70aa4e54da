"""EDDI identification: phase one (damping), phase two (stiffness), joined.

:func:`identify` takes a measured free response ``(t, x, v)`` of a generalized coordinate
and the known mass (or inertia) and returns an :class:`IdentifiedModel` holding the
equation of motion, the route used in phase two and everything both phases measured.
It adds no numerics of its own: it checks inputs, cuts the window, calls
:func:`eddi.phase_one.phase_one` and a route of :mod:`eddi.phase_two`, and (for
``route="auto"``) keeps the route whose model reproduces the measured response best.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from eddi.energy import check_series, noise_level, sample_window
from eddi.errors import ModelError, SignalError, TermError
from eddi.model import EquationOfMotion
from eddi.peaks import peak_abs
from eddi.phase_one import PhaseOneResult, phase_one
from eddi.phase_two import ROUTES, PhaseTwoResult, lagrangian_route, potential_route
from eddi.slow_errors import drift_basis
from eddi.terms import DEFAULT_DAMPING, DEFAULT_STIFFNESS, Term, parse_terms

if TYPE_CHECKING:
    from eddi.refine import Refinement


@dataclass(frozen=True)
class IdentifiedModel:
    """The result of :func:`identify`.

    Attributes
    ----------
    eom : EquationOfMotion
        ``mass x'' + sum b_j B_j + sum k_n K_n = F``.
    route : str
        Phase-two route used: ``"potential"`` or ``"lagrangian"``.
    phase_one : PhaseOneResult
        Crossings, ``T(gamma_i)``, ``Q``, ``R``, dissipated and mechanical energies.
    phase_two : PhaseTwoResult
        Samples and fit of the route used.
    window : tuple of int
        ``[start, stop)`` sample indices of the caller's arrays that were used.
    route_scores : dict of str to float
        For ``route="auto"``: the free-response NRMSE of the model of each route tried,
        over the span of the crossings (lower is better); empty otherwise.
    alternatives : dict of str to PhaseTwoResult
        Phase-two results of the routes tried.
    unrefined : EquationOfMotion or None
        With ``refine=True``: the EDDI estimate before the output-error refinement
        (``eom`` is then the refined model); None otherwise.
    refinement : Refinement or None
        With ``refine=True``: what the refinement did (:class:`eddi.refine.Refinement`).
    """

    eom: EquationOfMotion
    route: str
    phase_one: PhaseOneResult
    phase_two: PhaseTwoResult
    window: tuple[int, int]
    route_scores: dict[str, float] = field(default_factory=dict)
    alternatives: dict[str, PhaseTwoResult] = field(default_factory=dict)
    unrefined: EquationOfMotion | None = None
    refinement: Refinement | None = None


def _terms(spec: str | tuple[str, ...] | list[str], what: str) -> tuple[Term, ...]:
    terms = parse_terms(spec)
    if not terms:
        raise TermError(f"{what} library is empty; give at least one term")
    return terms


def identify(
    t: np.ndarray,
    x: np.ndarray,
    v: np.ndarray,
    mass: float,
    *,
    damping: str | tuple[str, ...] | list[str] = DEFAULT_DAMPING,
    stiffness: str | tuple[str, ...] | list[str] = DEFAULT_STIFFNESS,
    route: str = "auto",
    a: np.ndarray | None = None,
    window: tuple[int, int] | None = None,
    coordinate: str = "displacement [m]",
    weighting: str = "relative",
    energy_floor: float = 1e-6,
    v_fraction: float = 0.0,
    anchored: bool = True,
    noise: str | tuple[float, float] | None = "auto",
    refine: bool | str = False,
    select: bool = False,
    mapper=None,
    kernel_var: float = 0.0,
    kernel_known: bool = True,
) -> IdentifiedModel:
    """Identify an equation of motion from a free response with the EDDI method.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Uniform, increasing sample times.
    x : ndarray, shape (n,)
        Generalized coordinate, measured from static equilibrium ([m], [rad]...).
    v : ndarray, shape (n,)
        Its rate ([m/s], [rad/s]...).
    mass : float
        Mass [kg], or inertia for an angle (pendulum: ``m l^2``), > 0.
    damping : str or sequence of str
        Damping candidates ``B_j(x, v)`` (e.g. ``"v,x^2*v,v^3"``).
    stiffness : str or sequence of str
        Stiffness candidates ``K_n(x)`` (functions of ``x`` only).
    route : {"auto", "potential", "lagrangian"}
        Phase-two route. ``"auto"`` fits both and keeps the one whose model's free
        response from the first crossing matches the measurement best (ties, i.e. scores
        within ``ROUTE_TIE`` of each other, go to the potential route).
    a : ndarray, shape (n,), optional
        Measured acceleration: sharpens ``v`` at the crossings, and the Lagrangian route
        uses it instead of differentiating ``v``.
    window : tuple of int, optional
        ``[start, stop)`` sample indices of the free response to use (default: all).
    coordinate : str
        What ``x`` is, stored in the model for people.
    weighting : {"relative", "paper"}
        Phase-one row weighting (see :mod:`eddi.phase_one`).
    energy_floor : float
        Smallest energy, relative to ``E(gamma_0)``, used in phase-two row weights.
    v_fraction : float
        Lagrangian route: samples with ``|v|`` below this fraction of the velocity
        amplitude at the current energy are left out (default 0: none; the route needs no
        division by ``v``, :mod:`eddi.phase_two`).
    anchored : bool
        The potential route uses the mechanical energy re-anchored on ``T(gamma_i)`` at
        every crossing (default) instead of the paper's Eq. 12 (accumulated from
        ``gamma_0``). The Lagrangian route always uses Eq. 12's exact rate (the anchoring
        adds only the half-cycle energy misfits, which do no work against the
        conservative force; :mod:`eddi.phase_two`).
    noise : "auto", None or (sigma_x, sigma_v)
        Noise on ``x`` and ``v``: ``"auto"`` (default) estimates white noise from third
        differences (:func:`eddi.energy.noise_level`; on clean data this changes the
        paper-case coefficients by < 1e-8 relative); ``None`` assumes clean signals; or
        give the standard deviations. It sets a 4-sigma dead band on the zero crossings and
        inverse-variance row weights in phase one and the potential route; unless ``None``,
        the white noise of ``a`` (third differences) weights the Lagrangian route's rows.
    refine : bool or {"a", "v", "x"}
        After EDDI, refine the coefficients by an output-error fit (:mod:`eddi.refine`):
        the model's free response from a fitted initial state is fitted to the measured
        ``a`` (or ``x`` without ``a``; or the signal named) over the window. Not part of the
        paper's method; the EDDI estimate is kept in ``unrefined``. Much more accurate on
        noisy records (``docs/eddi-method.md``), and slower (20-60 simulations with their
        sensitivities, of the first 1/8, 1/2 and all of the window, on block means).
    select : bool
        With ``refine``: remove the terms the data do not support (BIC backward
        elimination, :func:`eddi.refine.refine_output_error`).
    mapper : callable, optional
        For the refinement's independent term-selection trials (see
        :func:`eddi.refine.refine_output_error`); default: in turn, here. Same result.
    kernel_var : float
        With ``refine``: variance of the DAQ's sampling kernel [sample intervals^2]
        (:func:`eddi.intervals.sampling_curvature`); 0 for point samples.
    kernel_known : bool
        With ``refine``: False when the record does not state its sampling (the refinement then
        measures the margin an unstated kernel needs, ``Refinement.kernel_margin``).

    Returns
    -------
    IdentifiedModel

    Raises
    ------
    ModelError
        If ``mass`` is not a finite positive number.
    SignalError
        On NaN, length mismatch, non-uniform or non-increasing time, bad window.
    TermError
        On an unknown term, a duplicated term, or a stiffness term that depends on ``v``.
    IdentificationError
        If the window holds too few zero crossings.
    """
    try:
        mass_f = float(mass)
    except (TypeError, ValueError):
        raise ModelError(f"mass must be a number > 0, got {mass!r}") from None
    if not (math.isfinite(mass_f) and mass_f > 0):
        raise ModelError(f"mass must be > 0, got {mass!r}")
    if route not in ("auto",) + ROUTES:
        raise SignalError(f"route must be one of auto, {', '.join(ROUTES)}; got {route!r}")
    d_terms = _terms(damping, "damping")
    k_terms = _terms(stiffness, "stiffness")
    for tm in k_terms:
        if tm.depends_on_v:
            raise TermError(f"stiffness term {tm.text!r} depends on v; put it in the damping library")
    t, sig = check_series(t, {"x": x, "v": v, "a": a})
    w0, w1 = sample_window(window, t.size, 4)
    tw, xw, vw = t[w0:w1], sig["x"][w0:w1], sig["v"][w0:w1]
    aw = sig["a"][w0:w1] if sig["a"] is not None else None

    if noise is None:
        sx, sv = 0.0, 0.0
    elif isinstance(noise, str):
        if noise != "auto":
            raise SignalError(f"noise must be None, 'auto' or (sigma_x, sigma_v); got {noise!r}")
        sx, sv = noise_level(xw), noise_level(vw)
    else:
        try:
            sx, sv = float(noise[0]), float(noise[1])
        except (TypeError, ValueError, IndexError):
            raise SignalError(f"noise must be None, 'auto' or (sigma_x, sigma_v); got {noise!r}") from None
        if not (sx >= 0 and sv >= 0 and math.isfinite(sx) and math.isfinite(sv)):
            raise SignalError(f"noise standard deviations must be finite and >= 0; got {noise!r}")
    # white noise of the measured acceleration (weights of the Lagrangian route's rows)
    sa = noise_level(aw) if (noise is not None and aw is not None) else 0.0
    p1 = phase_one(tw, xw, vw, mass_f, d_terms, a=aw, weighting=weighting, offset=w0,
                   noise_x=sx, noise_v=sv)
    i0, i1 = p1.sample_slice[0] - w0, p1.sample_slice[1] - w0
    xs, vs = xw[i0:i1], vw[i0:i1]
    a_s = aw[i0:i1] if aw is not None else None
    b = p1.as_dict()

    def model(p2: PhaseTwoResult) -> EquationOfMotion:
        return EquationOfMotion.create(
            mass=mass_f, damping=b, stiffness=p2.as_dict(), coordinate=coordinate,
            notes=f"identified by EDDI (phase two: {p2.route} route) from samples {w0}..{w1}",
        )

    results: dict[str, PhaseTwoResult] = {}
    # both routes' slow-error columns use the same drift basis over phase one's samples (built
    # here once when there are rows enough for it to be used: >= 4 functions, 2 columns each)
    drift = drift_basis(p1.t, p1.gamma) if route == "auto" and p1.t.size >= 10 * (len(k_terms) + 8) else None
    if route in ("auto", "potential"):
        results["potential"] = potential_route(p1, xs, k_terms, energy_floor=energy_floor,
                                               anchored=anchored, noise_v=sv, v=vs, mass=mass_f, drift=drift)
    if route in ("auto", "lagrangian"):
        results["lagrangian"] = lagrangian_route(p1, xs, vs, mass_f, k_terms, a=a_s,
                                                 v_fraction=v_fraction, energy_floor=energy_floor,
                                                 noise_a=sa, drift=drift)
    scores: dict[str, float] = {}
    if route == "auto":
        for name, p2 in results.items():
            scores[name] = _free_response_score(model(p2), p1.t, xs, vs)
        chosen = min(results, key=lambda k: scores[k])
        if scores["potential"] <= (1.0 + ROUTE_TIE) * scores[chosen]:
            chosen = "potential"
    else:
        chosen = route
    p2 = results[chosen]
    eom = model(p2)
    unrefined = None
    refinement = None
    if refine:
        from eddi.refine import refine_output_error  # local: scipy.optimize, the simulator

        unrefined = eom
        eom, refinement = refine_output_error(eom, tw, xw, vw, aw,
                                              channel=refine if isinstance(refine, str) else None,
                                              select=select, mapper=mapper, kernel_var=kernel_var,
                                              kernel_known=kernel_known)
    return IdentifiedModel(
        eom=eom, route=chosen, phase_one=p1, phase_two=p2, window=(w0, w1),
        route_scores=scores, alternatives=results, unrefined=unrefined, refinement=refinement,
    )


#: Relative difference of route scores below which the routes tie (then: potential). Two
#: models that are both exact to 1e-8 score within ~2 % of each other (the RK4 error of the
#: scoring simulation, ~1e-5 NRMSE on the paper Duffing, dominates both scores).
ROUTE_TIE = 0.05

#: Largest ``h * omega_max`` of the route-scoring simulation grid (see
#: :func:`_free_response_score`), the simulator's own sub-step rule: RK4 phase error
#: ~ (h omega)^5 / 120 per step, i.e. ~5e-6 rad per cycle at the stiffest amplitude.
SCORE_H_OMEGA = 0.1


def _free_response_score(eom: EquationOfMotion, t: np.ndarray, x: np.ndarray,
                         v: np.ndarray) -> float:
    """NRMSE of the free response of ``eom`` from the measured state at ``t[0]``.

    The simulation runs on every ``k``-th sample, ``k`` as large as keeps
    ``k dt omega_max <= SCORE_H_OMEGA`` (``omega_max``: the model's largest local angular
    frequency over the measured amplitudes). Densely sampled records (19.2 kHz for a few
    Hz) are scored some 10-40 times faster than on every sample, with the same ranking.

    Parameters
    ----------
    eom : EquationOfMotion
    t : ndarray, shape (k,), [s]
    x, v : ndarray, shape (k,)
        Measured coordinate and rate over ``t``.

    Returns
    -------
    float
        ``||x_sim - x|| / ||x||`` over the decimated grid (``inf`` if it diverged).
    """
    from eddi.simulate import max_angular_frequency  # local: the simulator imports numba
    from eddi.validate import validate

    dt = float(t[1] - t[0])
    omega = max_angular_frequency(eom, peak_abs(x), peak_abs(v))
    k = max(1, int(SCORE_H_OMEGA / (dt * omega))) if omega > 0 else 1
    k = min(k, max(1, t.size // 64))
    return validate(eom, t[::k], x[::k], v=v[::k]).nrmse
