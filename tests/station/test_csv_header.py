"""CSV headers as other tools write them: delimiters, names, units, notes (station.csv_header)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from station.cli import main
from station.errors import InputFileError
from station.readers import read_csv, read_measurement

RATE = 5000.0


def _rows(n: int = 4000) -> np.ndarray:
    t = np.arange(n) / RATE
    force = np.where(t < 2e-3, 40.0 * np.sin(np.pi * t / 2e-3), 0.0)
    acc = np.where(t >= 2e-3, 30.0 * np.exp(-3 * t) * np.sin(2 * np.pi * 21.0 * t), 0.0)
    return np.column_stack([t, force, acc])


def _write(path: Path, header: str, rows: np.ndarray, sep: str = ",", decimal_comma: bool = False,
           notes: str = "") -> Path:
    lines = [sep.join(f"{v:.17g}" for v in row) for row in rows]
    if decimal_comma:
        lines = [ln.replace(".", ",") for ln in lines]
    path.write_text(notes + header + "\n" + "\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_station_format_reads_untouched(tmp_path: Path) -> None:
    rows = _rows()
    m = read_csv(_write(tmp_path / "a.csv", "t,force,acc", rows))
    np.testing.assert_array_equal(m.channels["acc"], rows[:, 2])  # bit for bit: no conversion
    np.testing.assert_array_equal(m.channels["force"], rows[:, 1])
    assert "converted" not in m.metadata


@pytest.mark.parametrize("header,sep,comma,notes", [
    ("Time [s],Force [N],Acceleration [m/s^2]", ",", False, ""),
    ("time;force;acceleration", ";", True, ""),  # a European spreadsheet export
    ("Time (s)\tHammer (N)\tAccel (m/s²)", "\t", False, "# logger 7, channel map v2\n# 2026-11-24\n"),
    ("t force acc", " ", False, ""),
    ('"Time [s]","Force [N]","Acceleration [m/s^2]"', ",", False, ""),  # a spreadsheet quotes its header
])
def test_other_delimiters_names_and_notes_read_the_same_numbers(tmp_path: Path, header: str, sep: str,
                                                                comma: bool, notes: str) -> None:
    rows = _rows()
    ref = read_csv(_write(tmp_path / "ref.csv", "t,force,acc", rows))
    m = read_measurement(str(_write(tmp_path / "other.txt", header, rows, sep, comma, notes)))
    assert set(m.channels) == {"force", "acc"}
    for name in ("force", "acc"):
        np.testing.assert_array_equal(m.channels[name], ref.channels[name])
    assert m.rate_hz == ref.rate_hz


@pytest.mark.parametrize("cell,column,factor", [
    ("Acceleration [g]", "acc", 9.80665), ("acc (mm/s^2)", "acc", 1e-3), ("Velocity [mm/s]", "vel", 1e-3),
    ("Displacement [um]", "disp", 1e-6), ("disp [in]", "disp", 0.0254)])
def test_units_in_the_header_are_converted_to_si(tmp_path: Path, cell: str, column: str, factor: float) -> None:
    rows = _rows()
    m = read_csv(_write(tmp_path / "u.csv", f"Time [ms],Force [kN],{cell}", rows * [1e3, 1e-3, 1.0]))
    np.testing.assert_allclose(m.channels[column], rows[:, 2] * factor, rtol=1e-15, atol=0)
    np.testing.assert_allclose(m.channels["force"], rows[:, 1], rtol=1e-15)
    assert m.rate_hz == pytest.approx(RATE, rel=1e-9)
    assert m.metadata["converted"][column] == f"{cell} (x{factor:g})"


def test_several_sensors_by_number_or_name(tmp_path: Path) -> None:
    rows = _rows()[:, [0, 1, 2, 2, 2]]
    m = read_csv(_write(tmp_path / "m.csv", "Time [s],Force [N],Acceleration 1 [g],accel_2 [g],Acceleration tip", rows))
    assert list(m.channels) == ["force", "acc1", "acc2", "acc_tip"]
    np.testing.assert_allclose(m.channels["acc2"], rows[:, 2] * 9.80665, rtol=1e-15)


@pytest.mark.parametrize("header,message", [
    ("t,force,Pressure [Pa]", "no response column in the header t,force (read past: 'Pressure [Pa]')"),
    ("t,force,Velocity [furlong/s]", "unknown unit 'furlong/s'; expected one of"),
    ("t,Force [V],acc", "is in volts"),
    ("t,acc,Acceleration [g]", "a column is named twice"),
    ("0,1,2", "no header: line 1 holds numbers"),
])
def test_headers_that_cannot_be_read_are_refused_in_one_line(tmp_path: Path, header: str, message: str) -> None:
    path = _write(tmp_path / "bad.csv", header, _rows(100))
    with pytest.raises(InputFileError, match=re.escape(message)):
        read_csv(path)


def test_identify_gives_one_model_whatever_the_units(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The same record in SI and in g / mm-free units identifies the same equation (to print precision)."""
    rows = _rows(6000)
    si = _write(tmp_path / "si.csv", "t,force,acc", rows)
    g = _write(tmp_path / "g.csv", "Time [s];Force [N];Acceleration [g]", rows / [1.0, 1.0, 9.80665], ";", True)
    out = []
    for path in (si, g):
        assert main(["identify", str(path), "--mass", "0.5", "--damping", "v", "--stiffness", "x"]) in (0, 1)
        out.append(capsys.readouterr().out.splitlines()[0].split(": ", 1)[1])
    assert out[0] == out[1]


