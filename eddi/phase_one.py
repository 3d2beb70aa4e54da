"""Phase one of EDDI: the damping model from the energy lost between zero crossings.

At every zero crossing ``gamma_i`` of the coordinate the potential energy is zero, so the
mechanical energy equals the kinetic energy ``T(gamma_i)``. The energy dissipated between
the first crossing and crossing ``i`` is then measured without any model (paper Eq. 7)::

    sum_j b_j integral_{gamma_0}^{gamma_i} v B_j(x, v) dt = T(gamma_0) - T(gamma_i)

which is linear in the damping coefficients ``b_j`` (paper Eqs. 9-11, ``Q b = R``).

Two row weightings are offered, identical for exact data:

``"paper"``
    the rows as written in the paper: cumulative from ``gamma_0``, unweighted.
``"relative"`` (default)
    differences over full cycles (energy lost between a crossing and the next one in the
    same direction, ``T(gamma_i-2) - T(gamma_i)``, :data:`LAG` = 2), each divided by the
    energy at the start of that cycle. Every cycle then counts by its *relative* loss, so
    the low-amplitude end of the record (where linear damping shows) is not drowned by the
    first, large cycles.

The energies phase two regresses on cover every sample of the response, not only the span
between the first and the last crossing: before ``gamma_0`` the energy is ``T(gamma_0)``
plus the modelled dissipation from ``t`` to ``gamma_0`` (less than one half cycle of it),
after ``gamma_N`` it is ``T(gamma_N)`` minus that from ``gamma_N``. The samples before
``gamma_0`` are the first half cycle after the impact, the largest of the record: there the
nonlinear stiffness terms are strongest against the noise. Measured on
``benchmarks/bench_vs_sindy.py``'s held-out systems at 30 dB (seeds 1-4), least squares on
the measured acceleration over ``[gamma_0, gamma_N]`` only is 1.9x worse (median error) than
over the whole window; leaving that half cycle out was most of plain EDDI's loss to STLSQ
there.

Why full cycles: a rate integrated from a measured acceleration carries a slowly varying
error ``dv`` (what the drift removal leaves of the integrated noise). At successive
crossings ``v`` alternates in sign, so ``T = m (v + dv)^2 / 2`` is off by ``+m |v| dv``,
then ``-m |v| dv``: a half-cycle difference carries ``2 m |v| dv``, a full-cycle difference
(same sign of ``v`` at both ends) only ``m dv (|v_i-2| - |v_i|)``, the decay over one cycle
times the error. On ``benchmarks/bench_vs_sindy.py``'s nonlinear-damping system the
``x^2 v`` coefficient went from 43 % to 12 % off at 30 dB (6.7 % to 1.6 % at 45 dB). Records
with fewer than ``len(terms) + 2`` crossings keep half-cycle rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eddi.energy import cumulative_energy, kinetic_energy, rate_interpolant, term_matrix, zero_crossings
from eddi.errors import IdentificationError
from eddi.terms import Term

WEIGHTINGS = ("relative", "paper")
#: Crossings spanned by one row of the ``"relative"`` weighting (2: a full cycle, see the notes).
LAG = 2


@dataclass(frozen=True)
class PhaseOneResult:
    """What phase one found and the energies it measured.

    Attributes
    ----------
    terms : tuple of str
        Damping terms, in the order of ``coefficients``.
    coefficients : ndarray, shape (m,)
        Identified ``b_j`` (SI units of each term).
    gamma : ndarray, shape (N+1,), [s]
        Zero-crossing times used, ``gamma_0`` first.
    kinetic_at_gamma : ndarray, shape (N+1,), [J]
        ``T(gamma_i)``, equal to the mechanical energy at each crossing.
    q_matrix : ndarray, shape (N, m), [J per unit coefficient]
        ``Q_ij = integral_{gamma_0}^{gamma_i} v B_j dt`` (paper Eq. 10).
    r_vector : ndarray, shape (N,), [J]
        ``R_i = T(gamma_0) - T(gamma_i)``: measured dissipated energy at the crossings.
    dissipated_model_at_gamma : ndarray, shape (N,), [J]
        ``Q b``: modelled dissipated energy at the crossings.
    t : ndarray, shape (k,), [s]
        Every sample time of the response given (before ``gamma_0`` and after ``gamma_N``
        too; see the module notes).
    dissipated : ndarray, shape (k,), [J]
        Modelled dissipated energy ``D(t)`` from ``gamma_0`` (paper Eq. 12; negative
        before ``gamma_0``).
    mechanical : ndarray, shape (k,), [J]
        ``E(t) = T(gamma_0) - D(t)`` (paper Eq. 12).
    mechanical_anchored : ndarray, shape (k,), [J]
        ``E(t)`` re-anchored on the measured ``T(gamma_i)`` at every crossing (see
        :func:`_anchored_energy`; before ``gamma_0`` carried back from ``T(gamma_0)``,
        after ``gamma_N`` forward from ``T(gamma_N)``); what phase two uses by default.
    kinetic : ndarray, shape (k,), [J]
        ``T(t)`` at the same samples.
    sample_slice : tuple of int
        ``[start, stop)`` indices, in the caller's arrays, of ``t``.
    weighting : str
        ``"relative"`` or ``"paper"``.
    residual : float
        RMS of ``(Q b - R) / T(gamma_0)``: misfit of the energy balance, relative.
    condition_number : float
        Condition number of the column-scaled, weighted system.
    """

    terms: tuple[str, ...]
    coefficients: np.ndarray
    gamma: np.ndarray
    kinetic_at_gamma: np.ndarray
    q_matrix: np.ndarray
    r_vector: np.ndarray
    dissipated_model_at_gamma: np.ndarray
    t: np.ndarray
    dissipated: np.ndarray
    mechanical: np.ndarray
    kinetic: np.ndarray
    sample_slice: tuple[int, int]
    weighting: str
    residual: float
    condition_number: float
    mechanical_anchored: np.ndarray

    def as_dict(self) -> dict[str, float]:
        """Coefficients by term."""
        return {name: float(c) for name, c in zip(self.terms, self.coefficients)}


def scaled_lstsq(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
    """Least squares with unit-norm columns (better conditioning), rescaled back.

    Parameters
    ----------
    a : ndarray, shape (n, m)
    b : ndarray, shape (n,)

    Returns
    -------
    coef : ndarray, shape (m,)
    cond : float
        Condition number of the scaled matrix.
    """
    norms = np.linalg.norm(a, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    a_s = a / norms
    sol, _res, _rank, sv = np.linalg.lstsq(a_s, b, rcond=None)  # sv: singular values of a_s
    cond = float(sv[0] / sv[-1]) if sv.size and sv[-1] > 0 else float("inf")
    return sol / norms, cond


def phase_one(
    t: np.ndarray,
    x: np.ndarray,
    v: np.ndarray,
    mass: float,
    terms: tuple[Term, ...],
    *,
    a: np.ndarray | None = None,
    weighting: str = "relative",
    offset: int = 0,
    noise_x: float = 0.0,
    noise_v: float = 0.0,
    relative_accuracy: float = 1e-6,
) -> PhaseOneResult:
    """Identify the damping coefficients from the energy lost between zero crossings.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Increasing sample times of a free response.
    x : ndarray, shape (n,)
        Coordinate, measured from static equilibrium.
    v : ndarray, shape (n,)
        Its rate.
    mass : float
        Mass or inertia (> 0).
    terms : tuple of Term
        Damping candidates ``B_j(x, v)``.
    a : ndarray, shape (n,), optional
        Acceleration, used only to interpolate ``v`` at the crossings more accurately.
    weighting : {"relative", "paper"}
        Row weighting (see the module notes).
    offset : int
        Index of ``t[0]`` in the caller's arrays (reported in ``sample_slice``).
    noise_x, noise_v : float
        Standard deviation of the noise on ``x`` and ``v`` (0 for clean signals). ``noise_x``
        sets the zero-crossing dead band (4 sigma); ``noise_v`` enters the row weights of
        the ``"relative"`` weighting: each full-cycle row is divided by
        ``sqrt((relative_accuracy * T(gamma_i-2))^2 + var)`` where ``var`` is the variance
        of ``T(gamma_i-2) - T(gamma_i)`` due to the noise on ``v``.
    relative_accuracy : float
        Relative accuracy of a half-cycle energy balance on clean data (quadrature).

    Returns
    -------
    PhaseOneResult

    Raises
    ------
    IdentificationError
        If there are fewer than ``len(terms) + 1`` zero crossings.
    """
    if weighting not in WEIGHTINGS:
        raise IdentificationError(f"weighting must be one of {', '.join(WEIGHTINGS)}, got {weighting!r}")
    m = len(terms)
    gamma = zero_crossings(t, x, v, hysteresis=4.0 * noise_x)
    need = m + 1
    if gamma.size < need:
        raise IdentificationError(
            f"found {gamma.size} zero crossing{'s' if gamma.size != 1 else ''} of x; need at least "
            f"{need} (one more than the {m} damping terms) to identify damping"
        )
    v_at = rate_interpolant(t, v, a)
    t_gamma = kinetic_energy(mass, v_at(gamma))
    power = v[:, None] * term_matrix(terms, x, v)
    antider = cumulative_energy(t, power)
    a_gamma = antider(gamma)  # (N+1, m)
    q = a_gamma[1:] - a_gamma[0]
    r = t_gamma[0] - t_gamma[1:]
    if weighting == "paper":
        coef, cond = scaled_lstsq(q, r)
    else:
        lag = LAG if gamma.size >= m + LAG else 1
        dq = a_gamma[lag:] - a_gamma[:-lag]
        dr = t_gamma[:-lag] - t_gamma[lag:]
        vg = np.sqrt(2.0 * t_gamma / mass)
        var = (mass * noise_v) ** 2 * (vg[:-lag] ** 2 + vg[lag:] ** 2) + 0.5 * (mass * noise_v**2) ** 2
        w = 1.0 / np.maximum(np.sqrt((relative_accuracy * t_gamma[:-lag]) ** 2 + var), 1e-300)
        coef, cond = scaled_lstsq(dq * w[:, None], dr * w)
    d_model_gamma = q @ coef
    # every sample of the response: before the first crossing (the largest half cycle) and
    # after the last one the energy is carried from the nearest crossing (see the notes)
    i0, i1 = 0, t.size
    ts = t[i0:i1]
    a_ts = antider(ts)
    dissipated = (a_ts - a_gamma[0]) @ coef
    mechanical = t_gamma[0] - dissipated
    anchored = _anchored_energy(ts, gamma, t_gamma, a_ts @ coef, a_gamma @ coef)
    scale = t_gamma[0] if t_gamma[0] > 0 else 1.0
    residual = float(np.sqrt(np.mean((d_model_gamma - r) ** 2)) / scale)
    return PhaseOneResult(
        terms=tuple(tm.text for tm in terms),
        coefficients=coef,
        gamma=gamma,
        kinetic_at_gamma=t_gamma,
        q_matrix=q,
        r_vector=r,
        dissipated_model_at_gamma=d_model_gamma,
        t=ts,
        dissipated=dissipated,
        mechanical=mechanical,
        kinetic=kinetic_energy(mass, v[i0:i1]),
        sample_slice=(offset + i0, offset + i1),
        weighting=weighting,
        residual=residual,
        condition_number=cond,
        mechanical_anchored=anchored,
    )


def _anchored_energy(ts: np.ndarray, gamma: np.ndarray, t_gamma: np.ndarray,
                     d_ts: np.ndarray, d_gamma: np.ndarray) -> np.ndarray:
    """Mechanical energy re-anchored on the measured ``T(gamma_i)`` at every crossing.

    Between crossings ``gamma_i <= t <= gamma_i+1`` the energy is carried forward from
    ``T(gamma_i)`` and backward from ``T(gamma_i+1)`` with the modelled dissipation, and
    the two estimates are blended linearly in time. A small error of the damping model then
    affects ``E`` by at most the error over one half cycle, instead of accumulating from
    ``gamma_0`` (the paper's Eq. 12), which matters where the energy has decayed a lot.
    Before ``gamma_0`` only the forward estimate from ``T(gamma_0)`` exists (carried back),
    after ``gamma_N`` only the backward one from ``T(gamma_N)``.

    Parameters
    ----------
    ts : ndarray, shape (k,), [s]
        Sample times within ``[gamma_0, gamma_N]``.
    gamma : ndarray, shape (N+1,), [s]
    t_gamma : ndarray, shape (N+1,), [J]
        ``T(gamma_i)``.
    d_ts, d_gamma : ndarray, [J]
        Modelled dissipation antiderivative (any common origin) at ``ts`` and ``gamma``.

    Returns
    -------
    ndarray, shape (k,), [J]
    """
    i = np.clip(np.searchsorted(gamma, ts, side="right") - 1, 0, gamma.size - 2)
    forward = t_gamma[i] - (d_ts - d_gamma[i])
    backward = t_gamma[i + 1] + (d_gamma[i + 1] - d_ts)
    lam = np.clip((ts - gamma[i]) / (gamma[i + 1] - gamma[i]), 0.0, 1.0)
    return (1.0 - lam) * forward + lam * backward
