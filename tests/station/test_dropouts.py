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
