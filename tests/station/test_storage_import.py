"""CSV import into a session file, and reading captures back as identify's Measurement."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from station.cli import main
from station.errors import CaptureFormatError, InputFileError
from station.readers import read_measurement as read_any
from station.storage import CaptureWriter, read_capture
from test_storage import make_capture



def write_csv(path: Path, n: int, rate: float, seed: int) -> Path:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    acc = np.exp(-t) * np.sin(2 * np.pi * 12.0 * t) + 0.01 * rng.normal(size=n)
    force = 50.0 * np.exp(-((t - 0.01) / 0.002) ** 2) + 0.01 * rng.normal(size=n)
    np.savetxt(path, np.column_stack([t, force, acc]), delimiter=",", header="t,force,acc", comments="", fmt="%.17g")
    return path


def test_import_csv_round_trips_exactly(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    csvs = [write_csv(tmp_path / "a.csv", 3000, 2000.0, 1), write_csv(tmp_path / "b.csv", 1000, 5120.0, 2)]
    out = tmp_path / "beam.h5"
    rc = main(["import", *map(str, csvs), "--out", str(out), "--mass", "1", "--notes", "bench", "--json",
               "--new-session"])  # two rates: refused without --new-session (test_storage_concurrency)
    assert rc == 0
    assert '"captures": 2' in capsys.readouterr().out
    for i, csv in enumerate(csvs):
        ref = read_any(str(csv))
        got = read_any(f"{out}:{i}")  # the dispatcher sends .h5 to station.storage
        for key in ("force", "acc"):
            np.testing.assert_array_equal(got.channels[key], ref.channels[key])
        np.testing.assert_allclose(got.t, ref.t, rtol=0, atol=1e-9)
        assert got.rate_hz == ref.rate_hz and got.mass == 1.0 and set(got.channels) == {"force", "acc"}
        assert read_capture(out, i).notes == "bench" and read_capture(out, i).source == str(csv)
    assert read_any(str(out)).source == f"{out}:0"  # default: the first capture


def test_measurement_from_acquired_capture_uses_file_metadata(tmp_path: Path) -> None:
    path = tmp_path / "s.h5"
    cap = make_capture(3)
    CaptureWriter(path).append(cap, mass_kg=0.088)
    m = read_any(f"{path}:0")
    np.testing.assert_array_equal(m.channels["force"], cap.si[:, 0])
    np.testing.assert_array_equal(m.channels["acc"], cap.si[:, 1])
    assert m.mass == 0.088 and m.pretrigger_samples == 1000 and m.rate_hz == 19200.0
    assert m.metadata["units"] == {"force": "N", "acc": "m/s^2"}
    assert m.metadata["sensitivities"]["force"] == [2.25, "mV/N"]


def test_measurement_refusals(tmp_path: Path) -> None:
    path = tmp_path / "s.h5"
    w = CaptureWriter(path)
    w.append(make_capture(1))
    w.append(make_capture(2, gaps=((50, 4),)))
    with pytest.raises(InputFileError, match=r"4 samples are missing \(gaps at rows \[50\]\)"):
        read_any(f"{path}:1")
    with pytest.raises(InputFileError, match=r"capture 5: expected an index 0\.\.1"):
        read_any(f"{path}:5")
    foreign = tmp_path / "f.h5"
    with h5py.File(foreign, "w") as f:
        f.attrs["format"] = "something else"
    with pytest.raises(CaptureFormatError, match="foreign HDF5 file"):
        read_any(str(foreign))


def test_cli_errors_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "s.h5"
    CaptureWriter(path).append(make_capture(1, n=300, pre=10))
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"\x00" * 100)
    cases = [
        (["export", f"{path}:3", "--uff", str(tmp_path / "o.uff")], "capture 3: expected an index 0..0"),
        (["export", str(junk), "--uff", str(tmp_path / "o.uff")], "expected an HDF5 file"),
        (["import", str(tmp_path / "none.csv"), "--out", str(path)], "no such file"),
        (["acquire", "--impacts", "2", "--out", str(path)], "--device: expected a device URL"),
        (["acquire", "--device", "sim://duffing-smooth", "--impacts", "0", "--out", str(path)], "--impacts: expected at least 1"),
        (["acquire", "--device", "sim://x", "--impacts", "1", "--out", str(junk)], "is a file of another kind"),
    ]
    for argv, message in cases:
        rc = main(argv)
        err = capsys.readouterr().err
        assert rc == 2, (argv, err)
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("station: error:") and message in lines[0], (argv, err)
    # and once through a real process: no traceback, exit code 2
    res = subprocess.run([sys.executable, "-m", "station.cli", *cases[0][0]], capture_output=True, text=True, timeout=60)
    assert res.returncode == 2 and "Traceback" not in res.stderr and cases[0][1] in res.stderr



def test_import_of_the_shared_real_measurement(tmp_path: Path) -> None:
    """The resonant double beam ring-down (real data, velocity only) stored without change."""
    csv = Path(__file__).resolve().parents[3] / "shared" / "data" / "resonant-double-beam" / "ringdown-01.csv"
    if not csv.exists():
        pytest.skip("shared data not present")
    out = tmp_path / "beam.h5"
    assert main(["import", str(csv), "--out", str(out), "--mass", "1"]) == 0
    ref, got = read_any(str(csv)), read_any(f"{out}:0")
    np.testing.assert_array_equal(got.channels["vel"], ref.channels["vel"])
    assert got.rate_hz == ref.rate_hz and got.t.shape == (15719,)  # README: 15,719 samples
    np.testing.assert_allclose(got.t, ref.t, rtol=0, atol=0.01 / ref.rate_hz)
