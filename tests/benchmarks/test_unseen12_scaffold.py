"""The twelfth blind scorecard's generator and scorer (benchmarks/unseen12): file writers, draws and verdicts.

Fast checks of the scaffolding only (no station command is run): the raw-count writers keep the signal to half a
count, the German spreadsheet's numbers and the integer microsecond stamps are what the case says, the chains
have the modes and masses their case names, and the record / multi-channel scorers give the verdicts the README's
rules state for a given station answer.
"""

from __future__ import annotations

import importlib
import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).resolve().parents[2] / "benchmarks" / "unseen12"
NAMES = ("physics", "formats", "draw", "cases", "judge")


@pytest.fixture(scope="module")
def u12():
    saved = {n: sys.modules.pop(n) for n in NAMES if n in sys.modules}
    sys.path.insert(0, str(HERE))
    try:
        yield {n: importlib.import_module(n) for n in NAMES}
    finally:
        sys.path.remove(str(HERE))
        for n in NAMES:
            sys.modules.pop(n, None)
        sys.modules.update(saved)


def test_counts_csv_keeps_the_signal_to_half_a_count(u12, tmp_path):
    fm = u12["formats"]
    rng = np.random.default_rng(3)
    t = np.arange(-50, 400) / 2048.0
    acc = np.exp(-3 * t.clip(0)) * np.sin(2 * np.pi * 40 * t) * 7.5
    force = np.where((t >= 0) & (t < 0.003), 120.0, 0.0)
    path = fm.write(str(tmp_path / "c"), "csv-counts", t, {"force": force, "acc": acc}, rng)
    lines = Path(path).read_text().splitlines()
    scales = [float(ln.split(":")[1].split()[0]) for ln in lines if ln.startswith("# scale")]
    head = lines.index("Time [s],Force [counts],Acceleration [counts]")
    rows = np.array([[float(x) for x in ln.split(",")] for ln in lines[head + 1:]])
    assert len(scales) == 2 and rows.shape == (len(t), 3)
    assert np.all(np.abs(rows[:, 1:]) <= 32768) and np.all(rows[:, 1:] == np.round(rows[:, 1:]))
    assert np.abs(rows[:, 1] * scales[0] - force).max() <= scales[0] / 2 + 1e-12
    assert np.abs(rows[:, 2] * scales[1] - acc).max() <= scales[1] / 2 + 1e-12


def test_spreadsheet_numbers_and_micro_stamps(u12, tmp_path):
    fm = u12["formats"]
    assert fm._thousands(35123.4567, 3) == "35.123,457"
    assert fm._thousands(-1234567.891, 3) == "-1.234.567,891"
    assert fm._thousands(-0.0001, 3) == "0,000"
    t = (np.arange(-30, 300) + 0.0) / 5120.0
    path = fm.write(str(tmp_path / "u"), "csv-us", t, {"force": np.zeros_like(t), "acc": np.ones_like(t)},
                    np.random.default_rng(0))
    stamps = np.array([int(ln.split(",")[0]) for ln in Path(path).read_text().splitlines()[1:]])
    assert stamps[0] == 0 and np.abs(stamps - (t - t[0]) * 1e6).max() <= 0.5


@pytest.mark.parametrize("masses, n", [("close", 2), ("spread", 2), ("spread", 3)])
def test_chains_have_the_modes_and_masses_their_case_names(u12, masses, n):
    cs = u12["cases"]
    rng = np.random.default_rng(11)
    for _ in range(3):
        ms, links, grounds, K, fr, d = cs._draw_chain(rng, n, masses, "kilograms")
        assert 1 <= d < n  # the driving point is never the first mass
        if masses == "close":
            assert 1.08 <= fr[1] / fr[0] <= 1.25
        else:
            assert 8.0 <= max(ms) / min(ms) <= 14.0 and min(fr[i + 1] / fr[i] for i in range(n - 1)) > 1.35


class FakeRun:
    """Answers station commands from a table {command word: (rc, stdout, stderr)}; writes --save-model files."""

    def __init__(self, data, answers):
        self.data, self.answers, self.argvs = str(data), answers, []

    def __call__(self, argv, timeout=300):
        self.argvs.append(list(argv))
        rc, out, err = self.answers[argv[0]]
        if "--save-model" in argv:
            Path(self.data, argv[argv.index("--save-model") + 1]).write_text("{}")
        return {"cmd": " ".join(argv), "rc": rc, "wall_s": 0.1, "cpu_s": 0.1}, out, err


