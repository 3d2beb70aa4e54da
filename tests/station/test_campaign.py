"""``station campaign`` on a real Dask LocalCluster of two worker processes.

Six captures of the simulated rig's paper Duffing oscillator (four in an HDF5 session, one
good CSV, one CSV with a text value in a data row) are identified with the true-structure
library; the table is checked row by row against the rig's true coefficients, the failing row
carries its one-line error, and a second run resumes (skips what is done, retries errors on
request).
"""

from __future__ import annotations

import csv
import json
import os

import numpy as np
import pyarrow.parquet as pq
import pytest

from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test
from simulated_rig.systems import system_info
from station.campaign.run import auto_chunk, dask_client, run_campaign
from station.campaign.sources import CaptureRef, expand_sources
from station.campaign.table import Journal
from station.campaign.tasks import TaskOptions
from station.cli import main
from station.errors import ConfigError
from station.storage import CaptureWriter
from station.trigger import Capture

RATE = 5000.0
SYSTEM = system_info("paper-duffing")
TRUE = {"b[v]": 0.5, "b[x^2*v]": 4000.0, "k[x]": 300.0, "k[x^3]": 3.0e8}
#: Relative tolerance of each coefficient for 80 N blows (45 dB rig noise, 1 s ring-down at
#: 5 kHz), from the spread over 20 other seeds (20-39, not used here): b[v] within 1.0 %,
#: k[x^3] within 1.7 %, k[x] -7.7 % .. +1.2 %. The weak x^2*v damping is the least observable
#: term at these amplitudes. (At 250 N the cubic dominates and EDDI's k[x] is off by up to
#: -80 % at 5 kHz: a pipeline matter, noted in /work/notes/issue-13-campaign.md.)
TOL = {"b[v]": 0.03, "b[x^2*v]": 0.6, "k[x]": 0.10, "k[x^3]": 0.03}
OPTS = TaskOptions(task="identify", mass=None, damping="v,x^2*v", stiffness="x,x^3")


def _record(force: float, seed: int):
    return impact_test("paper-duffing", force, rate_hz=RATE, pretrigger_s=0.2, seed=seed)


def _write_csv(path, rec, bad_line: int | None = None) -> None:
    rows = np.column_stack([rec.t, rec.force_n, rec.acc_m_s2])
    lines = ["t,force,acc"] + [f"{t:.9g},{f:.9g},{a:.9g}" for t, f, a in rows]
    if bad_line is not None:
        lines[bad_line - 1] = lines[bad_line - 1].rsplit(",", 1)[0] + ",n/a"
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def captures(tmp_path_factory):
    d = tmp_path_factory.mktemp("campaign")
    w = CaptureWriter(d / "session.h5")
    for force, seed in ((80.0, 1), (80.0, 2), (80.0, 3), (80.0, 4)):
        r = _record(force, seed)
        cap = Capture(counts=r.counts, si=np.column_stack([r.force_n, r.acc_m_s2]), channels=r.channels,
                      rate_hz=r.rate_hz, first_sample=0, trigger_sample=r.pretrigger_samples,
                      pretrigger_samples=r.pretrigger_samples)
        w.append(cap, mass_kg=SYSTEM.eom.mass, source="simulated rig")
    _write_csv(d / "good.csv", _record(80.0, 5))
    _write_csv(d / "bad.csv", _record(80.0, 6), bad_line=7)
    return d


@pytest.fixture(scope="module")
def client():
    with dask_client(None, workers=2) as c:
        assert len(c.nthreads()) == 2 and set(c.nthreads().values()) == {1}
        yield c


def _mass_opts() -> TaskOptions:
    # the CSVs do not record the mass: give it for all
    return TaskOptions(task=OPTS.task, mass=SYSTEM.eom.mass, damping=OPTS.damping, stiffness=OPTS.stiffness)


