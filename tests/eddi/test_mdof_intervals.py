"""95 % intervals of multi-DOF stiffness coefficients, and the drop of terms the data do not determine."""

from __future__ import annotations

import numpy as np

from eddi.mdof.intervals import block_jackknife_ci95
from eddi.phase_one import scaled_lstsq


def _ring_down(rng: np.random.Generator, n: int = 6000) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Two decaying coordinates, a force with a strong cubic term and a coupling term of true value 0,
    plus slow (correlated) noise as double integration leaves it."""
    t = np.arange(n) / 2048.0
    x1 = np.exp(-0.8 * t) * np.sin(2 * np.pi * 23 * t)
    x2 = 0.3 * np.exp(-0.5 * t) * np.sin(2 * np.pi * 49 * t + 0.4)
    cols = np.column_stack([x1, x1**3, x1 * x2**2])
    slow = np.convolve(rng.standard_normal(n), np.ones(200) / 200, "same")
    y = cols @ np.array([4.0e4, 2.0e4, 0.0]) + 2e2 * slow + 2.0 * rng.standard_normal(n)
    blocks = np.minimum(np.arange(n) * 15 // n, 14)
    return cols, y, blocks


def test_jackknife_interval_covers_the_truth_and_holds_zero_for_an_absent_term():
    covered = held_zero = 0
    for seed in range(20):
        cols, y, blocks = _ring_down(np.random.default_rng(seed))
        coef = scaled_lstsq(cols, y)[0]
        half = block_jackknife_ci95(lambda rows: scaled_lstsq(cols[rows], y[rows])[0], blocks)
        covered += int(abs(coef[1] - 2.0e4) <= half[1])
        held_zero += int(half[2] > abs(coef[2]))  # the absent coupling: its interval holds zero
        assert half[0] < 0.01 * 4.0e4  # the strong linear term is well determined
    assert covered >= 16 and held_zero >= 16  # about 95 % each, with room for 20 draws



def test_masses_from_reciprocity_go_through_the_real_springs_not_a_spurious_term():
    """Three masses in a chain (ground-1-2-3, cubic spring 2-3), no mass given but the driven one.
    A small spurious 1-3 coupling (as noise leaves it) must not set mass 3, and the N/m^3
    coefficients (1e10) must not swamp the N/m ones (1e4)."""
    from eddi.mdof.identify import EquationFit
    from eddi.mdof.masses import masses_and_inputs
    from simulated_rig.mdof_systems import Element, MdofSystem

    true_m = (1.0, 0.7, 0.4)
    chain = MdofSystem(masses_kg=true_m, elements=(
        Element(between=(0, 1), k=5e4), Element(between=(1, 2), k=3e4),
        Element(between=(2, 3), k=2e4, k3=1e10)))
    model = chain.model()
    per_mass = [{t: c / m for t, c in model.stiffness[i].items()} for i, m in enumerate(true_m)]
    per_mass[0]["x3"] = -180.0  # spurious, 0.6 % of the real 1-2 spring
    per_mass[2]["x1"] = -350.0  # its partner: alone they would make mass 3 0.51 kg
    per_mass[2]["x1^3"] = 4e8   # spurious cubic, large as a number
    fits = tuple(EquationFit({}, st, 1.0 if i == 0 else 0.0, 0.0, 0.0, 0) for i, st in enumerate(per_mass))
    masses, inputs, notes = masses_and_inputs("physical", fits, np.eye(3), 0, 3, np.array([1e-3, 1.6e-3, 2.2e-3]))
    assert np.allclose(masses, true_m, rtol=0.01) and inputs == [1.0, 0.0, 0.0] and not notes


def test_the_qr_jackknife_equals_the_refits_it_replaces():
    # columns of very different scales (as x, x^3 and a force are), correlated noise, uneven blocks
    from eddi.mdof.intervals import block_jackknife_ci95, jackknife_lstsq_ci95
    from eddi.phase_one import scaled_lstsq

    rng = np.random.default_rng(7)
    n = 3000
    t = np.linspace(0.0, 3.0, n)
    x = np.exp(-0.5 * t) * np.sin(2 * np.pi * 7 * t)
    a = np.column_stack([x * 1e-3, (x * 1e-3) ** 3, np.cos(2 * np.pi * 7 * t), rng.standard_normal(n)])
    y = a @ np.array([4e4, 3e9, 0.5, 0.01]) + np.convolve(rng.standard_normal(n), np.ones(25) / 25, "same")
    blocks = np.minimum(np.arange(n) * 7 // n, 6)
    blocks[::11] = 3  # uneven, interleaved
    want = block_jackknife_ci95(lambda rows: scaled_lstsq(a[rows], y[rows])[0][1:3], blocks)
    got = jackknife_lstsq_ci95(a, y, blocks, slice(1, 3))
    assert got.shape == (2,) and np.all(got > 0)
    assert np.allclose(got, want, rtol=1e-7, atol=0)
    assert np.all(np.isinf(jackknife_lstsq_ci95(a, y, np.minimum(np.arange(n) * 2 // n, 1))))
