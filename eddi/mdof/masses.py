"""Masses and input shares of an identified multi-DOF model, with no mass given.

Over the impact, ``q_i'' + B_i + K_i = g_i F`` gives the force per unit mass ``g_i``
(:func:`eddi.mdof.identify.fit_equation`). Modal coordinates: the force enters equation ``i``
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
    from eddi.mdof.identify import EquationFit


def masses_and_inputs(kind: str, fits: tuple[EquationFit, ...], tmat: np.ndarray, d: int, n: int,
                      amplitude: np.ndarray | None = None) -> tuple[list[float], list[float], list[str]]:
    """Masses [kg] and input shares of every coordinate, and notes (see the module docstring).

    ``kind`` is ``"modal"`` or ``"physical"``; ``tmat`` the shapes (channels x coordinates);
    ``d`` the driving-point channel; ``amplitude`` the RMS of each coordinate over the records
    [m] (weights of :func:`reciprocity`).
    """
    notes: list[str] = []
    gains = np.array([f.input_gain for f in fits])
    if not np.any(np.abs(gains) > 0):
        notes.append("no force: every coordinate identified per unit mass (mass 1)")
        return [1.0] * n, [0.0] * n, notes
    if kind == "modal":
        masses, inputs = [], []
        for i in range(n):
            u = float(tmat[d, i])
            g = gains[i]
            if abs(u) < 1e-6 or g == 0 or u / g <= 0:
                notes.append(f"mode {i + 1}: no driving-point residue (node at the driving point?); "
                             "identified per unit mass")
                masses.append(1.0)
                inputs.append(float(g))
            else:
                masses.append(u / g)
                inputs.append(u)
        return masses, inputs, notes
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
