"""``station diagnose`` / ``validate`` on multi-channel captures check the driving point against the
signs of every channel's modal constants (eddi.mdof.collocation): a pair struck at mass 2."""

from __future__ import annotations

import json

from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test
from station.cli import main

PAIR = MdofSystem(name="pair", masses_kg=(0.9, 0.3), driving_point=2,
                  elements=(Element(between=(0, 1), k=1.5e4, c=0.9), Element(between=(1, 2), k=1.0e4, c=0.4)),
                  impacts_n=(40.0, 100.0, 200.0))


def _captures(tmp_path) -> list[str]:
    return [str(mdof_impact_test(PAIR, peak, seed=30 + k, record_s=2.0).write_csv(tmp_path / f"p{k}.csv"))
            for k, peak in enumerate(PAIR.impacts_n)]


def test_default_driving_point_off_the_hammer_is_warned_naming_the_struck_channel(tmp_path, capsys):
    files = _captures(tmp_path)
    assert main(["diagnose", *files, "--json", "--no-refine"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["driving_point"] == "acc1"  # the default: the first response channel
    dp = [w for w in obj["warnings"] if "driving point" in w]
    assert len(dp) == 1 and dp[0].startswith("the records point to acc2 as the driving point")
    assert "acc1, the default" in dp[0] and "check --driving-point" in dp[0]
    assert obj["unstable"] is False  # a warning about the declaration, not a flagged model
    assert main(["diagnose", *files, "--json", "--no-refine", "--driving-point", "acc2"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert not [w for w in obj["warnings"] if "driving point" in w]  # declared right: silence


def test_validate_warns_on_a_models_wrong_driving_point_and_is_silent_on_the_right_one(tmp_path, capsys):
    files = _captures(tmp_path)
    right, wrong = tmp_path / "right.json", tmp_path / "wrong.json"
    right.write_text(PAIR.model().to_json())
    wrong.write_text(PAIR.model_copy(update={"driving_point": 1}).model().to_json())
    assert main(["validate", str(right), files[0], "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["warnings"] == []
    main(["validate", str(wrong), files[0], "--json"])
    w = json.loads(capsys.readouterr().out)["warnings"]
    assert len(w) == 1 and "point to acc2" in w[0] and "acc1, the model's," in w[0]
    main(["validate", str(wrong), files[0]])
    assert "WARNING: the records point to acc2" in capsys.readouterr().out


def test_replay_carries_the_warning(tmp_path):
    from station.mdof_replay import replay_mdof_object, replay_mdof_text
    from station.readers import read_measurement

    obj = replay_mdof_object([read_measurement(f) for f in _captures(tmp_path)])
    assert obj["driving_point"] == "acc1" and len(obj["warnings"]) == 1
    assert "point to acc2" in obj["warnings"][0] and "acc1, the default" in obj["warnings"][0]
    assert "WARNING: the records point to acc2" in replay_mdof_text(obj)
    right = replay_mdof_object([read_measurement(f) for f in _captures(tmp_path)], driving_point="acc2")
    assert right["warnings"] == []
