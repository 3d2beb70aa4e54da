"""Phase two of EDDI: the stiffness model from the mechanical energy of phase one.

Two routes, both fed by ``E(t) = T(gamma_0) - D(t)`` from phase one:

``"potential"`` (never divides by ``v``)
    ``V(x(t)) = E(t) - T(t)`` at every sample, and ``V(x) = sum_n k_n integral_0^x K_n``
    is linear in the stiffness coefficients (``x^(n+1)/(n+1)`` for ``x^n``). Rows are
    weighted by ``1 / E(t)`` (relative energy error), floored at ``energy_floor * E(gamma_0)``.
``"lagrangian"`` (paper Eqs. 13-16)
    ``L = 2T - E``; the conservative force is ``dL/dq - p qdd / qd`` with ``p = m qd``,
    ``dL/dq = (dL/dt) / qd`` and ``dL/dt = 2 m qd qdd - dE/dt``. With ``E`` of Eq. 12,
    ``dE/dt = -v B(x, v)`` exactly (:func:`energy_rate`) and the force is
    ``m a + B(x, v)``: evaluated in that closed form, no sample is divided by ``v`` and the
    turning points, where the stiffness terms are largest, stay in. The re-anchored energy
    (``anchored=True``) adds to ``dE/dt`` a constant power over each half cycle, that half
    cycle's energy-balance misfit: the conservative force does no work between two zeros of
    ``x``, so the misfit says nothing about it, and divided by ``v`` it is singular at the
    turning points (samples with ``|v|`` below ``v_fraction`` of the velocity amplitude at
    the current energy are then left out). :func:`eddi.identify.identify` uses Eq. 12 here.
    The force is regressed on ``-K_n(x)``; row weights in :func:`lagrangian_route`.

Sign convention: the equation of motion is ``m x'' + B + K(x) = F`` with
``K = sum k_n K_n``; the conservative force is ``F_c = -K(x) = -dV/dx``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eddi.calculus import spline_derivative
from eddi.energy import SPLINE_DEGREE, integrated_term, term_matrix
from eddi.phase_one import PhaseOneResult, scaled_lstsq
from eddi.slow_errors import drift_basis, normal_lstsq, rate_error_columns, refit_with_offset
from eddi.terms import Term, parse_terms

ROUTES = ("potential", "lagrangian")


@dataclass(frozen=True)
class PhaseTwoResult:
    """What phase two found.

    Attributes
    ----------
    route : str
        ``"potential"`` or ``"lagrangian"``.
    terms : tuple of str
        Stiffness terms, in the order of ``coefficients``.
    coefficients : ndarray, shape (m,)
        Identified ``k_n``.
    x : ndarray, shape (k,)
        Coordinate at the samples used in the regression.
    potential : ndarray, shape (k,) or None, [J]
        ``V = E - T`` at those samples (potential route).
    conservative_force : ndarray, shape (k,) or None, [N]
        ``F_c = -K(x)`` samples from Eq. 16 (Lagrangian route).
    residual : float
        Weighted RMS misfit of the regression, relative (potential: of ``V`` over ``E``;
        Lagrangian: of the force over its RMS).
    condition_number : float
        Of the column-scaled, weighted regression matrix.
    samples_used : int
        Rows of the regression.
    """

    route: str
    terms: tuple[str, ...]
    coefficients: np.ndarray
    x: np.ndarray
    potential: np.ndarray | None
    conservative_force: np.ndarray | None
    residual: float
    condition_number: float
    samples_used: int

    def as_dict(self) -> dict[str, float]:
        """Coefficients by term."""
        return {name: float(c) for name, c in zip(self.terms, self.coefficients)}


def mechanical_energy(p1: PhaseOneResult, anchored: bool) -> np.ndarray:
    """``E(t)`` of phase one: re-anchored at every crossing, or from ``gamma_0`` (Eq. 12)."""
    return p1.mechanical_anchored if anchored else p1.mechanical


def energy_rate(p1: PhaseOneResult, x: np.ndarray, v: np.ndarray, anchored: bool) -> np.ndarray:
    """``dE/dt`` of phase one's mechanical energy at its samples, exactly.

    ``E = T(gamma_0) - D(t)`` has ``dE/dt = -v B(x, v)`` (the modelled damping power, which
    the quintic spline of phase one interpolates at the samples). The re-anchored energy
    adds, between ``gamma_i`` and ``gamma_i+1``, the constant slope
    ``(T(gamma_i+1) - T(gamma_i) + D_i+1 - D_i) / (gamma_i+1 - gamma_i)`` of its blend (the
    misfit of that half cycle's energy balance, spread over it); before ``gamma_0`` and after
    ``gamma_N`` it is carried from one crossing and adds nothing.

    Parameters
    ----------
    p1 : PhaseOneResult
    x, v : ndarray, shape (k,)
        Coordinate and rate at the samples ``p1.t``.
    anchored : bool
        Rate of ``p1.mechanical_anchored`` (True) or of ``p1.mechanical`` (False).

    Returns
    -------
    ndarray, shape (k,), [W]
    """
    terms = parse_terms(p1.terms)
    rate = -v * (term_matrix(terms, x, v) @ p1.coefficients)
    if anchored:
        gamma = p1.gamma
        d_gamma = np.concatenate(([0.0], p1.dissipated_model_at_gamma))
        misfit = np.diff(p1.kinetic_at_gamma) + np.diff(d_gamma)
        i = np.clip(np.searchsorted(gamma, p1.t, side="right") - 1, 0, gamma.size - 2)
        inside = (p1.t >= gamma[0]) & (p1.t <= gamma[-1])
        rate = rate + np.where(inside, (misfit / np.diff(gamma))[i], 0.0)
    return rate


def _dk_dx(terms: tuple[Term, ...], x: np.ndarray) -> np.ndarray:
    """``dK_n/dx`` at ``x`` by a central difference (step 1e-6 of ``max |x|``)."""
    h = 1e-6 * max(float(np.max(np.abs(x))), 1e-300)
    zero = np.zeros_like(x)
    return (term_matrix(terms, x + h, zero) - term_matrix(terms, x - h, zero)) / (2.0 * h)


def _nuisance_basis(p1: PhaseOneResult, n_terms: int, basis=None):  # -> eddi.bspline.BandedRows | None
    """:func:`eddi.slow_errors.drift_basis` over phase one's samples, or None when too few rows.

    The nuisance columns (two per basis function) must leave at least ten rows per unknown.
    ``basis``: that basis when the caller already built it (both routes use the same one).
    """
    if basis is None:
        basis = drift_basis(p1.t, p1.gamma)
    if p1.t.size < 10 * (n_terms + 2 * basis.shape[1]):
        return None
    return basis


def _floor(energy: np.ndarray, p1: PhaseOneResult, energy_floor: float) -> np.ndarray:
    e0 = float(p1.kinetic_at_gamma[0])
    return np.maximum(energy, energy_floor * e0)


def potential_route(
    p1: PhaseOneResult,
    x: np.ndarray,
    terms: tuple[Term, ...],
    *,
    energy_floor: float = 1e-6,
    anchored: bool = True,
    noise_v: float = 0.0,
    v: np.ndarray | None = None,
    mass: float = 1.0,
    relative_accuracy: float = 1e-6,
    slow_errors: bool = True,
    drift=None,
) -> PhaseTwoResult:
    """Stiffness from ``V(x) = E - T`` (no division by ``v``).

    Parameters
    ----------
    p1 : PhaseOneResult
        Phase-one result; its ``mechanical`` and ``kinetic`` energies are used.
    x : ndarray, shape (k,)
        Coordinate at the samples of ``p1.t``.
    terms : tuple of Term
        Stiffness candidates ``K_n(x)``.
    energy_floor : float
        Smallest energy used in the row weights, relative to ``E(gamma_0)``.
    anchored : bool
        Use ``E`` re-anchored at every crossing (default) rather than Eq. 12.
    noise_v : float
        Standard deviation of the noise on ``v``; with ``v`` and ``mass`` it adds the
        variance ``(mass noise_v)^2 (v^2 + 2E/mass)`` of ``V`` to the row weights.
    v : ndarray, shape (k,), optional
        Rate at the samples (only for the noise weighting).
    mass : float
        Mass or inertia (only for the noise weighting).
    relative_accuracy : float
        Relative accuracy of ``E`` on clean data; rows are weighted by
        ``1 / sqrt((relative_accuracy E)^2 + var_noise)``.
    slow_errors : bool
        Fit, with the stiffness, a slow offset of ``x`` and a slow error of ``v`` (and of
        the energy anchored on it) in the conditioner's drift-spline space, and discard
        them (:mod:`eddi.slow_errors`; default). Needs ``v`` for the rate part.
    drift : eddi.bspline.BandedRows, optional
        :func:`eddi.slow_errors.drift_basis` ``(p1.t, p1.gamma)`` when the caller already built
        it (:func:`eddi.identify.identify` builds it once for both routes).

    Returns
    -------
    PhaseTwoResult
    """
    x = np.asarray(x, dtype=float)
    energy = mechanical_energy(p1, anchored)
    pot = energy - p1.kinetic
    cols = np.column_stack([integrated_term(tm, x) for tm in terms])
    scale = _floor(energy, p1, energy_floor)
    if noise_v > 0 and v is not None:
        # noise of V = E - T: T through v, and E through the T(gamma_i) it is anchored on
        v2 = np.asarray(v, dtype=float) ** 2 + 2.0 * np.abs(energy) / mass
        sd = mass * noise_v * np.sqrt(v2)
        scale = np.sqrt(scale**2 + (sd / relative_accuracy) ** 2)
    w = 1.0 / scale
    coef, cond = scaled_lstsq(cols * w[:, None], pot * w)
    basis = _nuisance_basis(p1, len(terms), drift) if slow_errors else None
    if basis is not None:
        kmat = term_matrix(terms, x, np.zeros_like(x))
        vcols = (rate_error_columns(p1.t, p1.gamma, p1.kinetic_at_gamma, v, mass, basis)
                 if v is not None else None)
        coef = refit_with_offset(cols, pot, w, coef, basis, lambda c: -(kmat @ c), vcols, normal_lstsq, x)
    resid = float(np.sqrt(np.mean(((cols @ coef - pot) * w) ** 2)))
    return PhaseTwoResult(
        route="potential",
        terms=tuple(tm.text for tm in terms),
        coefficients=coef,
        x=x,
        potential=pot,
        conservative_force=None,
        residual=resid,
        condition_number=cond,
        samples_used=int(x.size),
    )


def lagrangian_route(
    p1: PhaseOneResult,
    x: np.ndarray,
    v: np.ndarray,
    mass: float,
    terms: tuple[Term, ...],
    *,
    a: np.ndarray | None = None,
    v_fraction: float = 0.0,
    energy_floor: float = 1e-6,
    anchored: bool = False,
    noise_a: float = 0.0,
    relative_accuracy: float = 1e-6,
    slow_errors: bool = True,
    drift=None,
) -> PhaseTwoResult:
    """Stiffness from the conservative force of the reformulated Lagrangian (paper Eq. 16).

    Parameters
    ----------
    p1 : PhaseOneResult
    x, v : ndarray, shape (k,)
        Coordinate and rate at the samples of ``p1.t``.
    mass : float
        Mass or inertia; the momentum is ``p = mass * v``.
    terms : tuple of Term
        Stiffness candidates.
    a : ndarray, shape (k,), optional
        Acceleration; when absent it is the derivative of a quintic spline of ``v``.
    v_fraction : float
        Samples with ``|v| < v_fraction * sqrt(2 E / m)`` (near turning points) are left out
        (default 0: none; with ``anchored`` samples where ``v = 0`` always are).
    energy_floor : float
        Smallest energy used in the row weights, relative to ``E(gamma_0)``.
    anchored : bool
        Use ``E`` re-anchored at every crossing rather than Eq. 12 (default: Eq. 12; see
        the module notes: on ``benchmarks/bench_vs_sindy.py``'s held-out systems at 30 dB
        the re-anchored rate with turning points left out (``v_fraction`` 0.2) gave the
        stiffness terms 1.3x the median error of Eq. 12's with every sample).
    noise_a : float
        Standard deviation of the white noise on ``a`` [m/s^2]. Rows are weighted by
        ``1 / sqrt((relative_accuracy F0)^2 E / E0 + (mass noise_a)^2)`` (``F0``: the largest
        ``|mass a|``, ``E0``: the first energy): by the relative energy on clean data (as
        ``1 / sqrt(E)``), evenly where the noise dominates. Measured on
        ``benchmarks/bench_vs_sindy.py``'s ``soft_heavy`` at 45 dB, seed 8: the
        ``1 / sqrt(E)`` weights gave the noisy low-amplitude rows the most weight, ``x^3``
        2.6 % off; the even weights 0.05 % (``tests/eddi/test_slow_errors.py``).
    relative_accuracy : float
        Relative accuracy of the force on clean data.
    slow_errors : bool
        Fit a slow offset of ``x`` with the stiffness and discard it
        (:mod:`eddi.slow_errors`; default).
    drift : eddi.bspline.BandedRows, optional
        :func:`eddi.slow_errors.drift_basis` ``(p1.t, p1.gamma)`` when the caller already built
        it (:func:`eddi.identify.identify` builds it once for both routes).

    Returns
    -------
    PhaseTwoResult
    """
    t = p1.t
    energy = mechanical_energy(p1, anchored)
    x = np.asarray(x, dtype=float)
    v = np.asarray(v, dtype=float)
    acc = np.asarray(a, dtype=float) if a is not None else spline_derivative(t, v, SPLINE_DEGREE)
    # dL/dt = d(2T)/dt - dE/dt = 2 m v a - dE/dt, dE/dt = -v B (+ the anchoring's misfit
    # power), so F_c = (dL/dt) / v - m a = m a + B (- misfit power / v)
    e = _floor(energy, p1, energy_floor)
    keep = np.abs(v) >= v_fraction * np.sqrt(2.0 * e / mass)
    fc = mass * acc + term_matrix(parse_terms(p1.terms), x, v) @ p1.coefficients
    if anchored:
        keep &= np.abs(v) > 0
        misfit_power = energy_rate(p1, x, v, True) - energy_rate(p1, x, v, False)
        fc[keep] -= misfit_power[keep] / v[keep]
    cols = -term_matrix(terms, x[keep], v[keep])
    # row error: relative accuracy of the force on clean data (the force amplitude scales as
    # sqrt(E)), and the acceleration's white noise, m sigma_a, on every row alike
    f0 = mass * float(np.max(np.abs(acc))) / np.sqrt(max(float(e[0]), 1e-300))
    w = 1.0 / np.sqrt((relative_accuracy * f0) ** 2 * e[keep] + (mass * noise_a) ** 2)
    coef, cond = scaled_lstsq(cols * w[:, None], fc[keep] * w)
    basis = _nuisance_basis(p1, len(terms), drift) if slow_errors else None
    if basis is not None:
        xk = x[keep]
        dmat = _dk_dx(terms, xk)
        coef = refit_with_offset(cols, fc[keep], w, coef, basis.take(np.flatnonzero(keep)), lambda c: dmat @ c,
                                 None, normal_lstsq, xk)
    fit = cols @ coef
    rms = float(np.sqrt(np.mean((fc[keep] * w) ** 2))) or 1.0
    resid = float(np.sqrt(np.mean(((fit - fc[keep]) * w) ** 2)) / rms)
    return PhaseTwoResult(
        route="lagrangian",
        terms=tuple(tm.text for tm in terms),
        coefficients=coef,
        x=x[keep],
        potential=None,
        conservative_force=fc[keep],
        residual=resid,
        condition_number=cond,
        samples_used=int(keep.sum()),
    )
