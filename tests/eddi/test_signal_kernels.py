"""Session 16 (s16ident): the conditioning's record-length passes compiled, bit for bit.

:func:`eddi.calculus.integrate` (the 4th-order cumulative integral, twice per acceleration
record) and :func:`eddi.conditioning.levels.crossings` (twice per record) ran as 6-8 numpy passes
over the 45 s, 19.2 kHz record each; one compiled pass each (``_integrate_sum``,
``_crossing_scan``: built ahead of time with the simulator's kernels) gives the same numbers bit
for bit: here against the numpy passes (a strided input still takes them); built ahead of time
against the JIT in tests/eddi/test_kernels.py.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.calculus import integrate
from eddi.conditioning.levels import crossings


def _signals(seed: int, count: int):
    rng = np.random.default_rng(seed)
    for case in range(count):
        n = int(rng.choice([4, 5, 6, 9, 300, 20000]))
        t = np.linspace(0.0, 1.0, n)
        y = np.exp(-2.0 * t) * np.sin(2 * np.pi * rng.uniform(1, 200) * t) + rng.normal(size=n) * 10 ** rng.uniform(-4, -1)
        if case % 4 == 0:
            y[rng.integers(0, n, size=max(1, n // 8))] = rng.choice([0.0, -0.0])
        yield rng, y * 10 ** rng.uniform(-5, 3)


def _strided(y: np.ndarray) -> np.ndarray:
    out = np.repeat(y, 2)[::2]
    assert not out.flags.c_contiguous and np.array_equal(out, y)
    return out


@pytest.mark.parametrize("seed", [1, 2])
def test_integrate_compiled_is_the_numpy_passes_bit_for_bit(seed):
    for rng, y in _signals(seed, 60):
        dt = float(10 ** rng.uniform(-5, -2))
        for smooth in (0, 1, 2, int(rng.integers(0, y.size + 3)), y.size + 5):
            got = integrate(y, dt, smooth_from=smooth)
            want = integrate(_strided(y), dt, smooth_from=smooth)  # the numpy passes
            assert np.array_equal(got, want), (y.size, smooth)
            out = np.full(y.size, np.nan)
            assert integrate(y, dt, smooth_from=smooth, out=out) is out and np.array_equal(out, want)


@pytest.mark.parametrize("seed", [3, 4])
def test_crossings_compiled_are_the_numpy_passes_bit_for_bit(seed):
    for rng, y in _signals(seed, 60):
        sd = float(np.std(y))
        for h in (0.0, 0.1 * sd, sd, 5.0 * sd):
            start = int(rng.integers(0, max(1, y.size // 3)))
            stop = int(rng.integers(start, y.size + 1))
            for kw in ({"start": start}, {"start": start, "stop": stop}):
                got = crossings(y, h, **kw)
                want = crossings(_strided(y), h, **kw)
                assert got.dtype == want.dtype == np.float64
                assert np.array_equal(got, want), (y.size, h, kw)


def test_the_ring_down_crossings_and_integral_are_exact():
    """A decaying sine: the crossings sit within 1e-3 sample of the true zeros, and the
    integral of the integral of the acceleration returns the motion (the 4th-order stencil)."""
    rate, f0 = 2000.0, 7.0
    t = np.arange(int(2 * rate)) / rate
    w = 2 * np.pi * f0
    x = np.sin(w * t)
    zeros = np.arange(1, 28) * rate / (2 * f0)
    got = crossings(x, 0.1)
    assert got.size == 27 and np.max(np.abs(got - zeros)) < 1e-3
    a = -w * w * np.sin(w * t)
    v = integrate(a, 1.0 / rate)
    xi = integrate(v + w, 1.0 / rate)  # v(0) = w
    assert np.max(np.abs(xi - x)) < 1e-6


def test_drift_spline_evaluation_compiled_is_the_numpy_loop_bit_for_bit():
    """The drift spline's Horner evaluation on every sample (kinematics._horner_fill, session 16)
    against the numpy loop (strided inputs take it), written and subtracted in place."""
    from scipy.interpolate import BSpline

    from eddi.conditioning import kinematics

    assert kinematics._KERNELS is not None
    rng = np.random.default_rng(11)
    for case in range(80):
        n = int(rng.integers(50, 20000))
        t = np.sort(rng.uniform(0, 10, n)) if case % 2 else np.arange(n) / 1000.0
        inner = np.linspace(t[0], t[-1], int(rng.integers(1, 12)) + 1)
        knots = np.concatenate(([t[0]] * 3, inner, [t[-1]] * 3))
        spl = BSpline(knots, rng.normal(size=knots.size - 4) * 10 ** rng.uniform(-6, 2), 3, extrapolate=False)
        start = int(rng.integers(0, n // 2))
        got = kinematics._drift_spline_eval(spl, t, start)
        want = kinematics._drift_spline_eval(spl, _strided(t), start)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
        assert not got[0][:start].any() and got[0][start:].any()
        x, v = rng.normal(size=n), rng.normal(size=n)
        xs, vs = _strided(x), _strided(v)
        kinematics._drift_spline_eval(spl, t, start, minus=(x, v))
        kinematics._drift_spline_eval(spl, _strided(t), start, minus=(xs, vs))
        assert np.array_equal(x, xs) and np.array_equal(v, vs)