def _record(u12, defect):
    cs = u12["cases"]
    fmt, words, refusal, rule, reason = cs.RECORDS[defect]
    return {"id": f"rec-{defect}", "label": "F1", "files": {"fit": "f1-0.csv", "held": "f1-1.csv"},
            "truth": {"mass": 1.0, "damping": {"v": 2.0}, "stiffness": {"x": 4e4, "x^3": 1e9}}, "given_mass": 1.0,
            "meta": {"captures": [{"session": {"noise_nrmse": 0.003}}] * 2}, "warn_words": words,
            "refusal_ok": refusal, "args": [], "must_flag": defect == "swapped", "limit_cpu_s": 300}


@pytest.mark.parametrize("defect, err, verdict", [
    ("swapped", "station: error: f1-0.csv: too few zero crossings of the acceleration above the noise", "refused-detected"),
    ("counts", "station: error: f1-0.csv: column 'Force [counts]': unknown unit 'counts'", "refused-detected"),
    ("reordered", "station: error: f1-0.csv: unknown column 'Acceleration'", "REFUSED"),
    ("sample", "station: error: f1-0.csv: something went wrong", "REFUSED"),
])
def test_record_refusals(u12, tmp_path, defect, err, verdict):
    run = FakeRun(tmp_path, {"identify": (2, "", err + "\n")})
    assert u12["judge"].score_record(_record(u12, defect), run)["verdict"] == verdict
    assert run.argvs[0][:2] == ["identify", "f1-0.csv"] and "--mass" in run.argvs[0]


def test_a_swapped_record_given_a_model_without_naming_it_fails(u12, tmp_path):
    ident = {"damping": {"v": 50.0}, "stiffness": {"x": 10.0, "x^3": 0.0},
             "ci95": {"damping": {"v": 1.0}, "stiffness": {"x": 1.0, "x^3": 1.0}}, "model": {},
             "warnings": ["poor fit: the model reproduces the record with displacement nrmse 0.7"]}
    run = FakeRun(tmp_path, {"identify": (0, json.dumps(ident), ""), "validate": (0, json.dumps({"nrmse": 0.7}), "")})
    res = u12["judge"].score_record(_record(u12, "swapped"), run)
    assert res["verdict"] == "WARNED-UNNAMED"
    ident["warnings"].append("the hammer impulse over the momentum change is 0.01")
    run = FakeRun(tmp_path, {"identify": (0, json.dumps(ident), ""), "validate": (0, json.dumps({"nrmse": 0.7}), "")})
    assert u12["judge"].score_record(_record(u12, "swapped"), run)["verdict"] == "warned"


@pytest.mark.parametrize("coupling, cause, verdict", [
    ("ground-soft", "modal_coupling", "FALSE-COUPLING"), ("ground-soft", "none", "ok"),
    ("ground-soft", "unexplained", "abstained"), (None, "unexplained", "FALSE-ALARM"),
    (None, "none", "ok"), ("quadcubic", "modal_coupling", "ok"), ("quadcubic", "unexplained", "abstained"),
])
def test_multichannel_cause_rules(u12, tmp_path, coupling, cause, verdict):
    case = {"id": "mdof-x", "label": "M1", "files": {"train": ["m1-0.csv", "m1-1.csv", "m1-2.csv"],
                                                      "held": "m1-3.csv"},
            "all_files": [f"m1-{i}.csv" for i in range(4)], "driving_point": "acc2", "columns": ["acc1", "acc2"],
            "coupling": coupling, "coupling_effect_nrmse": {"acc1": 0.2, "acc2": 0.2},
            "noise_nrmse": [{"acc1": 0.003, "acc2": 0.003}] * 4, "via_h5": coupling == "ground-soft",
            "limit_cpu_s": 600}
    diag = {"cause": cause, "noise_floor": 0.01}
    val = {"nrmse": 0.02, "channel_nrmse": {"acc1": 0.02, "acc2": 0.03}}
    run = FakeRun(tmp_path, {"diagnose": (0, json.dumps(diag), ""), "validate": (0, json.dumps(val), ""),
                             "import": (0, "{}", "")})
    res = u12["judge"].score_mdof(case, run)
    assert res["verdict"] == verdict
    diag_argv = next(a for a in run.argvs if a[0] == "diagnose")
    assert diag_argv[diag_argv.index("--driving-point") + 1] == "acc2" and "--mass" not in diag_argv
    if case["via_h5"]:
        assert diag_argv[1:4] == ["score-M1.h5:0", "score-M1.h5:1", "score-M1.h5:2"]
        assert next(a for a in run.argvs if a[0] == "validate")[2] == "score-M1.h5:3"
