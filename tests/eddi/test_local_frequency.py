"""`eddi.simulate.local_angular_frequency`'s lean force evaluation: the same numbers bit for bit.

The function runs ~30 times per identification (the validation's segments, the refinement's
steps) and ~100 per diagnosis fit; session 14 replaced its call of
``EquationOfMotion.restoring_force`` by ``eddi.simulate._polynomial_force`` (no checks, no
broadcasting). These tests hold it to the general method, bit for bit, on random models of every
kind of polynomial term (powers, ``abs``, ``sign``, a term in both dicts), so the
step and grid choices of every simulation are unchanged.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddi.model import EquationOfMotion
from eddi.simulate import _polynomial_force, local_angular_frequency

TERMS_B = ("v", "x^2*v", "v^3", "abs(v)*v", "sign(v)", "x*v", "abs(x)*v", "v^5")
TERMS_K = ("x", "x^2", "x^3", "x^4", "x^5", "abs(x)*x", "x^7", "sign(x)", "x^2*abs(x)")


def _reference(eom: EquationOfMotion, x_amp: float, v_amp: float) -> float:
    """The function as it was before session 14 (restoring_force, np.tile/np.repeat)."""
    xs = np.linspace(-x_amp, x_amp, 257)
    vs = np.linspace(-v_amp, v_amp, 257)
    at = (0.0, x_amp, -x_amp)
    xx = np.concatenate((np.tile(xs, 3), np.repeat(at, xs.size)))
    vv = np.concatenate((np.repeat([xv * v_amp / x_amp for xv in at], xs.size), np.tile(vs, 3)))
    f = eom.restoring_force(xx, vv).reshape(6, xs.size)
    k_tan = float(np.max(np.abs(np.gradient(f[:3], xs, axis=1))))
    c_tan = float(np.max(np.abs(np.gradient(f[3:], vs, axis=1))))
    return max(math.sqrt(k_tan / eom.mass), c_tan / eom.mass)


def _models(seed: int, count: int):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        nb, nk = rng.integers(0, 4), rng.integers(1, 5)
        damping = {t: float(rng.normal() * 10.0 ** rng.uniform(-3, 3)) for t in rng.choice(TERMS_B, nb, replace=False)}
        stiffness = {t: float(rng.normal() * 10.0 ** rng.uniform(0, 9)) for t in rng.choice(TERMS_K, nk, replace=False)}
        yield EquationOfMotion(mass=float(10.0 ** rng.uniform(-2, 2)), damping=damping, stiffness=stiffness), \
            float(10.0 ** rng.uniform(-5, 0)), float(10.0 ** rng.uniform(-3, 2))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_same_frequency_bit_for_bit(seed):
    for eom, xa, va in _models(seed, 60):
        got, want = local_angular_frequency(eom, xa, va), _reference(eom, xa, va)
        assert got == want or (math.isnan(got) and math.isnan(want)), (eom, xa, va, got, want)


def test_same_force_bit_for_bit_and_inputs_untouched():
    rng = np.random.default_rng(7)
    x, v = rng.normal(size=1542) * 1e-3, rng.normal(size=1542)
    x[5], v[9] = 0.0, -0.0  # signed zeros: the sum's first term plus 0.0, as restoring_force
    x0, v0 = x.copy(), v.copy()
    for eom, _, _ in _models(11, 80):
        got = _polynomial_force(eom, x, v)
        want = eom.restoring_force(x, v)
        assert got.tobytes() == want.tobytes(), eom
        assert x.tobytes() == x0.tobytes() and v.tobytes() == v0.tobytes()  # x**1 is never x itself


def test_a_term_in_both_dicts():
    eom = EquationOfMotion(mass=2.0, damping={"x": 3.0, "v": 0.5}, stiffness={"x": 7.0, "x^3": 0.25})
    x, v = np.linspace(-1, 1, 11), np.linspace(2, -2, 11)
    assert _polynomial_force(eom, x, v).tobytes() == eom.restoring_force(x, v).tobytes()
    assert local_angular_frequency(eom, 0.3, 4.0) == _reference(eom, 0.3, 4.0)
