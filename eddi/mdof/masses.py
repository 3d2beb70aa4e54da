"""Masses and input shares of an identified multi-DOF model, with no mass given.

Over the impact, ``q_i'' + B_i + K_i = g_i F`` gives the force per unit mass ``g_i``
(:func:`eddi.mdof.equations.fit_equation`). Modal coordinates: the force enters equation ``i``
as ``psi_di F`` (``d`` the driving point), so the modal mass is ``m_i = psi_di / g_i`` (the
driving-point residue route). Physical coordinates: the driven mass is ``1 / g_d``; every
other mass follows from the reciprocity of the coupling springs (a potential term
``theta x_i^a x_j^b`` appears as ``a theta / m_i`` in equation ``i`` and ``b theta / m_j`` in
equation ``j``).
"""

from __future__ import annotations

import itertools
import math
from typing import TYPE_CHECKING

import numpy as np

from eddi.mdof.terms import monomial, parse_multi_term

if TYPE_CHECKING:
    from eddi.mdof.equations import EquationFit


def masses_and_inputs(kind: str, fits: tuple[EquationFit, ...], tmat: np.ndarray, d: int, n: int,
                      amplitude: np.ndarray | None = None, residue: np.ndarray | None = None
                      ) -> tuple[list[float], list[float], list[str]]:
    """Masses [kg] and input shares of every coordinate, and notes (see the module docstring).

    ``kind`` is ``"modal"`` or ``"physical"``; ``tmat`` the shapes (channels x coordinates);
    ``d`` the driving-point channel; ``amplitude`` the RMS of each coordinate over the records
    [m] (weights of :func:`reciprocity`); ``residue`` (modal only) each coordinate's modal mass
    from the driving-point residue (:func:`eddi.mdof.early.residue_masses`, NaN where there is
    none), used in place of ``psi_di / g_i`` where it is finite (:func:`_modal`).
    """
    notes: list[str] = []
    gains = np.array([f.input_gain for f in fits])
    if not np.any(np.abs(gains) > 0):
        notes.append("no force: every coordinate identified per unit mass (mass 1)")
        return [1.0] * n, [0.0] * n, notes
    if kind == "modal":
        return _modal(gains, tmat, d, n, residue, notes)
    masses = [math.nan] * n
    masses[d] = 1.0 / gains[d] if gains[d] > 0 else 1.0
    for _ in range(n):  # spread from the known masses, through the strongest coupling first
        best = None
        for i, j in itertools.permutations(range(n), 2):
            if math.isnan(masses[i]) or not math.isnan(masses[j]):
                continue
            got = reciprocity(fits[i], fits[j], i, j, n, amplitude)
            if got is not None and (best is None or got[1] > best[2]):
                best = (i, j, got[1], got[0])
        if best is None:
            break
        i, j, _w, ratio = best
        masses[j] = masses[i] * ratio
    for j in range(n):
        if math.isnan(masses[j]):
            notes.append(f"coordinate {j + 1}: no coupling to a driven mass; identified per unit mass")
            masses[j] = 1.0
    return masses, [1.0 if i == d else 0.0 for i in range(n)], notes


def _modal(gains: np.ndarray, tmat: np.ndarray, d: int, n: int, residue: np.ndarray | None, notes: list[str]
           ) -> tuple[list[float], list[float], list[str]]:
    """Modal masses: from the driving-point residue where it is given, else ``psi_di / g_i``.

    ``residue`` is NaN where the records' residues disagree (a nonlinear mode, see
    :data:`eddi.mdof.coordinates.RESIDUE_SPREAD_MAX`): there the impact fit's gain, fitted in the
    same coordinates as the model's equations, predicts better (measured on the rig's
    two-mass-cubic: training nrmse of the modal candidate 0.057 with it, 0.28 with the residue's).

    Both routes give the force per unit modal mass at the driving point; the residue is fitted on
    the first periods after the pulse with the poles refitted there (:mod:`eddi.mdof.early`), the
    impact gain ``g_i`` over the pulse on the coordinate ``q = pinv(Psi) y``, where a little of the
    other modes' pulse response leaks in through the shapes' errors. Measured (session 8, own
    two-mass pairs, ``coordinates="modal"``): both within 1 % of the true modal masses when the
    modes are far apart; on a 1:3 pair struck at the light mass the impact route gave 0.98 / 0.81
    kg for a 1.02 kg mode (the residue 1.02), and with coupling terms on a 1:3 pair at 4096 Hz
    0.33 kg for a 0.82 kg mode (the residue 0.817). Where a tail's shape is partly a cubic tone
    (``3 f_1`` on a 1:3 pair) both masses follow that shape; the residue keeps the driving
    point's residue ``psi_d^2 / m`` right (measured 0.362 vs true 0.366).
    """
    masses, inputs = [], []
    for i in range(n):
        u = float(tmat[d, i])
        g = gains[i]
        m_res = float(residue[i]) if residue is not None else math.nan
        if abs(u) >= 1e-6 and math.isfinite(m_res) and m_res > 0:
            if g != 0 and u / g > 0 and abs(u / g / m_res - 1.0) > 0.1:
                notes.append(f"mode {i + 1}: modal mass {m_res:.4g} kg from the driving-point residue "
                             f"(the impact fit's {u / g:.4g} kg differs by more than 10 %)")
            masses.append(m_res)
            inputs.append(u)
        elif abs(u) < 1e-6 or g == 0 or u / g <= 0:
            notes.append(f"mode {i + 1}: no driving-point residue (node at the driving point?); "
                         "identified per unit mass")
            masses.append(1.0)
            inputs.append(float(g))
        else:
            masses.append(u / g)
            inputs.append(u)
    return masses, inputs, notes


def reciprocity(fi: EquationFit, fj: EquationFit, i: int, j: int, n: int,
                amplitude: np.ndarray | None = None) -> tuple[float, float] | None:
    """``(m_j / m_i, weight)`` from potential terms shared by equations ``i`` and ``j``, or None.

    ``weight`` (the weighted sum of squares of equation ``j``'s shared terms) says how strongly
    the two coordinates are coupled: the masses are spread through the strongest coupling
    first, not through a spurious small term.

    Each shared potential monomial ``P`` gives one estimate; they are combined by least
    squares weighted by the size of ``P`` at the records' amplitudes (``amplitude``, RMS of
    each coordinate [m]): coefficients of different degrees have different units (N/m,
    N/m^3), and unweighted the cubic ones (large numbers) would outweigh a linear spring, or
    a spurious small linear term a cubic spring.
    """
    amp = np.ones(n) if amplitude is None else np.asarray(amplitude, float)
    num = den = 0.0
    for text_i, ci in fi.stiffness.items():
        e = parse_multi_term(text_i, n).exponents[0].copy()  # powers of x in d P / d x_i
        e[i] += 1  # the potential monomial P
        a, b_ = int(e[i]), int(e[j])
        if b_ == 0 or int(e.sum()) != int(e[i] + e[j]):
            continue
        ej = e.copy()
        ej[j] -= 1
        text_j = monomial({k: int(p) for k, p in enumerate(ej) if p}, n)
        cj = fj.stiffness.get(text_j)
        if cj is None:
            continue
        # theta = m_i ci / a = m_j cj / b  ->  m_j / m_i = b ci / (a cj)
        size = float(np.prod(amp ** e))  # P at the records' amplitudes [m^degree]
        num += (b_ * ci / a) * cj * size * size
        den += (cj * size) ** 2
    return (num / den, den) if den > 0 and num / den > 0 else None
