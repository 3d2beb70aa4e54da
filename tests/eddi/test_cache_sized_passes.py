"""Session 20's passes without record-length temporaries give numpy's numbers (or, for the
validation's misfit sums, numpy's to rounding), and every refusal they stand in for still fires."""

from __future__ import annotations

import numpy as np
import pytest

from eddi.errors import SignalError
from eddi.model import EquationOfMotion
from eddi.peaks import finite, misfit_sums, varies
from eddi.refine_grid import block_means, block_means_abs, window_means
from eddi.stability import _damping_force, _half_cycle_power, model_warnings
from eddi.validate import validate


def _bits_equal(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


def _awkward(rng: np.random.Generator, n: int, kind: str) -> np.ndarray:
    y = rng.standard_normal(n) * 10.0 ** rng.uniform(-5, 5, n)
    if kind == "zeros":
        y[rng.random(n) < 0.5] = -0.0
    elif kind == "all -0":
        y[:] = -0.0
    elif kind == "nan inf":
        y[rng.random(n) < 0.05] = np.nan
        y[rng.random(n) < 0.05] = -np.inf
    return y


@pytest.mark.parametrize("kind", ["plain", "zeros", "all -0", "nan inf"])
def test_block_means_are_numpys_row_means_bit_for_bit(kind: str) -> None:
    rng = np.random.default_rng(11)
    for block in list(range(2, 20)) + [23, 49, 64, 127, 128, 129, 300]:
        y = _awkward(rng, block * 53 + int(rng.integers(0, block)), kind)
        nb = y.size // block
        assert _bits_equal(block_means(y, block), y[: nb * block].reshape(nb, block).mean(axis=1)), block
        want = np.abs(y)[: nb * block].reshape(nb, block).mean(axis=1)
        assert _bits_equal(block_means_abs(y, block), want), block


def test_window_means_are_the_gathered_tables_means() -> None:
    rng = np.random.default_rng(12)
    y = _awkward(rng, 60000, "zeros")
    for run in (3, 5, 7, 9, 17, 33, 127, 129):
        first = np.sort(rng.integers(0, y.size - run, 700))
        want = y[first[:, None] + np.arange(run)[None, :]].mean(axis=1)
        assert _bits_equal(window_means(y, first, run), want), run
    assert window_means(y, np.array([], dtype=int), 5).shape == (0,)


def test_misfit_sums_are_numpys_to_rounding_and_refuse_other_layouts() -> None:
    rng = np.random.default_rng(13)
    a, b, c, d = (rng.standard_normal(100003) for _ in range(4))
    sq, ab = misfit_sums(a, b, c, d)
    assert sq == pytest.approx(float(np.linalg.norm(a - b)) ** 2, rel=1e-13)
    assert ab == pytest.approx(float(np.sum(np.abs(c - d))), rel=1e-13)
    assert misfit_sums(a, b)[1] == 0.0
    assert misfit_sums(a[::2], b[::2]) is None  # strided: the caller's numpy
    assert misfit_sums(a[:100], b[:100]) is None  # short: numpy


def test_finite_and_varies_answer_as_numpy() -> None:
    rng = np.random.default_rng(14)
    for n in (1, 7, 5000, 70000):
        y = rng.standard_normal(n)
        assert finite(y) and varies(y) == bool(np.ptp(y) > 0)
        for bad in (np.nan, np.inf, -np.inf):
            z = y.copy()
            z[int(rng.integers(n))] = bad
            assert not finite(z)
        z = np.full(n, 2.5)
        assert not varies(z)
        z[-1] = np.nextafter(2.5, 3.0)
        assert varies(z) == (n > 1)
    assert finite(np.zeros(0)) and not varies(np.array([-0.0, 0.0, -0.0]))


def test_half_cycle_power_is_reduceat_bit_for_bit() -> None:
    rng = np.random.default_rng(15)
    eom = EquationOfMotion(mass=0.8, damping={"v": 0.3, "x^2*v": -2.0, "v^3": 1e-3, "abs(v)*v": 0.1},
                           stiffness={"x": 100.0})
    for n in (5, 1000, 65536, 65537, 300001):
        t = np.arange(n) / 19200.0
        x = np.sin(2 * np.pi * 4.3 * t) * np.exp(-0.2 * t) + 1e-3 * rng.standard_normal(n)
        v = np.gradient(x, t)
        neg = np.signbit(x)
        starts = np.concatenate(([0], np.flatnonzero(neg[1:] != neg[:-1]) + 1))
        want = np.add.reduceat(_damping_force(eom, x, v) * v, starts)
        assert _bits_equal(_half_cycle_power(eom, x, v, starts), want), n
    # one half cycle longer than a piece
    x, v = np.abs(rng.standard_normal(200000)), rng.standard_normal(200000)
    starts = np.array([0, 3, 150000])
    assert _bits_equal(_half_cycle_power(eom, x, v, starts), np.add.reduceat(_damping_force(eom, x, v) * v, starts))


def test_negative_damping_is_still_flagged() -> None:
    t = np.arange(400000) / 19200.0
    x = np.sin(2 * np.pi * 4 * t)
    v = 2 * np.pi * 4 * np.cos(2 * np.pi * 4 * t)
    eom = EquationOfMotion(mass=1.0, damping={"v": -0.5}, stiffness={"x": 630.0})
    assert any("negative damping" in w for w in model_warnings(eom, x, v))
    assert not model_warnings(EquationOfMotion(mass=1.0, damping={"v": 0.5}, stiffness={"x": 630.0}), x, v)


@pytest.mark.parametrize("name", ["x", "v"])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_a_driven_validation_still_refuses_a_non_finite_signal(name: str, bad: float) -> None:
    eom = EquationOfMotion(mass=1.0, damping={"v": 0.1}, stiffness={"x": 100.0})
    t = np.arange(20000) / 1000.0
    f = np.zeros(t.size)
    f[:5] = 1.0
    sig = {"x": np.sin(t), "v": np.cos(t)}
    sig[name][12345] = bad
    with pytest.raises(SignalError, match=rf"^{name} contains 1 NaN or infinite values \(first at index 12345\)"):
        validate(eom, t, sig["x"], v=sig["v"], force=f)
    with pytest.raises(SignalError, match="need at least 2 samples"):
        validate(eom, t[:1], sig["x"][:1], v=sig["v"][:1], force=f[:1])
