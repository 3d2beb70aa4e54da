"""Session 16 (s16ident): two bit-for-bit savings of the validation's and the refinement's set-up.

* :func:`eddi.simulate._free_runner` runs :func:`eddi.simulate._dense_tail`'s force-free segments
  on the simulator's kernel with the term tables made once (no :func:`eddi.simulate.simulate`
  call, checks and column copies per segment): the same numbers as ``simulate`` bit for bit.
* :func:`eddi.simulate.local_angular_frequencies` evaluates several ranges at once (the
  refinement's 12 amplitude levels, :func:`eddi.refine_grid.local_substeps`): the same numbers as
  one :func:`eddi.simulate.local_angular_frequency` per range bit for bit, including ranges
  without extent (the bound) and models with effects.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddi.model import EquationOfMotion
from eddi.simulate import _free_runner, local_angular_frequencies, local_angular_frequency, simulate

from tests.eddi.test_local_frequency import _models, _reference


def _duffing(seed: int) -> EquationOfMotion:
    rng = np.random.default_rng(seed)
    m = float(10 ** rng.uniform(-1, 1))
    k1 = m * (2 * math.pi * rng.uniform(2, 30)) ** 2
    return EquationOfMotion(mass=m, damping={"v": 0.02 * math.sqrt(k1 * m), "x^2*v": float(rng.uniform(0, 10))},
                            stiffness={"x": k1, "x^2": k1 * float(rng.uniform(-10, 10)),
                                       "x^3": k1 * float(rng.uniform(0, 1e4))})


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_free_runner_is_simulate_bit_for_bit(seed):
    eom = _duffing(seed)
    run = _free_runner(eom)
    for m, q, steps in ((5, 7, 1), (300, 20, 3), (4000, 37, 2)):
        dt = 1.0 / 19200.0
        idx = np.arange(100, 100 + m * q, q)
        want = simulate(eom, (idx - idx[0]) * dt, x0=1e-3, v0=-0.05, substeps=steps)
        got = run(idx.size, float((idx[1] - idx[0]) * dt), 1e-3, -0.05, steps)
        for k in "xva":
            assert np.array_equal(getattr(got, k), getattr(want, k)), k
        assert got.diverged == want.diverged


def test_free_runner_reports_divergence_as_simulate():
    eom = EquationOfMotion(mass=1.0, damping={"v": -50.0}, stiffness={"x": 1e4, "x^3": 1e12})
    want = simulate(eom, np.arange(2000) * 1e-3, x0=0.1, v0=10.0, substeps=1)
    got = _free_runner(eom)(2000, 1e-3, 0.1, 10.0, 1)
    assert want.diverged and got.diverged
    assert np.array_equal(got.x, want.x, equal_nan=True)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_frequencies_of_many_ranges_bit_for_bit(seed):
    for eom, xa, va in _models(seed, 40):
        levels = xa * np.geomspace(1e-3, 1.0, 12)
        vlev = levels * (va / xa)
        got = local_angular_frequencies(eom, levels, vlev)
        assert got.shape == (12,)
        for g, a, b in zip(got, levels, vlev):
            want = _reference(eom, float(a), float(b))
            assert g == want or (math.isnan(g) and math.isnan(want)), (eom, a, b, g, want)
            assert g == local_angular_frequency(eom, a, b) or math.isnan(g)
        # a range without extent takes the bound, the others the grid
        mixed = local_angular_frequencies(eom, [xa, 0.0, xa], [va, va, 0.0])
        want = _reference(eom, xa, va)
        assert mixed[0] == want or (math.isnan(mixed[0]) and math.isnan(want))
        assert mixed[1] == local_angular_frequency(eom, 0.0, va)
        assert mixed[2] == local_angular_frequency(eom, xa, 0.0)


def test_frequencies_with_effects_take_the_bound():
    eom = EquationOfMotion(mass=1.0, damping={"v": 1.0}, stiffness={"x": 1e4},
                           effects=[{"name": "clearance", "params": {"gap_m": 1e-3, "stiffness_n_per_m": 4e4}}])
    got = local_angular_frequencies(eom, [1e-3, 2e-3], [0.1, 0.2])
    assert list(got) == [local_angular_frequency(eom, 1e-3, 0.1), local_angular_frequency(eom, 2e-3, 0.2)]
    assert got[0] == math.sqrt(5e4)
