"""Reading UFF58 time responses (station.uff_reader): the station's own export round trip, other
tools' files (units, several sensors), refusals in one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import pyuff

from station.cli import main
from station.errors import InputFileError
from station.readers import read_measurement

EXAMPLE = Path(__file__).resolve().parents[2] / "station" / "examples" / "duffing-impact.csv"


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("uff")
    h5, uff = d / "s.h5", d / "s.uff"
    assert main(["import", str(EXAMPLE), "--out", str(h5), "--mass", "0.815"]) == 0
    assert main(["export", str(h5), "--uff", str(uff)]) == 0
    return h5, uff


def test_station_export_reads_back_bit_for_bit(session: tuple[Path, Path]) -> None:
    h5, uff = session
    a, b = read_measurement(f"{h5}:0"), read_measurement(str(uff))
    assert set(b.channels) == set(a.channels) == {"force", "acc"}
    for name in a.channels:
        np.testing.assert_array_equal(b.channels[name], a.channels[name])
    assert b.rate_hz == a.rate_hz and b.pretrigger_samples == a.pretrigger_samples
    np.testing.assert_allclose(b.t - b.t[0], a.t - a.t[0], rtol=0, atol=1e-9)  # UFF time starts at 0
    assert b.metadata["format"] == "uff58" and b.source.endswith("s.uff:0")


def test_identify_gives_the_same_equation_from_hdf5_and_uff(session: tuple[Path, Path],
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    h5, uff = session
    out = []
    for spec in (f"{h5}:0", str(uff)):
        assert main(["identify", spec, "--mass", "0.815", "--damping", "v", "--stiffness", "x,x^3"]) in (0, 1)
        out.append(capsys.readouterr().out.splitlines()[0].split(": ", 1)[1])
    assert out[0] == out[1]


def _set(data: np.ndarray, kind: int, label: str, case: int = 0, node: int = 1, step: float = 2e-4,
         ftype: int = 1, len_exp: int = 1) -> dict:
    return pyuff.prepare_58(
        binary=1, func_type=ftype, id1=f"pt{node}", load_case_id=case, rsp_node=node, rsp_dir=3, ref_node=1,
        ref_dir=3, abscissa_spacing=1, abscissa_spec_data_type=17, ordinate_spec_data_type=kind,
        ordinate_len_unit_exp=len_exp, ordinate_force_unit_exp=0, ordinate_axis_units_lab=label,
        orddenom_spec_data_type=0, data=data, x=np.arange(data.size) * step)


def _write(path: Path, sets: list[dict]) -> Path:
    path.unlink(missing_ok=True)
    pyuff.UFF(str(path)).write_sets(sets, mode="add")  # (as station.uff writes: "overwrite" of a list
    # left pyuff 2.5.8 unable to read the file back)
    return path


def _signals(n: int = 3000) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(n) * 2e-4
    force = np.where(t < 1e-3, 30.0 * np.sin(np.pi * t / 1e-3), 0.0)
    acc = np.exp(-4 * t) * np.sin(2 * np.pi * 30 * t)
    return force, acc


def test_another_tools_file_units_and_several_sensors(tmp_path: Path) -> None:
    force, acc = _signals()
    path = _write(tmp_path / "lab.unv", [_set(force, 13, "N"), _set(acc, 12, "g", node=2),
                                         _set(2 * acc, 12, "mm/s^2", node=3)])
    m = read_measurement(str(path))
    assert list(m.channels) == ["force", "acc1", "acc2"]
    np.testing.assert_allclose(m.channels["acc1"], acc * 9.80665, rtol=1e-15)
    np.testing.assert_allclose(m.channels["acc2"], 2e-3 * acc, rtol=1e-15)
    assert m.rate_hz == pytest.approx(5000.0, rel=1e-5)  # UFF58 prints the increment with 6 digits


def test_units_dataset_164_converts_unlabelled_sets(tmp_path: Path) -> None:
    force, acc = _signals()
    units = pyuff.prepare_164(units_code=5, units_description="mm/newton", temp_mode=1, length=1000.0, force=1.0,
                              temp=1.0, temp_offset=273.15)
    path = _write(tmp_path / "mm.uff", [units, _set(force, 13, ""), _set(1e3 * acc, 12, "")])
    np.testing.assert_allclose(read_measurement(str(path)).channels["acc"], acc, rtol=1e-15)


@pytest.mark.parametrize("sets,spec,message", [
    ("two_cases", "", "2 load cases"),
    ("two_cases", ":7", "no load case 7"),
    ("volts", "", "in volts"),
    ("frf_only", "", "no time response"),
])
def test_refusals_are_one_line(tmp_path: Path, sets: str, spec: str, message: str) -> None:
    force, acc = _signals()
    content = {
        "two_cases": [_set(force, 13, "N"), _set(acc, 12, "m/s^2"), _set(force, 13, "N", case=1),
                      _set(acc, 12, "m/s^2", case=1)],
        "volts": [_set(force, 13, "N"), _set(acc, 12, "V")],
        "frf_only": [_set(acc, 12, "m/s^2", ftype=4)],
    }[sets]
    path = _write(tmp_path / "bad.uff", content)
    with pytest.raises(InputFileError, match=message):
        read_measurement(f"{path}{spec}")


def test_garbage_is_refused_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "junk.uff"
    path.write_bytes(b"\x00\x01 not a universal file \xff" * 20)
    assert main(["identify", str(path), "--mass", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "junk.uff" in err[0] and "Traceback" not in err[0]


@pytest.mark.parametrize("keep", [0.3, 0.6, 0.97])
def test_a_truncated_file_is_refused_as_truncated(tmp_path: Path, keep: float,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    force, acc = _signals()
    whole = _write(tmp_path / "whole.uff", [_set(force, 13, "N"), _set(acc, 12, "m/s^2")]).read_bytes()
    cut = tmp_path / "cut.uff"
    cut.write_bytes(whole[: int(keep * len(whole))])
    assert main(["identify", str(cut), "--mass", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "truncated" in err[0] and "Traceback" not in err[0]