def test_sources_expand_sessions_folders_and_globs(captures):
    refs = expand_sources([str(captures)])
    h5 = str(captures / "session.h5")
    assert refs == sorted(refs) and len(refs) == 6
    assert [r for r in refs if r.file == h5] == [CaptureRef(h5, i) for i in range(4)]
    assert expand_sources([str(captures / "*.csv")]) == [CaptureRef(str(captures / n)) for n in ("bad.csv", "good.csv")]
    assert expand_sources([f"{h5}:2", h5]) == [CaptureRef(h5, 2)] + [CaptureRef(h5, i) for i in (0, 1, 3)]


def test_sources_take_every_reader_uff_by_load_case(tmp_path):
    """A folder's UFF files give one reference per load case (one-case files: the file), TSV files
    are records, a folder's .txt notes are not (a glob may still name text records)."""
    from station.uff import export_uff58

    w = CaptureWriter(tmp_path / "s.h5")
    for seed in (1, 2):
        r = _record(80.0, seed)
        w.append(Capture(counts=r.counts, si=np.column_stack([r.force_n, r.acc_m_s2]), channels=r.channels,
                         rate_hz=r.rate_hz, first_sample=0, trigger_sample=r.pretrigger_samples,
                         pretrigger_samples=r.pretrigger_samples), mass_kg=SYSTEM.eom.mass)
    d = tmp_path / "runs"
    d.mkdir()
    assert export_uff58(tmp_path / "s.h5", d / "two.uff") == 4
    assert export_uff58(tmp_path / "s.h5", d / "one.unv", [1]) == 2
    _write_csv(d / "rec.tsv", _record(80.0, 3))
    (d / "notes.txt").write_text("bench A, 24 Nov\n")
    refs = expand_sources([str(d)])
    f = {n: str(d / n) for n in ("one.unv", "rec.tsv", "two.uff", "notes.txt")}
    assert refs == [CaptureRef(f["one.unv"]), CaptureRef(f["rec.tsv"]), CaptureRef(f["two.uff"], 0),
                    CaptureRef(f["two.uff"], 1)]
    assert expand_sources([str(d / "*.txt"), f"{f['two.uff']}:1"]) == [CaptureRef(f["notes.txt"]),
                                                                      CaptureRef(f["two.uff"], 1)]


