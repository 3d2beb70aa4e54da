"""eddi.refine_grid.through_sampling_pass: a Jacobian through the block-mean model in one compiled
pass, the same floats as eddi.intervals.through_sampling's numpy passes (session 17)."""

from __future__ import annotations

import numpy as np
import pytest

import eddi.intervals as intervals


_numpy_passes = intervals.through_sampling_numpy  # the reference: numpy's passes


def _cases():
    rng = np.random.default_rng(17)
    for i in range(120):
        n, k = int(rng.integers(1, 2500)), int(rng.integers(1, 15))
        y = (rng.standard_normal((n, k)) * 10 ** rng.uniform(-10, 10) if i % 2 else
             np.outer(np.sin(np.arange(n) * rng.uniform(0.01, 0.5)), rng.uniform(-3, 3, k)) * 10 ** rng.uniform(-6, 3))
        if i % 5 == 0:
            y.flat[int(rng.integers(0, y.size))] = (np.inf, np.nan, -0.0)[i % 3]
        c = rng.uniform(0.01, 0.1) if i % 3 else 0.0
        q = -rng.uniform(1e-4, 1e-2) if i % 4 else 0.0
        yield y, c, q


@pytest.mark.parametrize("case", range(120))
def test_the_same_floats_as_numpys_passes(case: int) -> None:
    y, c, q = list(_cases())[case]
    got, want = intervals.through_sampling(y, c, q), _numpy_passes(y, c, q)
    assert got.shape == want.shape
    assert np.array_equal(got, want, equal_nan=True) and np.array_equal(np.signbit(got), np.signbit(want))


def test_a_jacobian_takes_the_compiled_pass_and_a_vector_numpys(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(3)
    jac, vec = rng.standard_normal((9400, 14)), rng.standard_normal(9400)
    want_j, want_v = _numpy_passes(jac, 0.0416, -0.0014), _numpy_passes(vec, 0.0416, -0.0014)

    def no_copy(*a, **k):
        raise AssertionError("numpy's passes over the Jacobian")

    monkeypatch.setattr(intervals.np, "array", no_copy)
    assert np.array_equal(intervals.through_sampling(jac, 0.0416, -0.0014), want_j)
    monkeypatch.undo()
    assert np.array_equal(intervals.through_sampling(vec, 0.0416, -0.0014), want_v)
    strided = np.asfortranarray(jac)  # not C order: numpy's passes, the same floats
    assert np.array_equal(intervals.through_sampling(strided, 0.0416, -0.0014), want_j)
