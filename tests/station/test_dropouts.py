"""A sensor's dropouts (exact zeros amid the motion) are filled with a note, or refused when too
many; a signal that reads 0 at its crossings (a coarse converter) is left alone."""

from __future__ import annotations

import numpy as np
import pytest

from eddi.calculus import fill_gaps
from eddi.conditioning import dropout_runs
from station.errors import InputFileError
from station.readers import read_csv


def _ringdown(n: int = 700, rate: float = 1000.0, f: float = 35.6, zeta: float = 0.01, amp: float = 0.04):
    t = np.arange(n) / rate - 0.1
    w = 2 * np.pi * f
    v = np.where(t > 0, amp * np.exp(-zeta * w * t) * np.cos(w * np.sqrt(1 - zeta**2) * t), 0.0)
    rng = np.random.default_rng(3)
    v = v + 2e-5 * rng.standard_normal(n)
    force = np.where((t >= 0) & (t < 0.004), 40.0 * np.sin(np.pi * t / 0.004), 0.0)
    return t, force, v


def _write(path, t, force, v):
    np.savetxt(path, np.column_stack((t, force, v)), delimiter=",", header="t,force,vel", comments="",
               fmt="%.10g")


def test_dropouts_amid_the_motion_are_found_and_filled_within_the_noise(tmp_path, capsys):
    t, force, v = _ringdown()
    lost = v.copy()
    runs = [(123, 124), (149, 151), (153, 156), (291, 293)]  # 8 samples, inside half-cycles
    for a, b in runs:
        lost[a:b] = 0.0
    assert dropout_runs(lost) == runs
    _write(tmp_path / "r.csv", t, force, lost)
    meas = read_csv(tmp_path / "r.csv")
    err = capsys.readouterr().err
    assert "reads exactly 0 for 8 samples in 4 runs amid the motion" in err
    filled = meas.channels["vel"]
    # each filled sample within 1 % of the ring-down's amplitude of the value before the loss
    assert np.max(np.abs(filled - v)) < 0.01 * 0.04
    assert np.max(np.abs(filled - v)[[i for a, b in runs for i in range(a, b)]]) > 0  # filled, not copied


def test_a_dropout_that_straddles_a_crossing_is_found():
    t, force, v = _ringdown()
    lost = v.copy()
    ring = slice(120, 160)  # inside the ring-down (the blow starts at sample 100)
    k = ring.start + int(np.argmin(np.abs(v[ring])))  # the sample nearest a crossing
    assert abs(v[k - 2]) > 0.1 * 0.04  # the signal there is far from 0
    lost[k - 2:k] = 0.0  # the two samples before it
    assert (k - 2, k) in dropout_runs(lost)


def test_zeros_of_a_coarse_converter_at_its_crossings_are_no_dropouts(tmp_path, capsys):
    t, force, v = _ringdown()
    q = 0.04 / 60  # a coarse count: values within half a count of 0 read exactly 0
    coarse = np.round(v / q) * q
    assert np.count_nonzero(coarse == 0.0) > 20
    assert dropout_runs(coarse) == []
    _write(tmp_path / "c.csv", t, force, coarse)
    read_csv(tmp_path / "c.csv")
    assert "dropouts" not in capsys.readouterr().err


def test_a_long_loss_of_signal_is_refused_in_one_line(tmp_path):
    t, force, v = _ringdown()
    lost = v.copy()
    lost[200:212] = 0.0  # 12 samples: a third of a cycle
    _write(tmp_path / "l.csv", t, force, lost)
    with pytest.raises(InputFileError, match=r"column 'vel' reads exactly 0 for 12 samples .* too many to fill"):
        read_csv(tmp_path / "l.csv")


def test_fill_gaps_is_exact_on_a_cubic():
    x = np.arange(40.0)
    y = 0.5 * x**3 - 2 * x**2 + x - 7
    bad = np.zeros(40, dtype=bool)
    bad[[5, 6, 7, 20, 33]] = True
    np.testing.assert_allclose(fill_gaps(np.where(bad, 0.0, y), bad), y, rtol=1e-9, atol=1e-7)


