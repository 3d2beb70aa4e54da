"""Multi-channel captures are matched by channel name, never by column position: a logger or a
spreadsheet that writes the same channels in another order gives the same diagnosis."""

from __future__ import annotations

import csv

import numpy as np

from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test
from station.mdof_data import condition_all
from station.readers import read_measurement

PAIR = MdofSystem(name="pair", masses_kg=(0.9, 0.3), driving_point=1,
                  elements=(Element(between=(0, 1), k=1.5e4, c=0.9), Element(between=(1, 2), k=1.0e4, c=0.4)),
                  impacts_n=(40.0, 100.0))


def _reorder(src, dst, order: list[str]) -> None:
    with open(src, newline="") as fh:
        rows = list(csv.reader(fh))
    idx = [rows[0].index(name) for name in order]
    with open(dst, "w", newline="") as fh:
        csv.writer(fh).writerows([[row[i] for i in idx] for row in rows])


def test_the_same_channels_in_another_column_order_are_matched_by_name(tmp_path) -> None:
    a = mdof_impact_test(PAIR, 40.0, seed=3, record_s=1.0).write_csv(tmp_path / "a.csv")
    b = mdof_impact_test(PAIR, 100.0, seed=4, record_s=1.0).write_csv(tmp_path / "b.csv")
    header = open(b).readline().strip().split(",")
    assert header[-2:] == ["acc1", "acc2"]
    swapped = tmp_path / "b-swapped.csv"
    _reorder(b, swapped, [*header[:-2], "acc2", "acc1"])  # the logger wrote acc2 first
    straight, names, dp = condition_all([read_measurement(str(a)), read_measurement(str(b))])
    crossed, names2, dp2 = condition_all([read_measurement(str(a)), read_measurement(str(swapped))])
    assert names == names2 == ("acc1", "acc2") and dp == dp2 == "acc1"
    np.testing.assert_array_equal(crossed[1].a, straight[1].a)  # acc1's row is acc1's data
    assert not np.allclose(crossed[1].a[0], crossed[1].a[1])


def test_validate_matches_a_models_channels_by_name(tmp_path, capsys) -> None:
    import json

    from station.cli import main

    b = mdof_impact_test(PAIR, 100.0, seed=4, record_s=2.0).write_csv(tmp_path / "b.csv")
    header = open(b).readline().strip().split(",")
    swapped = tmp_path / "b-swapped.csv"
    _reorder(b, swapped, [*header[:-2], "acc2", "acc1"])
    model = tmp_path / "m.json"
    model.write_text(PAIR.model().to_json())
    got = []
    for path in (b, swapped):
        assert main(["validate", str(model), str(path), "--json"]) == 0
        got.append(json.loads(capsys.readouterr().out)["channel_nrmse"])
    assert got[0] == got[1] and got[0]["acc1"] < 0.05