def test_campaign_table_row_by_row_and_resume(captures, client, tmp_path):
    refs = expand_sources([str(captures)])
    opts = _mass_opts()
    journal = Journal(tmp_path / "out", opts.as_dict())
    res = run_campaign(client, refs, opts, journal, quiet=True)
    assert (res.total, res.processed, res.failed, res.skipped, res.rows, res.workers) == (6, 6, 1, 0, 6, 2)
    assert len(res.peak_memory_mb) == 2 and all(50 < m < 4000 for m in res.peak_memory_mb.values())

    arrow = pq.read_table(res.parquet)
    assert arrow.schema.field("k[x^3]").metadata == {b"unit": b"N/m^3"}
    assert arrow.schema.field("b[v]_ci95").metadata == {b"unit": b"N s/m"}
    table = arrow.to_pylist()
    assert [(r["file"], r["capture"]) for r in table] == [(r.file, r.capture) for r in refs]
    with open(res.csv, newline="") as fh:
        csv_rows = list(csv.DictReader(fh))
    assert len(csv_rows) == 6
    for row, crow in zip(table, csv_rows):
        assert crow["file"] == row["file"] and crow["status"] == row["status"]
        assert int(row["worker"].rsplit(":", 1)[1]) != os.getpid()  # read and run on a worker process
        if row["file"].endswith("bad.csv"):
            assert row["status"] == "error"
            assert row["error"] == f"{row['file']}: line 7: 'n/a' is not a number"
            assert crow["error"] == row["error"] and row["k[x^3]"] is None and row["model_json"] == ""
            continue
        assert row["status"] == "ok" and row["error"] == "", row["error"]
        for name, true in TRUE.items():
            assert row[name] == pytest.approx(true, rel=TOL[name]), (row["file"], row["capture"], name)
            assert float(crow[name]) == row[name]
            assert 0 < row[f"{name}_ci95"] < abs(true) and float(crow[f"{name}_ci95"]) == row[f"{name}_ci95"]
        assert 0 <= row["nrmse"] < 0.1 and row["diverged"] is False and row["driven_by"] == "force"
        assert row["unstable"] is False and crow["unstable"] == "False"
        if row["capture"] == 2:  # the worker ran exactly the pipeline `station identify` runs
            from station.commands.identify import run_identify
            from station.readers import read_measurement

            here = run_identify(read_measurement(f"{row['file']}:2"), SYSTEM.eom.mass, OPTS.damping, OPTS.stiffness)
            assert here.model.eom.stiffness["x"] == row["k[x]"] and here.validation.nrmse == row["nrmse"]
        model = EquationOfMotion.from_json((tmp_path / "out" / row["model_json"]).read_text())
        assert model.mass == SYSTEM.eom.mass and model.stiffness["x^3"] == row["k[x^3]"]

    # several captures per task (as the automatic chunking makes for long campaigns): the same rows
    chunked = run_campaign(client, refs, opts, Journal(tmp_path / "chunked", opts.as_dict()), chunk=4, quiet=True)
    assert (chunked.processed, chunked.failed) == (6, 1)
    same = [{k: v for k, v in r.items() if k not in ("seconds", "worker")} for r in pq.read_table(chunked.parquet).to_pylist()]
    assert same == [{k: v for k, v in r.items() if k not in ("seconds", "worker")} for r in table]
    assert [auto_chunk(n, 2) for n in (0, 6, 60, 1000, 10**6)] == [1, 1, 3, 8, 8]

    # resume: nothing to do; with --retry-errors only the failed capture runs (and fails again)
    again = run_campaign(client, refs, opts, Journal(tmp_path / "out", opts.as_dict()), quiet=True)
    assert (again.processed, again.skipped, again.rows) == (0, 6, 6)
    seen: list[dict] = []
    retry = run_campaign(client, refs, opts, Journal(tmp_path / "out", opts.as_dict()), quiet=True,
                         retry_errors=True, on_row=seen.append)
    assert (retry.processed, retry.failed, retry.skipped, retry.rows) == (1, 1, 5, 6)
    assert seen[0]["file"].endswith("bad.csv")
    # the repaired file succeeds on the next retry and its row replaces the error
    _write_csv(captures / "bad.csv", _record(80.0, 6))
    try:
        fixed = run_campaign(client, refs, opts, Journal(tmp_path / "out", opts.as_dict()), quiet=True,
                             retry_errors=True)
    finally:
        _write_csv(captures / "bad.csv", _record(80.0, 6), bad_line=7)
    assert (fixed.processed, fixed.failed, fixed.rows) == (1, 0, 6)
    row = [r for r in pq.read_table(fixed.parquet).to_pylist() if r["file"].endswith("bad.csv")][0]
    assert row["status"] == "ok" and row["k[x^3]"] == pytest.approx(3.0e8, rel=0.03)
    assert len((tmp_path / "out" / "rows.jsonl").read_text().splitlines()) == 8


