"""Reading MATLAB files (station.mat_reader): v5 and v7.3, names, rates, structs, refusals."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.io

from station.cli import main
from station.errors import InputFileError
from station.readers import read_measurement

EXAMPLE = Path(__file__).resolve().parents[2] / "station" / "examples" / "duffing-impact.csv"


@pytest.fixture(scope="module")
def example() -> np.ndarray:
    return np.loadtxt(EXAMPLE, delimiter=",", skiprows=1)


def test_v5_variables_read_as_the_csv(example: np.ndarray, tmp_path: Path) -> None:
    path = tmp_path / "rec.mat"
    scipy.io.savemat(path, {"time": example[:, 0], "force": example[:, 1], "acceleration": example[:, 2],
                            "operator": "jd", "x": np.arange(3.0)})
    m, ref = read_measurement(str(path)), read_measurement(str(EXAMPLE))
    for name in ("force", "acc"):
        np.testing.assert_array_equal(m.channels[name], ref.channels[name])
    assert m.rate_hz == ref.rate_hz
    assert m.metadata["ignored"] == ["operator", "x"]


def test_struct_with_rate_and_several_sensors(example: np.ndarray, tmp_path: Path) -> None:
    path = tmp_path / "two.mat"
    acc = np.column_stack([example[:, 2], 2 * example[:, 2]])
    scipy.io.savemat(path, {"hit1": {"fs": 5000.0, "force": example[:, 1], "acc": acc},
                            "hit2": {"dt": 2e-4, "force": example[:, 1], "vel": example[:, 2]}})
    with pytest.raises(InputFileError, match="2 structs"):
        read_measurement(str(path))
    m = read_measurement(f"{path}:hit1")
    assert list(m.channels) == ["force", "acc1", "acc2"] and m.rate_hz == pytest.approx(5000.0)
    np.testing.assert_array_equal(m.channels["acc2"], 2 * example[:, 2])
    assert list(read_measurement(f"{path}:hit2").channels) == ["force", "vel"]


def test_v73_hdf5_file(example: np.ndarray, tmp_path: Path) -> None:
    path = tmp_path / "v73.mat"
    with h5py.File(path, "w") as fh:  # MATLAB -v7.3 stores column vectors as 1 x n
        fh["t"] = example[:, 0][None, :]
        fh["force"] = example[:, 1][None, :]
        fh["acc"] = example[:, 2][None, :]
    np.testing.assert_array_equal(read_measurement(str(path)).channels["acc"], example[:, 2])


def test_v73_rate_as_a_one_by_one_matrix(example: np.ndarray, tmp_path: Path) -> None:
    # MATLAB -v7.3 keeps a scalar as a 1 x 1 matrix: `fs` read back as [[rate]] (blind unseen9,
    # session 12: `float()` of it raised TypeError under numpy 2, a traceback from identify)
    path = tmp_path / "v73rate.mat"
    rate = 1.0 / float(example[1, 0] - example[0, 0])
    with h5py.File(path, "w") as fh:
        fh["force"] = example[:, 1][None, :]
        fh["acceleration"] = example[:, 2][None, :]
        fh["fs"] = np.array([[rate]])
    m = read_measurement(str(path))
    assert m.rate_hz == pytest.approx(rate, rel=1e-9)
    np.testing.assert_array_equal(m.channels["acc"], example[:, 2])
    with h5py.File(path, "a") as fh:  # a rate of two numbers: one line, not a traceback
        del fh["fs"]
        fh["fs"] = np.array([[rate, rate]])
    with pytest.raises(InputFileError, match="'fs' should be one number"):
        read_measurement(str(path))


@pytest.mark.parametrize("content,message", [
    ({"t": np.arange(100) / 1e3, "notes": "x"}, "no response variable"),
    ({"acc": np.sin(np.arange(100.0))}, "no time vector"),
    ({"t": np.arange(100) / 1e3, "acc": np.sin(np.arange(99.0))}, "different lengths"),
    ({"fs": 1000.0, "acc": np.r_[np.sin(np.arange(99.0)), np.nan]}, "column 'acc' is not a finite number at sample 99"),
])
def test_refusals_are_one_line(tmp_path: Path, content: dict, message: str) -> None:
    path = tmp_path / "bad.mat"
    scipy.io.savemat(path, content)
    with pytest.raises(InputFileError, match=message):
        read_measurement(str(path))


@pytest.mark.parametrize("body", [b"MATLAB? no" * 50, b"x\n"])  # garbage; truncated (scipy's MatReadError)
def test_not_a_mat_file_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str], body: bytes) -> None:
    path = tmp_path / "junk.mat"
    path.write_bytes(body)
    assert main(["identify", str(path), "--mass", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "junk.mat" in err[0]


def test_raw_counts_with_their_scale_and_offset(example: np.ndarray, tmp_path: Path) -> None:
    # blind unseen12 F5 (session 17): int16 counts beside `force_scale` / `acc_scale` were read as
    # newtons and m/s^2 - the impulse check's mass 0.17x the given one, x^3 100 % off
    f_scale, a_scale, a_offset = 0.0144205, 0.00243058, -0.0375
    force = np.round(example[:, 1] / f_scale).astype(np.int16)
    acc = np.round((example[:, 2] - a_offset) / a_scale).astype(np.int32)
    path = tmp_path / "counts.mat"
    scipy.io.savemat(path, {"Fs": 1.0 / float(example[1, 0] - example[0, 0]), "force": force, "acc": acc,
                            "force_scale": f_scale, "ACC_GAIN": a_scale, "acc_offset": a_offset, "operator": "jd"})
    m = read_measurement(str(path))
    np.testing.assert_array_equal(m.channels["force"], force.astype(np.float64) * f_scale)
    np.testing.assert_array_equal(m.channels["acc"], acc.astype(np.float64) * a_scale + a_offset)
    assert np.max(np.abs(m.channels["acc"] - example[:, 2])) <= 0.5 * a_scale * (1 + 1e-9)
    assert sorted(m.metadata["scaled"]) == ["acc_gain", "acc_offset", "force_scale"]
    assert m.metadata["ignored"] == ["operator"]


@pytest.mark.parametrize("extra,message", [
    ({}, "'acc' holds integer counts \\(int16\\) and the file gives no scale"),
    ({"acc_scale": 0.0}, "the scale of 'acc' \\(acc_scale\\) is 0"),
    ({"acc_scale": np.array([1.0, 2.0])}, "'acc_scale' should be one number"),
])
def test_counts_without_a_usable_scale_are_refused(example: np.ndarray, tmp_path: Path, extra: dict,
                                                    message: str) -> None:
    path = tmp_path / "counts.mat"
    scipy.io.savemat(path, {"fs": 1000.0, "force": example[:, 1],
                            "acc": np.round(example[:, 2] * 100).astype(np.int16), **extra})
    with pytest.raises(InputFileError, match=message):
        read_measurement(str(path))
