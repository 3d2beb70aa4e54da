"""``station replay``: the pipeline rerun on saved captures, and the counts streamed through the device."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from drivers.channels import ChannelInfo
from simulated_rig.errors import RigError
from station.cli import main
from simulated_rig.replay import ReplaySource
from station.commands.replay import stream_through_device
from station.storage import read_capture
from tests.station.test_demo import demo_run


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def _channels(n: int) -> tuple[ChannelInfo, ...]:
    return tuple(ChannelInfo(name=f"c{i}", quantity="force", unit="N", scale=1e-3, offset=0.0, range_si=8e3,
                             adc_bits=24, sensitivity=1.0, sensitivity_unit="mV/N") for i in range(n))


def test_replay_source_serves_the_stored_counts_then_zeros() -> None:
    counts = np.arange(20, dtype=np.int32).reshape(10, 2) - 7
    src = ReplaySource(counts, _channels(2), 1000.0)
    a = src.read(4)
    b = src.read(10)
    np.testing.assert_array_equal(np.vstack([a, b[:6]]), counts)
    np.testing.assert_array_equal(b[6:], 0)
    assert a.dtype == np.int32 and src.sample_index == 14
    src.configure(rate_hz=1000.0)  # the stored rate: restarts
    np.testing.assert_array_equal(src.read(3), counts[:3])
    with pytest.raises(RigError, match="recorded at 1000 Hz"):
        src.configure(rate_hz=2000.0)
    with pytest.raises(RigError, match="cannot take a new impact"):
        src.deliver_impact(100.0)
    with pytest.raises(RigError, match=r"shape \(n, 3\)"):
        ReplaySource(counts, _channels(3), 1000.0)


def test_replay_through_device_is_bit_exact_and_reruns_the_pipeline(capsys: pytest.CaptureFixture[str]) -> None:
    demo, demo_obj = demo_run()
    session = demo / "session.h5"
    code, out, err = _run(["replay", str(session), "--through-device", "--json",
                           "--stiffness", "x,x^2,x^3,x^4,x^5", "--refine"], capsys)
    assert code == 0, err
    obj = json.loads(out)
    assert obj["bit_exact"] is True
    assert [c["capture"] for c in obj["through_device"]] == [0, 1, 2]
    for c in obj["through_device"]:
        assert c["samples"] == read_capture(session, c["capture"]).n_samples
        assert c["mismatched_samples"] == 0 and c["dropped_samples"] == 0 and c["crc_errors"] == 0
        assert c["transport_url"].startswith("serial:///dev/pts/")
    # the pipeline rerun gives the demo's model to the last bit
    assert obj["identified"]["stiffness"] == demo_obj["identified"]["stiffness"]
    assert obj["identified"]["damping"] == demo_obj["identified"]["damping"]
    assert obj["validation"]["nrmse"] == demo_obj["validation"]["nrmse"]


def test_a_corrupted_stream_is_caught(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    demo, _ = demo_run()
    original = ReplaySource.read

    def flip_one(self: ReplaySource, n: int) -> np.ndarray:
        k = self.sample_index
        out = original(self, n)
        if k <= 5000 < k + n:
            out[5000 - k, 1] ^= 1  # one bit of one count
        return out

    monkeypatch.setattr(ReplaySource, "read", flip_one)
    check = stream_through_device(str(demo / "session.h5"), 2)
    assert not check.bit_exact and check.mismatched_samples == 1
    code, out, _ = _run(["replay", str(demo / "session.h5:2"), "--through-device"], capsys)
    assert code == 1 and "1 samples differ" in out


def test_replay_without_device_on_one_capture(capsys: pytest.CaptureFixture[str]) -> None:
    demo, _ = demo_run()
    code, out, err = _run(["replay", str(demo / "session.h5:1")], capsys)
    assert code == 0, err
    assert "identified on" in out and "validated on itself" in out


def test_imported_si_capture_cannot_go_through_the_device(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from station.readers import read_measurement
    from station.storage import CaptureWriter, import_measurement
    from tests.conftest import REPO

    h5 = tmp_path / "imported.h5"
    import_measurement(CaptureWriter(h5), read_measurement(str(REPO / "station" / "examples" / "duffing-impact.csv")))
    code, out, err = _run(["replay", str(h5), "--through-device"], capsys)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "not raw counts" in err


@pytest.mark.parametrize("spec, expect", [
    ("{demo}/session.h5:4", "expected an index 0..2"),
    ("{tmp}/junk.h5", "expected an HDF5 file"),
    ("{tmp}/none.h5", "no such file"),
])
def test_replay_faults_are_one_line_exit_2(spec: str, expect: str, capsys: pytest.CaptureFixture[str],
                                          tmp_path: Path) -> None:
    demo, _ = demo_run()
    (tmp_path / "junk.h5").write_text("junk")
    code, out, err = _run(["replay", spec.format(demo=demo, tmp=tmp_path), "--through-device"], capsys)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and expect in err and "Traceback" not in err


def test_replay_ctrl_c_exits_130(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    import station.commands.replay as replay

    demo, _ = demo_run()

    def interrupted(*a: Any, **k: Any) -> Any:
        raise KeyboardInterrupt

    monkeypatch.setattr(replay, "stream_through_device", interrupted)
    code, _, err = _run(["replay", str(demo / "session.h5"), "--through-device"], capsys)
    assert code == 130 and err.count("\n") == 1 and "interrupted" in err
