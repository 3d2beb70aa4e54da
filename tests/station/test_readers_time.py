"""CSV time columns: rounding jitter of printed times is accepted, real irregularity refused."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from station.errors import InputFileError
from station.readers import read_csv, time_grid_rate

RATE = 19200.0


def _write(path: Path, t: np.ndarray, fmt: str = "%.9g") -> Path:
    acc = np.sin(2 * np.pi * 7.0 * t) * np.exp(-(t - t[0]))
    np.savetxt(path, np.column_stack([t, acc]), delimiter=",", header="t,acc", comments="", fmt=[fmt, "%.9g"])
    return path


@pytest.mark.parametrize("fmt,beyond_1pct", [("%.9g", False), ("%.8g", True)])
def test_late_times_printed_with_few_digits_are_accepted(tmp_path: Path, fmt: str, beyond_1pct: bool) -> None:
    """The end of a 320 s record at 19.2 kHz: %.9g rounds by up to 5e-7 s (~1 % of a step, the
    issue's case), %.8g by up to 5e-6 s (10 % of a step, still a quarter below half a step)."""
    t = 319.0 + np.arange(int(RATE)) / RATE
    path = _write(tmp_path / "late.csv", t, fmt)
    m = read_csv(path)
    raw = np.loadtxt(path, delimiter=",", skiprows=1)[:, 0]
    dev = np.abs(raw - (raw[0] + np.arange(raw.size) / RATE))
    assert (dev.max() > 0.02 / RATE) == beyond_1pct  # %.8g: the 1 %-of-a-step rule alone refuses it
    assert m.rate_hz == pytest.approx(RATE, rel=1e-7)


@pytest.mark.parametrize("shift_steps", [0.05, 0.5])
def test_a_shifted_sample_in_a_rounded_file_is_refused(tmp_path: Path, shift_steps: float) -> None:
    t = 319.0 + np.arange(int(RATE)) / RATE
    t[5000] += shift_steps / RATE  # beyond the rounding of 9-digit times (1e-6 s = 0.019 step)
    with pytest.raises(InputFileError, match=r"line 5002 has t = .* off the grid"):
        read_csv(_write(tmp_path / "shift.csv", t))


def test_a_missing_sample_is_refused_and_too_coarse_times_named(tmp_path: Path) -> None:
    t = 319.0 + np.arange(int(RATE)) / RATE
    with pytest.raises(InputFileError, match="samples missing: the time jumps .* at line 7002 .*about 1 samples"):
        read_csv(_write(tmp_path / "gap.csv", np.delete(t, 7000)))
    with pytest.raises(InputFileError, match="6 significant digits, too few|time must increase"):
        read_csv(_write(tmp_path / "coarse.csv", t, fmt="%.6g"))


def test_exact_grids_need_no_allowance() -> None:
    assert time_grid_rate(np.arange(100, dtype=float), "ints") == 1.0  # 2 digits, exact
    t = np.arange(50_000) / RATE
    assert time_grid_rate(t, "exact") == pytest.approx(RATE, rel=1e-12)
    with pytest.raises(InputFileError, match="at least 16"):
        time_grid_rate(t[:5], "short")


def test_tiny_and_long_numbers_are_parsed_exactly(tmp_path: Path) -> None:
    """Exponents beyond +-22 and 17 significant digits are read correctly rounded: every value
    equals Python's float() of its token (an independent, correctly rounded reference)."""
    t = np.arange(3000) / RATE
    acc = np.sin(2 * np.pi * 7.0 * t)  # sin(k pi) ~ 1e-16 at zero crossings: e-16 exponents
    acc[::97] = np.random.default_rng(1).normal(size=acc[::97].size) * 1e-30
    path = tmp_path / "tiny.csv"
    np.savetxt(path, np.column_stack([t, acc]), delimiter=",", header="t,acc", comments="", fmt=["%.17g", "%.17g"])
    ref = [float(line.split(",")[1]) for line in path.read_text().splitlines()[1:]]
    got = read_csv(path).channels["acc"]
    assert got.tolist() == ref
    np.testing.assert_array_equal(got, acc)  # %.17g round-trips float64 exactly


def test_rounded_times_reach_identification_as_a_uniform_grid(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The reader hands the least-squares grid on: identify runs on a 9-digit late record."""
    from station.cli import main

    t = 319.0 + np.arange(int(3 * RATE)) / RATE
    tt = t - t[0]
    acc = np.exp(-1.5 * tt) * np.sin(2 * np.pi * 12 * tt)
    force = 40 * np.exp(-(((tt - 0.01) / 0.001) ** 2))
    path = tmp_path / "late.csv"
    np.savetxt(path, np.column_stack([t, force, acc]), delimiter=",", header="t,force,acc", comments="",
               fmt=["%.9g", "%.9g", "%.9g"])
    m = read_csv(path)
    steps = np.diff(m.t)
    assert np.ptp(steps) < 1e-8 * steps.mean() and abs(m.t[0] - 319.0) < 1e-6
    assert main(["identify", str(path), "--mass", "1", "--damping", "v", "--stiffness", "x", "--json"]) == 0, \
        capsys.readouterr().err
    with pytest.raises(InputFileError, match="cannot resolve steps"):  # 1e8 s + 0.1 ms steps: float64 too coarse
        time_grid_rate(1e8 + np.arange(100) * 1e-4, "far")


@pytest.mark.parametrize("digits,rate", [(4, 437.0), (4, 300.0), (5, 3000.0)])
def test_times_rounded_to_under_half_a_step_are_a_uniform_grid(tmp_path: Path, digits: int, rate: float) -> None:
    """A logger printing 4 significant digits: 1 ms units at 437 Hz are 0.44 of a step (refused
    before as "too few digits"; blind unseen7). The least-squares grid through them gives the
    rate; a block dropped from the same file is refused naming the gap."""
    t = 0.5 + np.arange(4000) / rate  # up to ~9.7 s: 1 ms units with 4 digits at 437 Hz
    t = t[t < 9.99] if digits == 4 else t
    m = read_csv(_write(tmp_path / "rounded.csv", t, fmt=f"%.{digits}g"))
    assert m.rate_hz == pytest.approx(rate, rel=2e-5)
    with pytest.raises(InputFileError, match=r"samples missing: .*about 64 samples dropped"):
        read_csv(_write(tmp_path / "dropped.csv", np.delete(t, np.arange(1000, 1064)), fmt=f"%.{digits}g"))


def test_times_rounded_to_more_than_half_a_step_are_refused(tmp_path: Path) -> None:
    t = 0.5 + np.arange(3000) / 1300.0  # 1 ms units: 1.3 steps
    with pytest.raises(InputFileError, match="too few to tell|time must increase"):
        read_csv(_write(tmp_path / "coarse.csv", t, fmt="%.4g"))


def test_the_force_check_reads_a_long_record_without_numpy_median(monkeypatch) -> None:
    """``check_force_impact`` (every CSV/MAT/UFF/HDF5 read with a force channel): the same verdict
    and the same figures as with numpy.median, by selection (eddi.median; session 12: the two
    medians of a 45 s record were ~25 ms of the ~0.17 s read)."""
    import numpy as np
    import pytest

    from station.errors import InputFileError
    from station.readers import check_force_impact

    rng = np.random.default_rng(11)
    noise = 0.02 * rng.standard_normal(883_200) + 0.3  # an offset: the median is not 0
    blow = noise.copy()
    blow[19_200:19_230] += np.hanning(30) * 600.0
    real = np.median
    with pytest.raises(InputFileError) as flat:
        check_force_impact(noise, "noise.csv")
    monkeypatch.setattr(np, "median", lambda *a, **k: (_ for _ in ()).throw(AssertionError("numpy.median")))
    check_force_impact(blow, "blow.csv")  # a blow: no error, and no numpy.median
    with pytest.raises(InputFileError) as again:
        check_force_impact(noise, "noise.csv")
    assert str(again.value) == str(flat.value)
    centred = np.abs(noise - real(noise))
    assert f"noise {1.4826 * float(real(centred)):.3g}" in str(again.value)
