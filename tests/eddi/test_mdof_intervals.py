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

