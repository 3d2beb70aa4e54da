"""The undeclared-IEPE-coupling check in multi-record ``station identify`` (issue 10, session 10).

Several records of one sensor: the check runs once, on the record the model was fitted to, and
warns once with the corner and the option; records without a coupling give no warning, and a
declared corner turns the check off. Same rig and records as ``test_sensor_highpass.py``.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from station.cli import main
from tests.station.test_sensor_highpass import MASS, _csv


def _identify_many(paths: list[Path], capsys: pytest.CaptureFixture[str], *extra: str) -> tuple[int, dict, str]:
    try:
        code = main(["identify", *map(str, paths), "--mass", str(MASS), "--damping", "v,v^3", "--stiffness", "x,x^3",
                     "--json", *extra])
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, (json.loads(out) if out.strip() else {}), err


def _warned(js: dict) -> list[str]:
    return [w for w in js["warnings"] if "AC-coupled" in w]


def test_coupled_records_warned_once_with_the_corner(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    paths = [_csv(tmp_path, 0.4, seed) for seed in (0, 1, 2)]
    code, js, err = _identify_many(paths, capsys)
    assert code == 0, err
    warned = _warned(js)
    assert len(warned) == 1 and warned[0].startswith("the fit record (")
    fc = js["conditioning"]["sensor_highpass_estimate_hz"]
    assert 0.4 / 1.5 < fc < 0.4 * 1.5
    assert f"--sensor-highpass {fc:.2g}" in warned[0]
    code, told, err = _identify_many(paths, capsys, "--sensor-highpass", "0.4")
    assert code == 0, err
    assert not _warned(told) and "sensor_highpass_check" not in told["conditioning"]


def test_null_records_silent(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, js, err = _identify_many([_csv(tmp_path, None, seed) for seed in (0, 1, 2)], capsys)
    assert code == 0, err
    assert not _warned(js)
    assert js["conditioning"]["sensor_highpass_check"]["evident"] is False


def _diagnose(paths: list[Path], capsys: pytest.CaptureFixture[str], *extra: str) -> tuple[int, dict, str]:
    try:
        code = main(["diagnose", *map(str, paths), "--mass", str(MASS), "--damping", "v,v^3", "--stiffness", "x,x^3",
                     "--mechanisms", "coulomb_friction", "--json", *extra])
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, (json.loads(out) if out.strip() else {}), err


def test_diagnose_warns_once_on_coupled_captures_and_not_on_nulls(tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    code, js, err = _diagnose([_csv(tmp_path, 0.4, seed) for seed in (0, 1, 2)], capsys)
    assert code in (0, 1), err
    warned = _warned(js)
    assert len(warned) == 1 and warned[0].startswith("the fit record (")
    fc = js["sensor_highpass_check"]["corner_hz"]
    assert js["sensor_highpass_check"]["evident"] and 0.4 / 1.5 < fc < 0.4 * 1.5
    assert f"--sensor-highpass {fc:.2g}" in warned[0]
    code, null, err = _diagnose([_csv(tmp_path, None, seed) for seed in (0, 1, 2)], capsys)
    assert code in (0, 1), err
    assert not _warned(null) and null["sensor_highpass_check"]["evident"] is False
