"""Schema v2 metadata (t0, sensors, typed attributes), old files still read, SEP-005 and UFF exports."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path

import h5py
import numpy as np
import pyuff
import pytest

from station.cli import main
from station.config import parse_config
from station.sep005 import export_sep005, read_sep005
from station.storage import FORMAT_VERSION, CaptureWriter, iter_captures, read_capture, read_measurement
from test_storage import make_capture

SENSORS = {"force": {"sensor_model": "PCB 086C03", "sensor_serial": "SN 4711", "calibration_date": "2026-03-01",
                     "node": 7, "direction": "-Z"},
           "acc": {"sensor_model": "PCB 352C33", "node": 12, "direction": "+Y"}}
T0 = 1_795_400_000.123456  # [s since 1970 UTC]


def _session(path: Path, n: int = 3) -> list:
    caps = [make_capture(i, n=700 + 50 * i, pre=100) for i in range(n)]
    w = CaptureWriter(path)
    for i, c in enumerate(caps):
        w.append(c, mass_kg=0.815, notes=f"hit {i}", sensors=SENSORS, t0_unix_s=T0 + i,
                 device={"model": "EDDI-DAQ", "serial": "D1", "protocol_version": 1, "firmware": None},
                 rig={"scenario": "{}", "requested_double_hit": True, "requested_peak_force_n": 50.0})
    return caps


def test_v2_metadata_is_typed_and_documented(tmp_path: Path) -> None:
    path = tmp_path / "s.h5"
    _session(path, 1)
    doc = (Path(__file__).resolve().parents[2] / "docs" / "capture-format.md").read_text()
    with h5py.File(path, "r") as f:
        assert f.attrs["format_version"] == FORMAT_VERSION == 2
        g = f["captures/0000"]
        assert g.attrs["t0_unix_s"] == T0 and isinstance(g.attrs["t0_unix_s"], np.float64)
        assert dt.datetime.fromisoformat(g.attrs["t0_utc"]).timestamp() == pytest.approx(T0, abs=1e-6)
        assert isinstance(g.attrs["double_hit"], np.bool_) and isinstance(g["rig"].attrs["requested_double_hit"], np.bool_)
        assert "firmware" not in g["device"].attrs  # None is left out, never stored as "None"/"null"
        fch, ach = g["channels/force"].attrs, g["channels/acc"].attrs
        assert (fch["sensor_model"], fch["sensor_serial"], fch["calibration_date"], int(fch["node"]), fch["direction"]) \
            == ("PCB 086C03", "SN 4711", "2026-03-01", 7, "-Z")
        assert isinstance(fch["node"], np.int64) and "sensor_serial" not in ach
        # every attribute in the file is documented (name in backquotes or in the layout block)
        names = set()
        f.visititems(lambda _, o: names.update(o.attrs.keys()))
        names.update(f.attrs.keys())
    missing = sorted(n for n in names if n not in doc)
    assert missing == [], missing
    for key in ("true", "false", "True", "False"):  # no boolean stored as text anywhere
        with h5py.File(path, "r") as f:
            texts = []
            f.visititems(lambda _, o: texts.extend(v for v in o.attrs.values() if isinstance(v, str)))
            assert key not in texts


def test_version_1_files_are_still_read(tmp_path: Path) -> None:
    path = tmp_path / "old.h5"
    caps = _session(path, 2)
    with h5py.File(path, "r+") as f:  # what a version-1 writer left: no t0, sensors or session_index
        f.attrs["format_version"] = 1
        for g in f["captures"].values():
            for k in ("t0_unix_s", "t0_utc", "session_index"):
                del g.attrs[k]
            for ds in g["channels"].values():
                for k in ("sensor_model", "sensor_serial", "calibration_date", "node", "direction"):
                    if k in ds.attrs:
                        del ds.attrs[k]
    r = read_capture(path, 1)
    np.testing.assert_array_equal(r.channels["acc"].counts, caps[1].counts[:, 1])
    assert "t0_utc" not in r.attrs and r.mass_kg == 0.815
    CaptureWriter(path).append(make_capture(9, n=500, pre=50))  # appending keeps the file readable
    assert [c.index for c in iter_captures(path)] == [0, 1, 2]


def test_sensor_fields_come_from_the_bench_config() -> None:
    cfg = parse_config({"channels": [{"name": "force", "quantity": "force", "sensor_model": "PCB 086C03",
                                      "calibration_date": "2026-03-01", "node": 3, "direction": "+Z"},
                                     {"name": "acc", "quantity": "acceleration"}]})
    assert cfg.sensor_metadata() == {"force": {"sensor_model": "PCB 086C03", "calibration_date": "2026-03-01",
                                               "node": 3, "direction": "+Z"}}


def test_sep005_round_trip_is_exact(tmp_path: Path) -> None:
    path = tmp_path / "s.h5"
    caps = _session(path, 3)
    out = tmp_path / "s.json"
    assert export_sep005(path, out) == 6
    items = read_sep005(out)  # each dict validated by sdypy_sep005.Sep005Data
    assert [d["name"] for d in items[:2]] == ["s capture 0 force", "s capture 0 acc"]
    for d in items:
        i = d["capture"]
        cap = read_capture(path, i)
        ch = "force" if d["quantity"] == "f" else "acc"
        np.testing.assert_array_equal(d["data"], cap.channels[ch].si)  # bit-exact through JSON
        assert d["fs"] == 19200.0 and d["unit_str"] == {"force": "N", "acc": "m/s^2"}[ch]
        assert dt.datetime.fromisoformat(d["start_timestamp"]).timestamp() == pytest.approx(T0 + i, abs=1e-6)
        assert d["node"] == SENSORS[ch]["node"] and d["direction"] == SENSORS[ch]["direction"]
        assert d["pretrigger_samples"] == 100 and d["mass_kg"] == 0.815
    assert len(json.loads(out.read_text())[5]["data"]) == caps[2].n_samples


def test_export_command_writes_uff_and_sep005_with_nodes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "s.h5"
    _session(path, 2)
    uff, sep = tmp_path / "o.uff", tmp_path / "o.json"
    assert main(["export", f"{path}:1", "--uff", str(uff), "--sep005", str(sep), "--json"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["records"] == 2 and obj["sep005_channels"] == 2 and obj["captures"] == [1]
    sets = pyuff.UFF(str(uff)).read_sets()
    assert [(s["rsp_node"], s["rsp_dir"], s["ref_node"], s["ref_dir"]) for s in sets] == [(7, -3, 7, -3), (12, 2, 7, -3)]
    np.testing.assert_array_equal(sets[1]["data"], read_measurement(path, "1").channels["acc"])
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")] == []


def test_sep005_refuses_captures_with_gaps_and_foreign_json(tmp_path: Path) -> None:
    from station.errors import InputFileError

    path = tmp_path / "g.h5"
    CaptureWriter(path).append(make_capture(1, n=400, pre=10, gaps=((5, 3),)))
    with pytest.raises(InputFileError, match="3 samples missing"):
        export_sep005(path, tmp_path / "g.json")
    bad = tmp_path / "bad.json"
    bad.write_text('[{"name": "x", "data": [1, 2], "unit_str": "N"}]')  # neither fs nor time
    with pytest.raises(InputFileError, match="not SEP-005"):
        read_sep005(bad)