def test_validate_and_diagnose_tasks(captures, client, tmp_path):
    h5 = str(captures / "session.h5")
    refs = [CaptureRef(h5, 0), CaptureRef(h5, 1)]
    ident = run_campaign(client, refs[:1], _mass_opts(), Journal(tmp_path / "id", _mass_opts().as_dict()), quiet=True)
    fitted = pq.read_table(ident.parquet).to_pylist()[0]
    model_json = (tmp_path / "id" / fitted["model_json"]).read_text()
    vopts = TaskOptions(task="validate", model_json=model_json)
    val = run_campaign(client, refs, vopts, Journal(tmp_path / "val", vopts.as_dict()), quiet=True)
    rows = pq.read_table(val.parquet).to_pylist()
    assert [r["status"] for r in rows] == ["ok", "ok"] and "b[v]" not in rows[0]  # no coefficients fitted
    assert rows[0]["nrmse"] == fitted["nrmse"]  # the same model on the same record: the same score
    assert 0 < rows[1]["nrmse"] < 0.1 and rows[1]["driven_by"] == "force"  # another blow of the same system
    # a 1 s ring-down is too short for diagnose's three amplitude bands: a row says so
    dopts = TaskOptions(task="diagnose", mass=SYSTEM.eom.mass, damping=OPTS.damping, stiffness=OPTS.stiffness)
    diag = run_campaign(client, refs[:1], dopts, Journal(tmp_path / "diag", dopts.as_dict()), quiet=True)
    row = pq.read_table(diag.parquet).to_pylist()[0]
    assert row["status"] == "error" and "too short to split into 3 amplitude bands" in row["error"]


def test_resume_refuses_other_options(tmp_path):
    Journal(tmp_path, _mass_opts().as_dict())
    with pytest.raises(ConfigError, match="other options \\(stiffness\\)"):
        Journal(tmp_path, TaskOptions(task="identify", mass=SYSTEM.eom.mass, damping=OPTS.damping,
                                      stiffness="x,x^2,x^3").as_dict())


def test_cli_bad_input_is_one_line(captures, tmp_path, capsys):
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    cases = [
        (["campaign", str(tmp_path / "nothing-*.h5"), "--out", str(tmp_path / "o")], "matches no .csv, .tsv, .txt, .uff, .unv, .mat, .h5, .hdf5 file"),
        (["campaign", str(captures), "--out", str(captures)], "refusing to overwrite an input"),
        (["campaign", str(captures), "--out", str(other)], "a folder of other files, not a campaign's"),
        (["campaign", str(captures), "--out", str(captures / "good.csv")], "refusing to replace it with a folder"),
        (["campaign", str(captures), "--out", str(tmp_path / "v"), "--task", "validate"], "needs --model MODEL.json"),
        (["campaign", str(captures), "--out", str(tmp_path / "w"), "--workers", "0"], "--workers must be >= 1"),
    ]
    for argv, msg in cases:
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and msg in err, (argv, err)
    assert sorted(p.name for p in captures.iterdir() if not p.name.startswith(".")) == [
        "bad.csv", "good.csv", "session.h5"]  # nothing written (the session writer's lock file aside)
    assert [p.name for p in other.iterdir()] == ["notes.txt"]


def test_output_folder_below_a_source_is_not_read(captures, tmp_path):
    out = captures / "results"
    out.mkdir()
    try:
        (out / "results.csv").write_text("file,capture\n")
        assert len(expand_sources([str(captures)], exclude=out)) == 6
        assert len(expand_sources([str(captures)])) == 7
    finally:
        (out / "results.csv").unlink()
        out.rmdir()


def test_cli_json_resume_on_an_existing_scheduler(captures, client, tmp_path, capsys):
    out = tmp_path / "cli"
    args = ["campaign", str(captures / "session.h5:1"), str(captures / "good.csv"), "--out", str(out),
            "--mass", str(SYSTEM.eom.mass), "--damping", OPTS.damping, "--stiffness", OPTS.stiffness,
            "--scheduler", client.scheduler.address, "--json"]
    assert main(args) == 0
    first = json.loads(capsys.readouterr().out)
    assert (first["processed"], first["failed"], first["rows"], first["workers"]) == (2, 0, 2, 2)
    assert first["scheduler"] == client.scheduler.address
    assert main(args) == 0
    second = json.loads(capsys.readouterr().out)
    assert (second["processed"], second["skipped"], second["rows"]) == (0, 2, 2)
