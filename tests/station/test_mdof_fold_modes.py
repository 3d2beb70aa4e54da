"""Held-out per-mode errors when the folds' models keep different numbers of coordinates (session 12)."""

from __future__ import annotations

import pytest

from station.mdof_commands import fold_mean_per_mode


def test_folds_with_different_coordinate_counts_average_each_coordinate_over_the_folds_that_have_it():
    # a fold whose tail resolved one mode fewer: np.mean over the ragged rows raised ValueError
    # (a traceback instead of a verdict, on a 3-mass chain with 2 blows and a 2-mass one with 6)
    got = fold_mean_per_mode([[0.01, 0.03], [0.02], [0.03, 0.05]])
    assert got == pytest.approx([0.02, 0.04])
    assert fold_mean_per_mode([]) == []