def test_a_quantized_rest_before_a_steep_blow_is_no_dropout():
    # a quantized accelerometer at rest reads exact zeros up to the blow's foot; the cubic
    # through the rise puts large values there (session 15, s15uncouple: 1-3 samples on twelve
    # quantized captures were filled as a false impulse, x 0.023 -> 0.49 nrmse off the truth)
    rate, f = 2048.0, 40.0
    t = np.arange(2048) / rate - 0.2
    w = 2 * np.pi * f
    pulse = np.where((t >= 0) & (t < 0.002), np.sin(np.pi * t / 0.002), 0.0)
    ring = np.where(t >= 0.002, np.exp(-0.02 * w * (t - 0.002)) * np.sin(w * (t - 0.002)), 0.0)
    acc = 40.0 * pulse + 12.0 * ring + 0.004 * np.random.default_rng(5).standard_normal(t.size)
    q = 0.02  # counts of 20 mm/s^2: the rest reads 0
    coarse = np.round(acc / q) * q
    foot = int(np.argmax(t >= 0))
    assert np.all(coarse[foot - 5:foot] == 0.0) and abs(coarse[foot + 1]) > 100 * q
    assert dropout_runs(coarse) == []


def _fill_gaps_by_scan(y, bad, side=2):
    """The definition (session 15's code): each run's neighbours found by scanning the record."""
    y = np.array(y, dtype=float)
    edges = np.diff(np.concatenate(([0], bad.astype(np.int8), [0])))
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
        left = np.arange(a - 1, -1, -1)
        left = left[~bad[left]][:side]
        right = np.arange(b, y.size)
        right = right[~bad[right]][:side]
        idx = np.concatenate((left, right))
        if idx.size == 0:
            continue
        centre = 0.5 * (a + b - 1)
        c = np.polynomial.polynomial.polyfit(idx - centre, y[idx], min(3, idx.size - 1))
        y[a:b] = np.polynomial.polynomial.polyval(np.arange(a, b) - centre, c)
    return y


def test_fill_gaps_finds_the_same_neighbours_as_a_scan_bit_for_bit():
    # the neighbours come from a search in the good samples' indices (session 16: the scan of
    # the whole record per run cost 0.3-0.5 s of CPU on a 45 s quantized record's 309 zero runs)
    rng = np.random.default_rng(16)
    for trial in range(400):
        n = int(rng.integers(1, 80))
        y = rng.standard_normal(n)
        bad = rng.random(n) < rng.random()  # from none to all bad; runs at both ends, runs that touch
        side = int(rng.integers(1, 6))
        assert fill_gaps(y, bad, side).tobytes() == _fill_gaps_by_scan(y, bad, side).tobytes(), (trial, side)


def test_fill_gaps_of_chosen_runs_fills_those_as_all_runs_would():
    rng = np.random.default_rng(7)
    y = rng.standard_normal(300)
    bad = np.zeros(300, dtype=bool)
    runs = [(3, 5), (10, 11), (12, 15), (100, 108), (297, 300)]
    for a, b in runs:
        bad[a:b] = True
    every = fill_gaps(y, bad)
    some = fill_gaps(y, bad, runs=[(10, 11), (100, 108)])
    chosen = np.zeros(300, dtype=bool)
    chosen[10:11] = chosen[100:108] = True
    assert some[chosen].tobytes() == every[chosen].tobytes()  # the run at 12 still not a neighbour of 10
    assert some[~chosen].tobytes() == y[~chosen].tobytes()


def test_dropouts_of_a_quantized_rest_among_thousands_of_zero_runs():
    # a long quantized record reads exact zeros in thousands of short runs once the ring-down
    # is in the noise; none is a dropout, and three zeroed samples at a peak amid the motion are
    t, force, v = _ringdown(n=20000, rate=5000.0, f=35.6, zeta=0.02, amp=0.04)
    coarse = np.round(v / 4e-5) * 4e-5  # a count of twice the noise RMS
    assert np.count_nonzero(np.diff((coarse == 0.0).astype(int)) == 1) > 2000
    assert dropout_runs(coarse) == []
    lost = coarse.copy()
    k = 1000 + int(np.argmax(np.abs(coarse[1000:1140])))  # a peak of the ring-down (one cycle)
    lost[k:k + 3] = 0.0
    assert dropout_runs(lost) == [(k, k + 3)]


def test_the_smallest_step_is_numpy_uniques_bit_for_bit() -> None:
    # session 19: from the sorted values (no numpy.unique compaction, no numpy.ma import)
    from eddi.conditioning.checks import _smallest_step

    rng = np.random.default_rng(7)
    cases = [np.round(rng.normal(size=5000) * 300) / 300, rng.normal(size=1000), np.zeros(40), np.array([2.5]),
             np.array([-0.0, 0.0, 1.0]), np.array([1.0, np.inf, np.inf]), np.array([-np.inf, -np.inf, 1.0, 3.0]),
             np.array([1.0, np.nan, 2.0, 2.0]), np.array([np.nan, np.nan]), np.array([])]
    for y in cases:
        levels = np.unique(y)
        want = float(np.min(np.diff(levels))) if levels.size > 1 else 0.0
        got = _smallest_step(y)
        assert got == want or (np.isnan(got) and np.isnan(want))
