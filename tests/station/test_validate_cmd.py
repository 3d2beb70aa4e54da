"""``station validate MODEL.json CAPTURE...``: force-driven and free-response validation, modal sums, faults."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from eddi.multimode import load_any_model, predict_record
from station.cli import main
from station.demo import rig_truth
from station.readers import read_measurement
from tests.conftest import REPO
from tests.station.test_demo import demo_run

MODAL = REPO / "models" / "double_beam_two_mode.json"
BEAM = REPO / "tests" / "data" / "resonant-double-beam"


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_true_rig_model_reproduces_every_capture_driven_by_its_force(capsys: pytest.CaptureFixture[str],
                                                                      tmp_path: Path) -> None:
    demo, _ = demo_run()
    truth = rig_truth(demo / "session.h5")
    assert truth is not None and truth.stiffness["x"] == 390.0  # paper Eq. 22
    good = tmp_path / "truth.json"
    good.write_text(truth.to_json())
    off = tmp_path / "off.json"  # k1 5 % too stiff
    off.write_text(truth.model_copy(update={"stiffness": {**truth.stiffness, "x": 1.05 * 390.0}}).to_json())
    code, out, err = _run(["validate", str(good), str(demo / "session.h5"), "--json"], capsys)
    assert code == 0, err
    obj = json.loads(out)
    assert obj["model_kind"] == "equation_of_motion" and obj["compared"] == "displacement"
    assert [r["source"] for r in obj["records"]] == [f"{demo / 'session.h5'}:{i}" for i in range(3)]
    assert all(r["driven_by"] == "force" for r in obj["records"])
    nrmse = [r["nrmse"] for r in obj["records"]]
    assert max(nrmse) < 0.03  # the rig's own physics, through sensor noise and ADC
    assert obj["nrmse"] == pytest.approx(np.mean(nrmse), rel=1e-12)
    assert obj["nmte"] == pytest.approx(np.mean([r["nmte"] for r in obj["records"]]), rel=1e-12)
    code, out, _ = _run(["validate", str(off), str(demo / "session.h5:0"), str(demo / "session.h5:2"), "--json"],
                        capsys)
    worse = [r["nrmse"] for r in json.loads(out)["records"]]
    assert worse[0] > 5 * nrmse[0] and worse[1] > 5 * nrmse[2]


def test_modal_sum_model_on_velocity_records_reports_nrmse_and_nmte(capsys: pytest.CaptureFixture[str]) -> None:
    files = [BEAM / "ringdown-01.csv", BEAM / "ringdown-05.csv"]
    code, out, err = _run(["validate", str(MODAL), *map(str, files), "--json"], capsys)
    assert code == 0, err
    obj = json.loads(out)
    assert obj["model_kind"] == "modal_sum" and obj["compared"] == "velocity"
    model = load_any_model(MODAL.read_text())
    expected = []
    for f, rec in zip(files, obj["records"]):
        m = read_measurement(str(f))
        e = predict_record(model, m.t, m.channels["vel"]).errors
        # nmte = mean |v_pred - v| / max |v|
        assert rec["nmte"] == pytest.approx(e.nmte, rel=1e-12) and rec["nrmse"] == pytest.approx(e.nrmse, rel=1e-12)
        assert rec["driven_by"] == "initial state" and rec["peak_force_n"] is None
        expected.append(e)
    assert obj["nmte"] == pytest.approx(np.mean([e.nmte for e in expected]), rel=1e-12)
    assert obj["nrmse"] == pytest.approx(np.mean([e.nrmse for e in expected]), rel=1e-12)
    assert obj["nmte"] < 0.05  # the two-mode model follows the measured ring-downs
    code, text, _ = _run(["validate", str(MODAL), str(files[0])], capsys)
    assert code == 0 and f"nmte {expected[0].nmte:.4g}" in text and "mean over 1 record(s)" in text


def test_equation_of_motion_on_a_record_without_force_starts_from_its_state(capsys: pytest.CaptureFixture[str],
                                                                             tmp_path: Path) -> None:
    from eddi.model import EquationOfMotion
    from eddi.simulate import simulate

    eom = EquationOfMotion.create(mass=1.0, damping={"v": 0.4}, stiffness={"x": 400.0, "x^3": 2.0e6})
    rate = 2000.0
    t = np.arange(int(6 * rate)) / rate
    sim = simulate(eom, t, x0=0.01, v0=0.0)
    csv = tmp_path / "free.csv"
    np.savetxt(csv, np.column_stack([t, sim.x, sim.v]), delimiter=",", header="t,disp,vel", comments="")
    model = tmp_path / "m.json"
    model.write_text(eom.to_json())
    code, out, err = _run(["validate", str(model), str(csv), "--json"], capsys)
    assert code == 0, err
    rec = json.loads(out)["records"][0]
    assert rec["driven_by"] == "initial state"
    assert rec["nmte"] is not None and rec["nmte"] < 0.01 and rec["nrmse"] < 0.02


@pytest.mark.parametrize("model_text, record, expect", [
    (None, "{demo}/session.h5:9", "expected an index 0..2"),
    (None, "{tmp}/garbage.h5", "expected an HDF5 file"),
    (None, "{tmp}/nothing.csv", "no such file"),
    ('{"mass": ', "{demo}/session.h5:0", "model is not valid JSON"),
    ('{"mass": -1, "damping": {}, "stiffness": {"x": 1}}', "{demo}/session.h5:0", "m.json"),
    ('[1, 2]', "{demo}/session.h5:0", "must be an object"),
    ("MISSING", "{demo}/session.h5:0", "no such model file"),
    # incomplete model files: no restoring force (these exited 0 with a meaningless nrmse)
    ('{"mass": 1}', "{demo}/session.h5:0", "no stiffness terms and no effects"),
    ('{"mass": 1, "damping": {}, "stiffness": {}}', "{demo}/session.h5:0", "no stiffness terms"),
    ('{"mass": 1, "damping": {"v": 0.1}}', "{demo}/session.h5:0", "no stiffness terms"),
    ('{"equation_of_motion": {"mass": 0.8}}', "{demo}/session.h5:0", "no stiffness terms"),
    ('{"mass": 1, "stiffness": {"x": "abc"}}', "{demo}/session.h5:0", "stiffness.x"),
    ('{"mass": 1, "stiffness": {"q^2": 1}}', "{demo}/session.h5:0", "m.json"),
    # numbers written as strings: a damaged file, not a value to guess at (these were converted)
    ('{"mass": "0.7", "stiffness": {"x": 100}}', "{demo}/session.h5:0", "mass: Input should be a valid number"),
    ('{"mass": 1, "stiffness": {"x": "100"}}', "{demo}/session.h5:0", "stiffness.x"),
])
def test_validate_faults_are_one_line_exit_2(model_text: str | None, record: str, expect: str,
                                            capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    demo, _ = demo_run()
    (tmp_path / "garbage.h5").write_bytes(b"\x00" * 64)
    model = tmp_path / "m.json"
    if model_text is None:
        model = demo / "model.json"
    elif model_text != "MISSING":
        model.write_text(model_text)
    code, out, err = _run(["validate", str(model), record.format(demo=demo, tmp=tmp_path)], capsys)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("station: error:") and expect in err and "Traceback" not in err
    assert out == ""


def test_validate_ctrl_c_exits_130(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    import station.session

    demo, _ = demo_run()

    def interrupted(*a: Any, **k: Any) -> Any:
        raise KeyboardInterrupt

    monkeypatch.setattr(station.session, "validate_measurement", interrupted)
    code, _, err = _run(["validate", str(demo / "model.json"), str(demo / "session.h5")], capsys)
    assert code == 130 and err.count("\n") == 1 and "interrupted" in err
