"""eddi.median: numpy.median's value bit for bit, without partitioning the whole array."""

from __future__ import annotations

import numpy as np
import pytest

import eddi.median as em
from eddi.energy import noise_level


def _arrays():
    rng = np.random.default_rng(11)
    yield rng.normal(size=20_001)
    yield rng.normal(size=460_000)
    yield np.abs(np.diff(np.cumsum(rng.normal(size=300_003)), 3))  # noise_level's argument
    yield np.sort(rng.exponential(size=123_457))  # sorted: the strided sample is still spread
    yield np.round(rng.normal(size=200_000), 1)  # many ties at the middle
    n = 500_000
    yield np.sin(0.01 * np.arange(n)) * np.exp(-np.arange(n) / n)  # a ring-down


@pytest.mark.parametrize("a", list(_arrays()), ids=lambda a: f"n{a.size}")
def test_equals_numpy_bit_for_bit(a):
    assert em.median(a) == float(np.median(a))


def test_long_array_not_partitioned_whole(monkeypatch):
    """The speed claim: a long array's median never calls numpy.median (the fallback)."""
    a = np.random.default_rng(3).normal(size=460_000)
    want = float(np.median(a))

    def refuse(*_a, **_k):
        raise AssertionError("numpy.median called on a long array")

    monkeypatch.setattr(em.np, "median", refuse)
    assert em.median(a) == want


def test_nan_and_short_arrays_as_numpy():
    a = np.random.default_rng(5).normal(size=50_000)
    a[17] = np.nan
    assert np.isnan(em.median(a))
    short = np.array([3.0, 1.0, 2.0, 10.0])
    assert em.median(short) == 2.5


def test_noise_level_unchanged():
    """noise_level's value is the one numpy.median gives (the identify JSON stays byte-identical)."""
    rng = np.random.default_rng(7)
    t = np.arange(400_000) / 19200.0
    y = np.sin(2 * np.pi * 12.0 * t) + 1e-3 * rng.normal(size=t.size)
    ref = float(np.median(np.abs(np.diff(y, 3))) / 0.6745 / np.sqrt(20.0))
    assert noise_level(y) == ref
    assert abs(noise_level(y) / 1e-3 - 1.0) < 0.02


def test_the_force_channels_noise_is_numpys_median_without_numpy_median(monkeypatch) -> None:
    """The impulse check's force noise (every ``station identify``; diagnose's chain checks): the
    same float as numpy.median of the 45 s record's differences, by selection (session 12: ~6 ms)."""
    import math

    from eddi.diagnosis.chain import _force_noise

    rng = np.random.default_rng(3)
    f = 0.02 * rng.standard_normal(883_200)
    f[19_200:19_230] += np.hanning(30) * 600.0  # a blow
    want = float(1.4826 * np.median(np.abs(np.diff(f))) / math.sqrt(2.0))

    def no_median(*a, **k):
        raise AssertionError("numpy.median partitioned the whole record")

    monkeypatch.setattr(np, "median", no_median)
    assert _force_noise(f) == want


def test_the_bracket_is_one_compiled_pass(monkeypatch) -> None:
    """Session 17: a long contiguous array's counts and middle values come from one compiled pass
    (``_bracket_split``), not numpy's comparison passes; the same float as numpy.median."""
    rng = np.random.default_rng(17)
    arrays = [rng.normal(size=460_000), np.round(rng.normal(size=200_001), 2), rng.exponential(size=77_777)]
    want = [float(np.median(a)) for a in arrays]

    def no_count(*a, **k):
        raise AssertionError("a numpy pass over the whole array")

    monkeypatch.setattr(em.np, "count_nonzero", no_count)
    assert [em.median(a) for a in arrays] == want
    strided = rng.normal(size=100_000)[::2]  # not contiguous: numpy's passes, the same value
    monkeypatch.undo()
    assert em.median(strided) == float(np.median(strided))


def test_noise_levels_third_difference_is_numpys_bit_for_bit(monkeypatch) -> None:
    """Session 17: ``|diff(y, 3)|`` in one compiled pass (``eddi.calculus.abs_third_difference``):
    numpy's three passes' values exactly, on rough and smooth signals and quantized ties."""
    from eddi.calculus import abs_third_difference

    rng = np.random.default_rng(5)
    ys = [np.cumsum(rng.normal(size=n)) * s + rng.normal(size=n) * e
          for n, s, e in ((4, 1.0, 1.0), (5_000, 1e-6, 1e-9), (300_001, 1e3, 1e-12))]
    ys.append(np.round(np.sin(np.arange(100_000) * 0.003), 3))
    want = [np.abs(np.diff(y, 3)) for y in ys]

    def no_diff(*a, **k):
        raise AssertionError("numpy.diff's passes")

    monkeypatch.setattr(np, "diff", no_diff)
    for y, w in zip(ys, want):
        got = abs_third_difference(y)
        assert got.shape == w.shape and np.array_equal(got, w)
    monkeypatch.undo()
    assert np.array_equal(abs_third_difference(ys[2][::3]), np.abs(np.diff(ys[2][::3], 3)))  # strided: numpy
    assert abs_third_difference(np.ones(3)).size == 0


def test_short_arrays_give_numpys_median_bit_for_bit_without_importing_numpy_ma() -> None:
    # session 19: numpy.median's NaN check imports numpy.ma (~10-25 ms of a process)
    import subprocess
    import sys

    from eddi.median import _small_median, median

    rng = np.random.default_rng(19)
    for n in [1, 2, 3, 4, 5, 16, 17, 100, 1001, 19_999]:
        for a in (rng.normal(size=n), np.round(rng.normal(size=n), 1), np.full(n, -0.0), rng.normal(size=n) * 1e300):
            assert median(a) == np.median(a) and _small_median(a) == np.median(a)
            assert np.signbit(median(a)) == np.signbit(np.median(a))
    nan = rng.normal(size=20)
    nan[7] = np.nan
    assert np.isnan(median(nan)) and np.isnan(median(np.zeros((3, 3)) * np.nan))
    assert median(np.arange(9.0).reshape(3, 3)) == 4.0
    code = ("import sys, numpy as np; from eddi.median import median; median(np.arange(16.0)); "
            "print('numpy.ma' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
