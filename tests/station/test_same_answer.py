"""The same record through every command gives the same model, error and warnings.

``tests/station/test_one_pipeline.py`` holds the coefficients and held-out errors of identify,
replay, report, demo and diagnose's baseline together; here what the campaign's workers run
(``station.campaign.tasks.run_capture``, in this process: the Dask path is
tests/station/test_campaign.py's) and the warnings that are not the pipeline's own.
"""

from __future__ import annotations

import contextlib
import html
import io
import json
from pathlib import Path
from typing import Any

from station.campaign.sources import CaptureRef
from station.campaign.tasks import TaskOptions, run_capture
from station.cli import main
from tests.station.test_demo import demo_run
from tests.station.test_sensor_highpass import MASS, _csv


def _json(argv: list[str]) -> dict[str, Any]:
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(argv + ["--json"])
    assert code == 0, argv
    return json.loads(buf.getvalue())


def _coupling(warnings: list[str]) -> list[str]:
    return [w for w in warnings if "AC-coupled" in w]


def test_undeclared_coupling_is_warned_by_every_command_that_identifies(tmp_path: Path) -> None:
    # a 0.4 Hz IEPE coupling on a 4 Hz, 500 kg structure: identify warned, replay, report and a
    # campaign said nothing of it (fails without the shared check, station.coupling)
    path = str(_csv(tmp_path, 0.4))
    ident = _json(["identify", path, "--mass", str(MASS)])
    replay = _json(["replay", path, "--mass", str(MASS)])["identified"]
    report = _json(["report", path, "--mass", str(MASS), "--out", str(tmp_path / "rep")])
    row = run_capture(CaptureRef(path), TaskOptions(mass=MASS))
    assert row["status"] == "ok", row["error"]
    warned = _coupling(ident["warnings"])
    assert len(warned) == 1 and "--sensor-highpass 0.41" in warned[0]
    assert replay["warnings"] == ident["warnings"]
    assert report["identified"]["warnings"] == ident["warnings"]
    assert row["warnings"] == ident["warnings"]
    assert replay["conditioning"]["sensor_highpass_estimate_hz"] == ident["conditioning"]["sensor_highpass_estimate_hz"]
    assert html.escape(warned[0]) in (tmp_path / "rep" / "index.html").read_text()  # the page says it too
    # declared (stored with the capture by station import): checked by none
    h5 = str(tmp_path / "told.h5")
    assert main(["import", path, "--out", h5, "--mass", str(MASS), "--sensor-highpass", "0.4"]) == 0
    told = _json(["replay", h5])["identified"]
    assert not _coupling(told["warnings"]) and "sensor_highpass_check" not in told["conditioning"]
    assert not _coupling(run_capture(CaptureRef(h5, 0), TaskOptions())["warnings"])


def test_campaign_diagnose_row_is_station_diagnose() -> None:
    # the campaign diagnosed with its own defaults (no pipeline baseline, no chain tolerance):
    # on the demo's middle capture `station campaign --task diagnose` gave an extended model with
    # nrmse 0.047 where `station diagnose` gives 0.0090 (= station identify's), and with the
    # options' defaults left empty (as here) an error row; now the command's own function
    # (fails without)
    demo, _ = demo_run()
    h5 = str(demo / "session.h5")
    cli = _json(["diagnose", f"{h5}:1"])
    row = run_capture(CaptureRef(h5, 1), TaskOptions(task="diagnose"))
    assert row["status"] == "ok", row["error"]
    assert row["cause"] == cli["cause"]
    assert row["nrmse"] == cli["extended"]["nrmse"]
    assert row["gain"] == cli["gain"]
    ext = cli["extended"]["model"]
    assert row["coefficients"] == {**{f"b[{t}]": c for t, c in ext["damping"].items()},
                                   **{f"k[{t}]": c for t, c in ext["stiffness"].items()}}
    assert row["unstable"] == cli["unstable"]
    assert row["warnings"] == [*cli["warnings"], *cli["notes"]]
    ident = _json(["identify", f"{h5}:1"])
    assert cli["cause"] != "none" or row["nrmse"] == ident["validation"]["nrmse"]
