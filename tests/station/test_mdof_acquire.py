"""N accelerometers live: the MDOF rig in its own process on a pty -> ``station acquire`` -> HDF5 with
N response channels and the driving point -> ``station diagnose`` / ``validate`` with no mass given."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from station.capture import _driving_point
from station.cli import main
from station.config import parse_config
from station.errors import ConfigError
from station.mdof_data import resolve_driving_point
from station.storage import CaptureWriter, check_file, read_capture, read_measurement

REPO = Path(__file__).resolve().parents[2]


def test_n_accelerometers_from_the_rig_on_a_pty_to_a_model(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "s.h5"
    res = subprocess.run([sys.executable, "-m", "station.cli", "acquire", "--device", "sim://two-mass-cubic?seed=2",
                          "--impacts", "3", "--out", str(out), "--json"],
                         capture_output=True, text=True, cwd=REPO, timeout=300)
    assert res.returncode == 0, res.stderr[-800:]
    assert json.loads(res.stdout)["captures"] == 3 and check_file(out) == 3
    cap = read_capture(out, 1)
    assert list(cap.channels) == ["force", "acc1", "acc2"]  # one force + N = 2 accelerometers, raw counts kept
    assert cap.attrs["driving_point"] == "acc1" and cap.mass_kg is None
    assert cap.device["transport_url"].startswith("serial:///dev/pts/")  # the rig's own pty
    meas = read_measurement(out, "1")
    assert meas.metadata["driving_point"] == "acc1" and set(meas.channels) == {"force", "acc1", "acc2"}
    specs = [f"{out}:{i}" for i in range(3)]
    model = tmp_path / "m.json"
    assert main(["diagnose", *specs, "--no-refine", "--json", "--save-model", str(model)]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["channels"] == ["acc1", "acc2"] and obj["driving_point"] == "acc1"
    assert obj["cause"] == "modal_coupling"  # the rig's cubic coupling spring
    saved = json.loads(model.read_text())
    # no mass given: the modal masses come out of the driving-point force, positive and finite
    assert all(np.isfinite(m) and m > 0 for m in saved["mass"])
    assert main(["validate", str(model), specs[0], "--json"]) == 0
    val = json.loads(capsys.readouterr().out)
    assert set(val["channel_nrmse"]) == {"acc1", "acc2"}
    assert max(val["channel_nrmse"].values()) < 0.2


def test_driving_point_precedence_and_refusal() -> None:
    from drivers.channels import ChannelInfo

    chans = (ChannelInfo("force", "force", "N", 0.01), ChannelInfo("acc1", "acceleration", "m/s^2", 0.001),
             ChannelInfo("acc2", "acceleration", "m/s^2", 0.001))
    rig = json.dumps({"driving_point": "acc1"})
    assert _driving_point(parse_config({}), chans, 0, rig) == "acc1"  # the simulated rig's
    assert _driving_point(parse_config({}), chans, 0, None) is None  # a real bench that names none
    cfg = parse_config({"specimen": {"driving_point": "acc2"}})
    assert _driving_point(cfg, chans, 0, rig) == "acc2"  # the configuration (--driving-point) wins
    with pytest.raises(ConfigError, match="acc9"):
        _driving_point(parse_config({"specimen": {"driving_point": "acc9"}}), chans, 0, rig)
    with pytest.raises(ConfigError):
        _driving_point(parse_config({"specimen": {"driving_point": "force"}}), chans, 0, rig)


def test_a_stored_driving_point_is_what_a_replayed_capture_uses(tmp_path: Path) -> None:
    t = np.arange(2048) / 1024.0
    out = tmp_path / "imp.h5"
    with CaptureWriter(out) as w:
        w.append_si({"force": np.zeros_like(t), "acc1": np.sin(60 * t), "acc2": np.cos(90 * t)}, 1024.0,
                    extra={"driving_point": "acc2"})
        w.append_si({"force": np.zeros_like(t), "acc1": np.sin(60 * t), "acc2": np.cos(90 * t)}, 1024.0)
    stored, plain = read_measurement(out, "0"), read_measurement(out, "1")
    assert resolve_driving_point(stored, None) == "acc2"
    assert resolve_driving_point(plain, None) == "acc1"  # none stored: the first response channel
    assert resolve_driving_point(stored, "acc1") == "acc1"  # --driving-point overrides