def test_other_logged_quantities_are_read_past_and_said(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A DAQ export with a temperature and a trigger line beside the vibration (the trigger as
    text): those columns are read past, said once on stderr, and the record reads the same."""
    rows = _rows()
    ref = read_csv(_write(tmp_path / "ref.csv", "t,force,acc", rows))
    text = ["Time (s);Force (N);Trigger;Acceleration (m/s^2);Temperature [C]"]
    text += [f"{r[0]:.17g};{r[1]:.17g};{'ON' if r[1] > 5 else 'OFF'};{r[2]:.17g};21,5".replace(".", ",")
             for r in rows]
    path = tmp_path / "daq.csv"
    path.write_text("\n".join(text) + "\n", encoding="utf-8")
    m = read_measurement(str(path))
    assert set(m.channels) == {"force", "acc"}
    np.testing.assert_array_equal(m.channels["acc"], ref.channels["acc"])
    assert m.metadata["ignored_columns"] == ["Trigger", "Temperature [C]"]
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("station: note:") and "'Trigger', 'Temperature [C]'" in err[0]


def test_an_unknown_quantity_is_still_refused(tmp_path: Path) -> None:
    with pytest.raises(InputFileError, match="unknown column 'Strain gauge angle'"):
        read_measurement(str(_write(tmp_path / "x.csv", "t,force,acc,Strain gauge angle",
                                    np.column_stack([_rows(), np.zeros(4000)]))))


@pytest.mark.parametrize("header", ["Time [s],Force [N],Accel 1 [m/s^2]", "t,force,acc_tip",
                                    "Time (s),Force (N),Accelerometer 3 (m/s^2)"])
def test_one_sensor_with_a_suffix_is_the_response(tmp_path: Path, header: str) -> None:
    rows = _rows()
    m = read_measurement(str(_write(tmp_path / "one.csv", header, rows)))
    assert set(m.channels) == {"force", "acc"}
    np.testing.assert_array_equal(m.channels["acc"], rows[:, 2])
    assert list(m.metadata["renamed"].values()) == ["acc"]


def test_two_sensors_stay_two(tmp_path: Path) -> None:
    rows = _rows()
    m = read_measurement(str(_write(tmp_path / "two.csv", "t,force,acc1,acc2",
                                    np.column_stack([rows, 0.5 * rows[:, 2]]))))
    assert set(m.channels) == {"force", "acc1", "acc2"} and "renamed" not in m.metadata


@pytest.mark.parametrize("header,units,sep,scale", [
    ("Time,Force,Acceleration", "[s],[N],[g]", ",", [1.0, 1.0, 1 / 9.80665]),
    ("t;force;acc", "s;kN;m/s^2", ";", [1.0, 1e-3, 1.0]),
    ("t,force,acc", "(s),(N),(m/s²)", ",", [1.0, 1.0, 1.0]),
    ("Time [s],Force,Acceleration", "[s],[N],[g]", ",", [1.0, 1.0, 1 / 9.80665]),  # the same unit twice
])
def test_a_units_row_under_the_names_joins_them(tmp_path: Path, header: str, units: str, sep: str,
                                                scale: list[float]) -> None:
    """A logger's export with the units on a row of their own (blind unseen7: refused before as
    "line 2: '[s]' is not a number")."""
    rows = _rows()
    ref = read_csv(_write(tmp_path / "ref.csv", "t,force,acc", rows))
    m = read_measurement(str(_write(tmp_path / "units.csv", header + "\n" + units, rows * scale, sep)))
    for name in ("force", "acc"):
        np.testing.assert_allclose(m.channels[name], ref.channels[name], rtol=1e-12, atol=0)
    assert m.rate_hz == pytest.approx(RATE, rel=1e-12)


def test_a_units_row_that_contradicts_the_header_is_refused(tmp_path: Path) -> None:
    path = _write(tmp_path / "both.csv", "Time [s],Force [N],Acceleration [g]\n[s],[N],[m/s^2]", _rows())
    with pytest.raises(InputFileError, match="unit 'g' in the header and 'm/s\\^2' in the units row"):
        read_measurement(str(path))
