"""Lumped masses expected from the modal masses of the driving-point residues.

With a force channel every mode's modal mass follows from its driving-point residue
(:func:`eddi.mdof.early.residue_masses`: ``m_r`` for the shape ``phi_r`` as ERA gives it). For masses
on the channels (a lumped chain, a diagonal mass matrix ``M = diag(mu)``) the shapes are
``M``-orthogonal and ``phi_r^T M phi_r = m_r``, so ``M = Phi^-T diag(m) Phi^-1`` (``Phi`` square:
as many modes as channels), and per mass

    sum_i mu_i phi_ir^2 = m_r                   (every mode r)
    sum_i mu_i phi_ir phi_is = 0                (every pair r < s)

a linear least squares in ``mu`` (the second set fixes the ratios from the shapes alone, the first
the scale from the residues). The lumped fit (:mod:`eddi.mdof.lumped`) is homogeneous in the free
window and, on three-mass chains, nearly collinear where a mass hardly moves: its masses then
follow the noise (session 15: relative masses 0.044 / 0.161 / 0.134 for 1 / 0.5 / 2 kg, the
candidate refused). The expectation here does not use the equations of motion at all, so it
starts that fit physical and regularises it (:func:`eddi.mdof.physical.identify_lumped`).

No I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: A mode's modal mass counts with relative standard deviation ``max(spread / SPREAD_TO_STD,
#: MIN_MODE_STD)`` (the spread is ``(max - min) / median`` over the records: about 1.7 standard
#: deviations for three records); an orthogonality row with ``MIN_MODE_STD`` of ``sqrt(m_r m_s)``.
SPREAD_TO_STD = 1.7
MIN_MODE_STD = 0.05
#: The expectation's relative standard deviation is never below this (the shapes' own error, the
#: residue fit's bias on a nonlinear mode): measured on the session 13/15 chain at 35 / 50 dB,
#: the per-mass estimates 3-18 % off.
MIN_MASS_STD = 0.1


@dataclass(frozen=True)
class MassPrior:
    """Masses expected on the channels [kg], their relative standard deviations, and how the
    matrix ``Phi^-T diag(m) Phi^-1`` departs from a diagonal one (largest ``|M_ij| / sqrt(M_ii M_jj)``)."""

    masses: np.ndarray
    rel_std: np.ndarray
    off_diagonal: float

    def note(self) -> str:
        return ("masses expected from the driving-point residues " + " / ".join(f"{m:.3g}" for m in self.masses)
                + f" kg (+-{100 * float(np.max(self.rel_std)):.0f} %, off-diagonal {self.off_diagonal:.2f})")


def mass_prior(shapes: np.ndarray, modal_masses: np.ndarray, spread: np.ndarray | None = None) -> MassPrior | None:
    """The expected masses (module docstring) from ERA's shapes (channels x modes) and the residues'
    modal masses; None unless there are as many modes as channels, every modal mass is finite and
    positive and the solution is positive."""
    phi = np.asarray(shapes, float)
    m = np.asarray(modal_masses, float)
    n, r = phi.shape if phi.ndim == 2 else (0, 0)
    if n < 2 or r != n or m.size != r or not np.all(np.isfinite(m)) or not np.all(m > 0):
        return None
    sp = np.zeros(r) if spread is None or np.size(spread) != r else np.nan_to_num(np.asarray(spread, float), nan=1.0)
    std = np.maximum(sp / SPREAD_TO_STD, MIN_MODE_STD)
    rows, rhs = [], []
    for k in range(r):
        rows.append(phi[:, k] ** 2 / (m[k] * std[k]))
        rhs.append(1.0 / std[k])
    for k in range(r):
        for j in range(k + 1, r):
            rows.append(phi[:, k] * phi[:, j] / (math.sqrt(m[k] * m[j]) * MIN_MODE_STD))
            rhs.append(0.0)
    a, y = np.array(rows), np.array(rhs)
    mu = np.linalg.lstsq(a, y, rcond=None)[0]
    if not np.all(mu > 0):
        return None
    # rows in units of their standard deviation: the covariance, inflated by the rows' disagreement
    dof = max(a.shape[0] - n, 1)
    chi2 = float(np.sum((a @ mu - y) ** 2)) / dof
    cov = np.linalg.pinv(a.T @ a) * max(chi2, 1.0)
    spread_rel = np.sqrt(np.maximum(np.diag(cov), 0.0)) / mu
    try:
        inv = np.linalg.inv(phi)
    except np.linalg.LinAlgError:
        return None
    full = inv.T @ np.diag(m) @ inv
    diag = np.abs(np.diag(full))
    off = float(np.max(np.abs(full - np.diag(np.diag(full))) / np.sqrt(np.outer(diag, diag)), initial=0.0))
    # the two estimates of each mass (the least squares, the diagonal of the full matrix) differ by
    # the shapes' error: their disagreement is part of the expectation's uncertainty
    rel = np.maximum.reduce([np.abs(np.diag(full) - mu) / mu, spread_rel, np.full(n, MIN_MASS_STD)])
    return MassPrior(mu, np.maximum(rel, off), off)


def records_prior(records, modes) -> MassPrior | None:
    """:func:`mass_prior` of the records' linear modes (``LinearModes``), None without a force on every record."""
    if not records or any(r.force is None for r in records):
        return None
    return mass_prior(modes.shapes, modes.modal_masses, modes.modal_mass_spread)


#: A regularising row's weight per row of its equation is at least this (a fit that closes its
#: equations to rounding would otherwise ignore the expectation altogether; 1e-3 of the inertia RMS
#: is below any residual the measured records leave).
MIN_RESIDUAL = 1e-3


def prior_weights(prior: MassPrior, plain, d: int) -> tuple[np.ndarray, np.ndarray]:
    """``(ratios, weights)`` for :func:`eddi.mdof.lumped.fit_lumped`'s ``mass_prior``: the expected
    masses per unit driven mass, each weighted so that a mass one standard deviation of the
    expectation off costs as much as the force-balance residual the unregularised fit ``plain``
    (a ``LumpedFit`` on the same rows) leaves on every row of that mass's equation. The data
    then decide where they determine a mass better than that, and the expectation where they do
    not (collinear columns: a mass that hardly moves, a ground spring standing in for a link)."""
    ratios = prior.masses / prior.masses[d]
    resid = np.maximum(np.nan_to_num(np.asarray(plain.residual, float), nan=1.0), MIN_RESIDUAL)
    return ratios, resid / (prior.rel_std * ratios)


def refusal_note(refused: list[str], prior: MassPrior | None) -> str:
    """Why the lumped candidate was refused (every variant had a non-positive mass), with the numbers."""
    expect = (f"; {prior.note()}" if prior is not None
              else "; no masses expected from the residues (a mode's residue mass missing, or fewer modes than channels)")
    return ("lumped candidate refused: every variant has a non-positive mass (rows from " + "; ".join(refused)
            + " after the blow)" + expect)
