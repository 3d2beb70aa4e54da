"""Every bad input ends in one line on stderr and exit code 2, never a traceback (issue 11, item 6).

The cases are the table of ``docs/bad-inputs.md`` (a test checks that every case is listed
there). Each runs the CLI in-process (``station.cli.main``) on files made here; the boundary
(readers, argument types, the bench configuration, output checks) refuses them before any
numerics run, so the whole table takes seconds.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import h5py
import numpy as np
import pytest

from station.cli import main
from station.storage import CaptureWriter
from test_storage import make_capture

REPO = Path(__file__).resolve().parents[2]
RATE = 2000.0


def _ringdown(n: int = 2000, rate: float = RATE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(n) / rate
    acc = np.exp(-2 * t) * np.sin(2 * np.pi * 9.0 * t)
    force = 40.0 * np.exp(-((t - 0.02) / 0.003) ** 2)
    return t, force, acc


def _csv(path: Path, header: str, rows: np.ndarray, fmt: str = "%.17g") -> Path:
    np.savetxt(path, rows, delimiter=",", header=header, comments="", fmt=fmt)
    return path


def _session(path: Path, **attrs: object) -> Path:
    """A valid 1-capture session, then root/capture attributes changed (checksums stay valid)."""
    CaptureWriter(path).append(make_capture(1, n=400, pre=100), mass_kg=1.0)
    with h5py.File(path, "r+") as f:
        g = f["captures/0000"]
        for k, v in attrs.items():
            (f if k.startswith("root.") else g).attrs[k.removeprefix("root.")] = v
    return path


def build_files(d: Path) -> dict[str, Path]:
    """Every bad (and a few good) input file the cases use, keyed by name."""
    t, force, acc = _ringdown()
    good = np.column_stack([t, force, acc])
    files: dict[str, Path] = {}

    def csv(name: str, header: str = "t,force,acc", rows: np.ndarray | None = None, fmt: str = "%.17g") -> None:
        files[name] = _csv(d / f"{name}.csv", header, good if rows is None else rows, fmt)

    def text(name: str, body: str | bytes, suffix: str = ".csv") -> None:
        p = d / f"{name}{suffix}"
        p.write_bytes(body if isinstance(body, bytes) else body.encode())
        files[name] = p

    csv("good")
    csv("two_sensors", "t,force,acc1,acc2", good[:, [0, 1, 2, 2]])  # a multi-DOF record on a 1-DOF command
    text("empty", "")
    text("header_only", "t,force,acc\n")
    text("blank_header", "   \n1,2,3\n")
    csv("unknown_column", "t,force,pressure")
    csv("duplicate_column", "t,acc,acc", good[:, [0, 2, 2]])
    csv("no_time", "force,acc", good[:, 1:])
    csv("no_response", "t,force", good[:, :2])
    text("ragged", "t,force,acc\n" + "0,1,2\n" * 20 + "0.5,1\n")
    text("text_in_number", "t,force,acc\n" + "".join(f"{i / RATE},1,{'abc' if i == 7 else 1}\n" for i in range(40)))
    for name, col, val in [("nan_acc", 2, np.nan), ("inf_force", 1, np.inf), ("huge_acc", 2, 1e300),
                           ("acc_1e60", 2, 1e60), ("neg_huge_force", 1, -1e300), ("huge_time", 0, 1e300),
                           ("time_1e60", 0, 1e60), ("nan_time", 0, np.nan)]:
        rows = good.copy()
        rows[50, col] = val
        csv(name, rows=rows)
    rows = good.copy()
    rows[:, 2] *= 1e300
    csv("all_huge_acc", rows=rows)
    csv("time_decreasing", rows=good[::-1])
    rows = good.copy()
    rows[30, 0] = rows[29, 0]
    csv("time_repeated", rows=rows)
    csv("missing_sample", rows=np.delete(good, 100, axis=0))
    rows = good.copy()
    rows[200, 0] += 0.05 / RATE
    csv("time_jitter_5pct", rows=rows)
    csv("time_coarse_digits", rows=good, fmt="%.3g")
    csv("too_few_rows", rows=good[:10])
    rows = good.copy()
    rows[:, 0] += 1e8
    csv("time_offset_1e8", rows=rows)
    text("binary_garbage", bytes(range(256)) * 4)
    rows = good.copy()
    rows[300:320, 2] = rows[:, 2].max() + 1
    csv("clipped_acc", rows=rows)
    rows = good.copy()
    rows[:, 1] = 0.0
    csv("force_no_impact", rows=rows)
    rows = good.copy()
    rows[:, 2] = 0.0
    csv("acc_all_zero", rows=rows)
    rows = good.copy()
    rows[:, 2] = 3.0
    csv("acc_constant", rows=rows)
    text("semicolons", "t;force;acc\n" + "".join(f"{i / RATE};1;2\n" for i in range(40)))
    text("nul_bytes", "t,force,acc\n" + "0,1,2\n" + "\0" * 50)
    text("wrong_suffix", "t,acc\n0,1\n", suffix=".xlsx")
    text("no_suffix", "t,acc\n0,1\n", suffix="")
    (d / "folder.csv").mkdir()
    files["folder"] = d / "folder.csv"
    files["dollar"] = _csv(d / "ring$x^2$.csv", "t,force,acc", good)
    # HDF5
    files["session"] = _session(d / "session.h5")
    text("not_hdf5", "this is text, not HDF5\n", suffix=".h5")
    text("zero_h5", b"", suffix=".h5")
    with h5py.File(d / "foreign.h5", "w") as f:
        f["x"] = np.arange(3)
    files["foreign"] = d / "foreign.h5"
    with h5py.File(d / "captures_dataset.h5", "w") as f:
        f.attrs["format"] = "eddi-station-captures"
        f.attrs["format_version"] = 2
        f["captures"] = np.arange(3)
    files["captures_dataset"] = d / "captures_dataset.h5"
    with h5py.File(d / "no_captures.h5", "w") as f:
        f.attrs["format"] = "eddi-station-captures"
        f.attrs["format_version"] = 2
    files["no_captures"] = d / "no_captures.h5"
    with h5py.File(d / "empty_session.h5", "w") as f:
        f.attrs["format"] = "eddi-station-captures"
        f.attrs["format_version"] = 2
        f.create_group("captures")
    files["empty_session"] = d / "empty_session.h5"
    files["version_99"] = _session(d / "v99.h5", **{"root.format_version": 99})
    files["version_text"] = _session(d / "vtext.h5", **{"root.format_version": "two"})
    files["rate_zero"] = _session(d / "rate0.h5", rate_hz=0.0)
    files["rate_nan"] = _session(d / "ratenan.h5", rate_hz=np.nan)
    files["rate_negative"] = _session(d / "rateneg.h5", rate_hz=-19200.0)
    files["rate_inf"] = _session(d / "rateinf.h5", rate_hz=np.inf)
    files["order_not_json"] = _session(d / "order.h5", channel_order="force;acc")
    files["order_unknown_channel"] = _session(d / "order2.h5", channel_order='["force", "gyro"]')
    files["n_samples_wrong"] = _session(d / "nwrong.h5", n_samples=999)
    files["n_samples_negative"] = _session(d / "nneg.h5", n_samples=-5)
    files["mass_text"] = _session(d / "masstext.h5", mass_kg="heavy")
    p = _session(d / "checksum.h5")
    with h5py.File(p, "r+") as f:
        ds = f["captures/0000/channels/acc"]
        ds[5] = ds[5] + 1
    files["checksum"] = p
    p = _session(d / "encoding.h5")
    with h5py.File(p, "r+") as f:
        f["captures/0000/channels/acc"].attrs["encoding"] = "float16"
    files["encoding"] = p
    p = _session(d / "nochan.h5")
    with h5py.File(p, "r+") as f:
        del f["captures/0000/channels/acc"]
    files["missing_channel"] = p
    p = _session(d / "capgroup.h5")
    with h5py.File(p, "r+") as f:
        del f["captures/0000"]
        f["captures/0000"] = np.arange(4)
    files["capture_is_dataset"] = p
    p = d / "gaps.h5"
    CaptureWriter(p).append(make_capture(2, n=400, pre=100, gaps=((50, 5),)), mass_kg=1.0)
    files["gaps"] = p
    p = d / "si_huge.h5"
    tt, ff, aa = _ringdown(400, 19200.0)
    CaptureWriter(p).append_si({"force": ff, "acc": aa * 1e300}, 19200.0, mass_kg=1.0)
    files["si_huge"] = p
    raw = files["session"].read_bytes()
    text("truncated_h5", raw[: len(raw) // 2], suffix=".h5")
    # models and configurations
    text("model_not_json", "{ not json", suffix=".json")
    text("model_wrong_schema", json.dumps({"hello": 1}), suffix=".json")
    text("model_list", "[1, 2, 3]", suffix=".json")
    # a saved model and a SEP-005 export: JSON files of two kinds, neither replaces the other
    text("model_saved", json.dumps({"schema_version": 1, "mass": 1.0, "damping": {"v": 0.1},
                                    "stiffness": {"x": 100.0}}, indent=2), suffix=".json")
    text("model_sep005", json.dumps([{"name": "force", "data": [0.0, 1.0], "fs": 100.0}]), suffix=".json")
    configs = {
        "cfg_good": "[trigger]\nrecord_s = 2.0\n",
        "cfg_record_1e9": "[trigger]\nrecord_s = 1e9\n",
        "cfg_record_inf": "[trigger]\nrecord_s = inf\n",
        "cfg_pretrigger_nan": "[trigger]\npretrigger_s = nan\n",
        "cfg_level_zero": "[trigger]\nlevel_n = 0.0\n",
        "cfg_rate_zero": '[device]\nurl = "sim://duffing-smooth"\nrate_hz = 0\n',
        "cfg_rate_huge": '[device]\nurl = "sim://duffing-smooth"\nrate_hz = 1e300\n',
        "cfg_mass_negative": "[specimen]\nmass_kg = -2\n",
        "cfg_mass_inf": "[specimen]\nmass_kg = inf\n",
        "cfg_unknown_field": "[trigger]\nrecrod_s = 4\n",
        "cfg_bad_toml": "[trigger\nrecord_s = 4\n",
        "cfg_bad_slope": '[trigger]\nslope = "up"\n',
        "cfg_bad_url": '[device]\nurl = "duffing"\n',
        "cfg_duplicate_channel": '[[channels]]\nname = "f"\nquantity = "force"\n[[channels]]\nname = "f"\nquantity = "force"\n',
        "cfg_bad_quantity": '[[channels]]\nname = "f"\nquantity = "torque"\n',
        "cfg_bad_direction": '[[channels]]\nname = "force"\nquantity = "force"\ndirection = "up"\n',
        "cfg_bad_date": '[[channels]]\nname = "force"\nquantity = "force"\ncalibration_date = "yesterday"\n',
        "cfg_negative_node": '[[channels]]\nname = "force"\nquantity = "force"\nnode = -1\n',
        "cfg_bad_terms": '[identify]\ndamping = ["q^2"]\n',
        "cfg_peak_order": "[simulation]\npeak_force_n = [100.0, 10.0]\n",
    }
    for name, body in configs.items():
        text(name, body, suffix=".toml")
    files["missing"] = d / "missing.csv"
    files["missing_h5"] = d / "missing.h5"
    files["missing_dir"] = d / "no-such-folder"
    return files


def _f(name: str) -> str:
    return "{" + name + "}"


G, S = _f("good"), _f("session")
#: (case id, argv with {file} placeholders). Every id is a row of docs/bad-inputs.md.
CASES: list[tuple[str, list[str]]] = [
    # -- CSV content (station identify FILE)
    *[(f"csv-{n}", ["identify", _f(n), "--mass", "1"]) for n in [
        "empty", "header_only", "blank_header", "unknown_column", "duplicate_column", "no_time", "no_response",
        "ragged", "text_in_number", "nan_acc", "inf_force", "huge_acc", "acc_1e60", "neg_huge_force", "huge_time",
        "time_1e60", "nan_time", "all_huge_acc", "time_decreasing", "time_repeated", "missing_sample",
        "time_jitter_5pct", "time_coarse_digits", "time_offset_1e8", "too_few_rows", "binary_garbage", "clipped_acc", "acc_all_zero",
        "acc_constant", "semicolons", "nul_bytes", "wrong_suffix", "no_suffix", "folder", "missing"]],
    ("csv-capture-on-csv", ["identify", G + ":3", "--mass", "1"]),
    ("csv-force-no-impact", ["identify", _f("force_no_impact"), "--mass", "1"]),
    ("csv-two-sensors-identify", ["identify", _f("two_sensors"), "--mass", "1"]),
    ("csv-two-sensors-replay", ["replay", _f("two_sensors"), "--mass", "1"]),
    # -- HDF5 content (station identify FILE.h5[:N])
    *[(f"h5-{n}", ["identify", _f(n)]) for n in [
        "not_hdf5", "zero_h5", "foreign", "captures_dataset", "no_captures", "empty_session", "version_99",
        "version_text", "rate_zero", "rate_nan", "rate_negative", "rate_inf", "order_not_json",
        "order_unknown_channel", "n_samples_wrong", "n_samples_negative", "mass_text", "checksum", "encoding",
        "missing_channel", "capture_is_dataset", "gaps", "si_huge", "truncated_h5", "missing_h5"]],
    ("h5-index-out-of-range", ["identify", S + ":7"]),
    ("h5-index-negative-out-of-range", ["identify", S + ":-9"]),
    ("h5-index-not-a-number", ["identify", S + ":first"]),
    ("h5-captures-dataset-export", ["export", _f("captures_dataset"), "--uff", "{tmp}/o.uff"]),
    ("h5-captures-dataset-diagnose", ["diagnose", _f("captures_dataset"), "--mass", "1"]),
    # -- options
    *[(f"opt-mass-{k}", ["identify", G, "--mass", v]) for k, v in
      [("inf", "inf"), ("nan", "nan"), ("negative", "-1"), ("zero", "0"), ("text", "abc"), ("1e400", "1e400"),
       ("minus-inf", "-inf")]],
    ("opt-damping-x-alone", ["identify", G, "--mass", "1", "--damping", "x"]),
    ("opt-damping-empty", ["identify", G, "--mass", "1", "--damping", ","]),
    ("opt-damping-syntax", ["identify", G, "--mass", "1", "--damping", "v^^2"]),
    ("opt-damping-twice", ["identify", G, "--mass", "1", "--damping", "v,v"]),
    ("opt-damping-power-13", ["identify", G, "--mass", "1", "--damping", "v^13"]),
    ("opt-stiffness-with-v", ["identify", G, "--mass", "1", "--stiffness", "x,v"]),
    ("opt-stiffness-unknown", ["identify", G, "--mass", "1", "--stiffness", "q"]),
    ("opt-route-unknown", ["identify", G, "--mass", "1", "--route", "sideways"]),
    ("opt-unknown-option", ["identify", G, "--bogus", "1"]),
    ("opt-missing-argument", ["identify"]),
    ("opt-unknown-command", ["identfy", G]),
    ("opt-no-mass", ["identify", G]),
    ("opt-diagnose-mass-inf", ["diagnose", G, "--mass", "inf"]),
    ("opt-diagnose-margin-nan", ["diagnose", G, "--mass", "1", "--margin", "nan"]),
    ("opt-diagnose-margin-negative", ["diagnose", G, "--mass", "1", "--margin", "-0.5"]),
    ("opt-diagnose-damping-x", ["diagnose", G, "--mass", "1", "--damping", "x"]),
    ("opt-diagnose-model-missing", ["diagnose", G, "--model", "{tmp}/nope.json"]),
    ("opt-diagnose-model-not-json", ["diagnose", G, "--model", _f("model_not_json")]),
    ("opt-report-mass-nan", ["report", G, "--out", "{tmp}/rep", "--mass", "nan"]),
    ("opt-report-fit-negative", ["report", G, "--out", "{tmp}/rep", "--fit", "-1"]),
    ("opt-replay-fit-text", ["replay", S, "--fit", "x"]),
    ("opt-replay-mass-zero", ["replay", S, "--mass", "0"]),
    ("opt-import-mass-inf", ["import", G, "--out", "{tmp}/new.h5", "--mass", "inf"]),
    ("opt-import-lock-wait-nan", ["import", G, "--out", "{tmp}/new.h5", "--lock-wait", "nan"]),
    ("opt-import-lock-wait-negative", ["import", G, "--out", "{tmp}/new.h5", "--lock-wait", "-1"]),
    ("opt-acquire-mass-inf", ["acquire", "--device", "sim://duffing-smooth", "--impacts", "1", "--out",
                              "{tmp}/a.h5", "--mass", "inf"]),
    ("opt-acquire-idle-timeout-negative", ["acquire", "--device", "sim://duffing-smooth", "--impacts", "1",
                                           "--out", "{tmp}/a.h5", "--idle-timeout", "-1"]),
    ("opt-acquire-idle-timeout-nan", ["acquire", "--device", "sim://duffing-smooth", "--impacts", "1",
                                      "--out", "{tmp}/a.h5", "--idle-timeout", "nan"]),
    ("opt-acquire-impacts-zero", ["acquire", "--device", "sim://duffing-smooth", "--impacts", "0", "--out",
                                  "{tmp}/a.h5"]),
    ("opt-acquire-impacts-text", ["acquire", "--device", "sim://duffing-smooth", "--impacts", "many", "--out",
                                  "{tmp}/a.h5"]),
    ("opt-acquire-no-device", ["acquire", "--impacts", "1", "--out", "{tmp}/a.h5"]),
    ("opt-acquire-device-no-scheme", ["acquire", "--device", "duffing", "--impacts", "1", "--out", "{tmp}/a.h5"]),
    ("opt-acquire-config-missing", ["acquire", "--config", "{tmp}/none.toml", "--impacts", "1", "--out",
                                    "{tmp}/a.h5"]),
    # -- bench configurations (station acquire --config FILE)
    *[(f"cfg-{n.removeprefix('cfg_')}", ["acquire", "--config", _f(n), "--device", "sim://duffing-smooth",
                                         "--impacts", "1", "--out", "{tmp}/a.h5"]) for n in [
        "cfg_record_1e9", "cfg_record_inf", "cfg_pretrigger_nan", "cfg_level_zero", "cfg_rate_zero",
        "cfg_rate_huge", "cfg_mass_negative", "cfg_mass_inf", "cfg_unknown_field", "cfg_bad_toml", "cfg_bad_slope",
        "cfg_bad_url", "cfg_duplicate_channel", "cfg_bad_quantity", "cfg_bad_direction", "cfg_bad_date",
        "cfg_negative_node", "cfg_bad_terms", "cfg_peak_order"]],
    # -- outputs
    ("out-export-uff-onto-input", ["export", S, "--uff", S]),
    ("out-export-uff-missing-folder", ["export", S, "--uff", "{missing_dir}/o.uff"]),
    ("out-export-uff-onto-folder", ["export", S, "--uff", "{tmp}"]),
    ("out-export-uff-onto-csv", ["export", S, "--uff", G]),
    ("out-export-sep005-onto-input", ["export", S, "--sep005", S]),
    ("out-export-sep005-onto-model", ["export", S, "--sep005", _f("model_saved")]),
    ("out-export-sep005-missing-folder", ["export", S, "--sep005", "{missing_dir}/o.json"]),
    ("out-export-nothing", ["export", S]),
    ("out-export-same-file-twice", ["export", S, "--uff", "{tmp}/x.out", "--sep005", "{tmp}/x.out"]),
    ("out-export-rate-zero", ["export", _f("rate_zero"), "--uff", "{tmp}/r0.uff"]),
    ("out-export-rate-nan", ["export", _f("rate_nan"), "--sep005", "{tmp}/rn.json"]),
    ("out-export-gaps", ["export", _f("gaps"), "--uff", "{tmp}/g.uff"]),
    ("out-export-si-huge", ["export", _f("si_huge"), "--sep005", "{tmp}/h.json"]),
    ("out-export-csv-source", ["export", G, "--uff", "{tmp}/c.uff"]),
    ("out-export-capture-out-of-range", ["export", S + ":5", "--uff", "{tmp}/c.uff"]),
    ("out-import-onto-input", ["import", G, "--out", G]),
    ("out-import-onto-json", ["import", G, "--out", _f("model_list")]),
    ("out-import-missing-folder", ["import", G, "--out", "{missing_dir}/s.h5"]),
    ("out-import-foreign-h5", ["import", G, "--out", _f("foreign")]),
    ("out-import-bad-csv", ["import", _f("nan_acc"), "--out", "{tmp}/new.h5"]),
    ("out-import-rate-disagrees", ["import", G, "--out", S]),
    ("out-diagnose-save-model-onto-input", ["diagnose", S, "--mass", "1", "--save-model", S]),
    ("out-diagnose-save-model-onto-csv", ["diagnose", G, "--mass", "1", "--save-model", G]),
    ("out-diagnose-save-model-onto-sep005", ["diagnose", G, "--mass", "1", "--save-model", _f("model_sep005")]),
    ("out-diagnose-save-model-missing-folder", ["diagnose", G, "--mass", "1", "--save-model",
                                                "{missing_dir}/m.json"]),
    ("out-diagnose-report-onto-file", ["diagnose", G, "--mass", "1", "--report", G]),
    ("out-report-onto-input", ["report", S, "--out", S]),
    ("out-report-onto-file", ["report", G, "--out", _f("model_list")]),
    ("out-acquire-onto-csv", ["acquire", "--device", "sim://duffing-smooth", "--impacts", "1", "--out", G]),
    ("out-acquire-onto-config", ["acquire", "--config", _f("cfg_good"), "--device", "sim://duffing-smooth",
                                 "--impacts", "1", "--out", _f("cfg_good")]),
    ("out-demo-onto-file", ["demo", "--out", G]),
    ("out-campaign-onto-input", ["campaign", G, "--out", G]),
    ("out-campaign-onto-file", ["campaign", G, "--out", _f("model_list")]),
    ("opt-campaign-mass-nan", ["campaign", G, "--out", "{tmp}/camp", "--mass", "nan"]),
    ("opt-campaign-damping-x", ["campaign", G, "--out", "{tmp}/camp", "--damping", "x"]),
    # -- models (station validate MODEL CAPTURE)
    ("model-not-json", ["validate", _f("model_not_json"), G]),
    ("model-wrong-schema", ["validate", _f("model_wrong_schema"), G]),
    ("model-list", ["validate", _f("model_list"), G]),
    ("model-missing", ["validate", "{tmp}/none.json", G]),
]


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return build_files(tmp_path_factory.mktemp("bad"))


def _argv(argv: list[str], files: dict[str, Path]) -> list[str]:
    tmp = next(iter(files.values())).parent
    subs = {k: str(v) for k, v in files.items()} | {"tmp": str(tmp)}
    return [a.format(**subs) for a in argv]


@pytest.mark.parametrize("case,argv", CASES, ids=[c for c, _ in CASES])
def test_bad_input_is_one_line_and_exit_2(case: str, argv: list[str], files: dict[str, Path],
                                          capsys: pytest.CaptureFixture[str]) -> None:
    before = {p: p.read_bytes() for p in files.values() if p.is_file()}
    try:
        rc = main(_argv(argv, files))
    except SystemExit as exc:  # argparse refusals
        rc = exc.code
    out = capsys.readouterr()
    lines = out.err.strip().splitlines()
    assert rc == 2, (case, out.err[-2000:])
    assert len(lines) == 1 and "Traceback" not in out.err, (case, out.err)
    assert lines[0].startswith(("station: error:", "station ")), lines[0]
    after = {p: p.read_bytes() for p in before}
    assert after == before  # no input file was changed by a refused command


def test_table_in_docs_lists_every_case() -> None:
    doc = (REPO / "docs" / "bad-inputs.md").read_text()
    listed = set(re.findall(r"^\| `([a-z0-9_-]+)` \|", doc, re.M))
    ids = {c for c, _ in CASES}
    assert len(ids) == len(CASES) >= 100
    assert ids <= listed, sorted(ids - listed)


def test_valid_inputs_of_the_table_are_accepted(files: dict[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    """The good file, and a dollar sign in a name, pass the boundary (the refusals are not blanket)."""
    from station.readers import read_measurement

    for name in ("good", "dollar"):
        m = read_measurement(str(files[name]))
        assert m.rate_hz == pytest.approx(RATE, rel=1e-12) and m.t.size == 2000


def test_dollar_in_a_file_name_reaches_a_figure_title_as_plain_text(tmp_path: Path) -> None:
    """``ring$x^{2$.csv`` is invalid mathtext: the figure is still written, with the name as typed."""
    from station import figures

    t, force, _ = _ringdown()
    fig = figures.force_figure(t, force, title="Force, ring$x^{2$.csv")
    out = figures.save(fig, tmp_path / "f.png")
    assert out.read_bytes()[:4] == b"\x89PNG"
    assert "Force, ring$x^{2$.csv" in [a.get_title() for a in fig.axes]
