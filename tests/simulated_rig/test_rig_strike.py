"""Striking a served rig without a terminal: the serve process's control socket and `station rig strike`."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from simulated_rig.device import EmulatedDaq, PatternSource
from simulated_rig.errors import RigError
from simulated_rig.serve import PtyServer, strike
from station.cli import main

REPO = Path(__file__).resolve().parents[2]


def test_strike_reaches_the_served_rig_and_a_bad_blow_is_refused(tmp_path: Path) -> None:
    source = PatternSource(n_channels=2)
    control = str(tmp_path / "rig.ctl")
    with PtyServer(EmulatedDaq(source), control=control):
        assert strike(control, 300.0) == 0  # nothing streamed yet: device sample 0
        assert strike(control, 40.0, double_hit=True) == 0
        with pytest.raises(RigError, match="refused the blow: impact peak force must be positive, got -5.0 N"):
            strike(control, -5.0)
    assert source.impacts == [(0, 300.0, False), (0, 40.0, True)]
    assert not os.path.exists(control)  # the server removes its socket


def test_strike_with_nothing_served_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["rig", "strike", "--control", str(tmp_path / "none.ctl"), "--force-n", "100"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no rig answers there" in err and "station rig serve --control" in err
    assert main(["rig", "strike", "--control", str(tmp_path / "none.ctl"), "--force-n", "-1"]) == 2
    assert "--force-n: expected a finite force > 0 N" in capsys.readouterr().err


def test_a_control_path_holding_another_file_is_never_replaced(tmp_path: Path) -> None:
    keep = tmp_path / "notes.txt"
    keep.write_text("mine")
    with pytest.raises(RigError, match="exists and is not a socket; refusing to replace it"):
        PtyServer(EmulatedDaq(PatternSource()), control=str(keep))
    assert keep.read_text() == "mine"
    live = str(tmp_path / "live.ctl")
    with PtyServer(EmulatedDaq(PatternSource()), control=live):
        with pytest.raises(RigError, match="another rig serves there"):
            PtyServer(EmulatedDaq(PatternSource()), control=live)
        assert strike(live, 10.0) == 0  # the first server still owns its socket


@pytest.mark.slow
@pytest.mark.skipif(not os.environ.get("STATION_TOUR"), reason="the whole tour takes minutes: STATION_TOUR=1 (CI)")
def test_the_tour_runs_from_an_empty_directory(tmp_path: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(REPO), "STATION": f"{sys.executable} -m station.cli"}
    res = subprocess.run(["bash", str(REPO / "examples" / "tour.sh")], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=1800)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    assert "tour done" in res.stdout
    for made in ("demo-out/model.json", "session.h5", "extended.json", "report/index.html", "session.uff",
                 "imported.h5", "served.h5"):
        assert (tmp_path / made).exists(), made


def test_a_rig_process_that_cannot_start_says_why_in_one_line() -> None:
    from simulated_rig.serve import RigProcess

    rig = RigProcess("no-such-system")
    with pytest.raises(RigError, match=r"the simulated rig 'no-such-system' did not start: rig: error: .*unknown system"):
        rig.wait_ready(timeout_s=120)
    rig.close()  # idempotent
