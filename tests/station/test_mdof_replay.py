"""``station replay`` on multi-channel captures: identify on all but the last, predict every channel."""

from __future__ import annotations

import json

from simulated_rig.mdof_systems import load_mdof_system, mdof_impact_test
from station.session_writer import CaptureWriter
from station.cli import main


def test_replay_of_a_multichannel_session_predicts_every_channel_held_out(tmp_path, capsys):
    system = load_mdof_system("two-mass-cubic")
    out = tmp_path / "s.h5"
    with CaptureWriter(out) as w:
        for k, peak in enumerate((40.0, 150.0, 300.0, 200.0)):  # the last (200 N) is held out
            rec = mdof_impact_test(system, peak, seed=20 + k, record_s=2.0)
            cols = rec.columns()
            w.append_si({name: cols[name] for name in ("force", "acc1", "acc2")}, rec.rate_hz,
                        rec.pretrigger_samples, extra={"driving_point": "acc1"})
    assert main(["replay", str(out), "--json"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["model_kind"] == "mdof" and obj["channels"] == ["acc1", "acc2"]
    assert [r["role"] for r in obj["records"]] == ["train"] * 3 + ["held out"]
    held = obj["records"][3]
    assert set(held["channel_nrmse"]) == {"acc1", "acc2"} and not held["diverged"]
    assert max(held["channel_nrmse"].values()) < 0.1  # the coupled chain predicted, no mass given
    assert abs(obj["masses_kg"][0] - 1.0) < 0.05 and abs(obj["masses_kg"][1] - 0.5) < 0.03
    assert main(["replay", str(out)]) == 0  # the people's text says held out, per channel
    text = capsys.readouterr().out
    assert "held out" in text and "acc2" in text and "no mass given" in text
    rep = tmp_path / "rep"
    assert main(["report", str(out), "--out", str(rep), "--json"]) == 0  # one panel per channel
    robj = json.loads(capsys.readouterr().out)
    assert len(robj["figures"]) == 4 and all((rep / f"capture-{k}.png").stat().st_size > 5000 for k in range(4))
    page = (rep / "index.html").read_text()
    assert page.count("<tr>") == 5 and "held out" in page and "acc2" in page
    assert robj["records"][3]["channel_nrmse"] == held["channel_nrmse"]  # the same model as replay


def test_replay_of_one_multichannel_capture_says_it_validated_on_itself(tmp_path, capsys):
    rec = mdof_impact_test(load_mdof_system("two-mass-cubic"), 200.0, seed=3, record_s=2.0)
    path = rec.write_csv(tmp_path / "one.csv")
    assert main(["replay", str(path), "--json"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["records"][0]["role"].startswith("train (single capture")
    assert obj["held_out_nrmse"] is None
