"""Bad inputs on the paths the table of docs/bad-inputs.md does not walk: multi-channel records
(a dead sensor, a single-coordinate model or command on several sensors), the campaign's
workers, and an export onto a full disk. One line naming the cause, exit code 2, no traceback."""

from __future__ import annotations

import csv
import os
import resource
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test
from station.campaign.sources import CaptureRef
from station.campaign.tasks import TaskOptions, run_capture
from station.cli import main
from station.session_writer import CaptureWriter

REPO = Path(__file__).resolve().parents[2]
PAIR = MdofSystem(name="pair", masses_kg=(0.9, 0.3), driving_point=1,
                  elements=(Element(between=(0, 1), k=1.5e4, c=0.9), Element(between=(1, 2), k=1.0e4, c=0.4)),
                  impacts_n=(40.0, 100.0))


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    try:
        rc = main([str(a) for a in argv])
    except SystemExit as exc:
        rc = int(exc.code or 0)
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return rc, lines[0]


@pytest.fixture(scope="module")
def pair(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("pair")
    return Path(mdof_impact_test(PAIR, 40.0, seed=3, record_s=1.0).write_csv(d / "pair.csv"))


def _dead_acc2(src: Path, dst: Path) -> Path:
    with open(src, newline="") as fh:
        rows = list(csv.reader(fh))
    k = rows[0].index("acc2")
    for row in rows[1:]:
        row[k] = "0"
    with open(dst, "w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    return dst


@pytest.mark.parametrize("command", ["import", "replay", "diagnose", "report"])
def test_a_dead_sensor_of_a_multichannel_record_is_named(command: str, pair: Path, tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    # one sensor of two reads 0 throughout (unplugged): the one-sensor records' refusal; was
    # imported silently, and replay/report failed deep in the fit ("coordinate 2: 0 half cycles")
    dead = _dead_acc2(pair, tmp_path / "dead.csv")
    argv = {"import": ["import", dead, "--out", tmp_path / "s.h5"], "replay": ["replay", dead],
            "diagnose": ["diagnose", dead, dead], "report": ["report", dead, "--out", tmp_path / "rep"]}[command]
    rc, line = _run(argv, capsys)
    assert rc == 2 and "column 'acc2' is constant (0); expected a measured response" in line, line
    assert not (tmp_path / "s.h5").exists()


def test_a_dead_sensor_stored_in_a_session_is_named(pair: Path, tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    from station.readers import read_measurement

    m = read_measurement(str(pair))
    h5 = tmp_path / "dead.h5"
    with CaptureWriter(h5) as w:
        w.append_si({"force": m.channels["force"], "acc1": m.channels["acc1"], "acc2": np.zeros(m.t.size)},
                    m.rate_hz)
    rc, line = _run(["replay", h5], capsys)
    assert rc == 2 and line.endswith(f"capture 0 of {h5}: channel 'acc2' is constant (0); expected a measured response")


def test_a_single_coordinate_model_on_several_sensors_says_so(pair: Path, tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    # was "need at least one of acc, vel, disp; got none" (the record has two)
    from eddi.model import EquationOfMotion

    model = tmp_path / "m.json"
    model.write_text(EquationOfMotion.create(mass=1.0, damping={"v": 1.0}, stiffness={"x": 1e4}).to_json())
    rc, line = _run(["validate", model, pair], capsys)
    assert rc == 2 and "2 response sensors (acc1, acc2); expected one for a single-coordinate model" in line, line
    row = run_capture(CaptureRef(str(pair)), TaskOptions(task="validate", model_json=model.read_text()))
    assert row["status"] == "error" and "2 response sensors (acc1, acc2)" in row["error"], row["error"]


def test_campaign_identify_refuses_several_sensors_as_identify_does(pair: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    rc, line = _run(["identify", pair, "--mass", "1"], capsys)
    row = run_capture(CaptureRef(str(pair)), TaskOptions(mass=1.0))
    assert rc == 2 and row["status"] == "error"
    assert "2 response sensors (acc1, acc2)" in line and "2 response sensors (acc1, acc2)" in row["error"], row["error"]


def test_export_onto_a_full_disk_is_one_line_and_leaves_no_file(tmp_path: Path) -> None:
    # RLIMIT_FSIZE stands for a full disk: pyuff wraps the write's OSError in a bare Exception,
    # which came out as a traceback (fails without station/uff.py's handling)
    from tests.station.test_storage import make_capture

    h5 = tmp_path / "s.h5"
    CaptureWriter(h5).append(make_capture(1, n=20_000, pre=100), mass_kg=1.0)
    out = tmp_path / "x.uff"

    def small_files() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (64_000, 64_000))

    env = {**os.environ, "PYTHONPATH": str(REPO)}
    p = subprocess.run([sys.executable, "-m", "station.cli", "export", str(h5), "--uff", str(out)], cwd=tmp_path,
                       env=env, capture_output=True, text=True, preexec_fn=small_files, timeout=300)
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1 and "Traceback" not in p.stderr, p.stderr[-2000:]
    assert lines[0] == f"station: error: cannot write {out}: File too large"
    assert sorted(x.name for x in tmp_path.iterdir()) == [".s.h5.lock", "s.h5"] or not out.exists()
    assert not out.exists() and not list(tmp_path.glob(".x.uff.*"))


def _station(argv: list, cwd: Path, *, fsize: int | None = None, sigint_once: Path | None = None
             ) -> tuple[int, list[str], str]:
    """``python -m station.cli ARGV`` in a process group of its own: its exit code, its stderr
    lines (progress lines left out) and the whole stderr. ``fsize``: RLIMIT_FSIZE [bytes] (a
    full disk); ``sigint_once``: a terminal's Ctrl-C (SIGINT to the group) once that file exists."""
    import signal

    def setup() -> None:
        signal.signal(signal.SIGINT, signal.SIG_DFL)  # a background job may start with it ignored
        if fsize is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))

    env = {**os.environ, "PYTHONPATH": str(REPO)}
    p = subprocess.Popen([sys.executable, "-m", "station.cli", *map(str, argv)], cwd=cwd, env=env, text=True,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, preexec_fn=setup, start_new_session=True)
    if sigint_once is not None:
        _wait_for_content(sigint_once, p)
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGINT)
    _, err = p.communicate(timeout=600)
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith(("[", "station: note:"))]
    return p.returncode, lines, err


def _wait_for_content(path: Path, proc: subprocess.Popen, limit_s: float = 300.0) -> None:
    """Block until ``path`` has content or ``proc`` ends: woken by the kernel's file events
    (inotify on the folder tree above ``path``; no polling on the clock), ``limit_s`` a guard."""
    import ctypes
    import select

    libc = ctypes.CDLL(None, use_errno=True)
    fd = libc.inotify_init1(os.O_NONBLOCK | os.O_CLOEXEC)
    assert fd >= 0, "inotify"
    try:
        watched: set[Path] = set()
        while proc.poll() is None and not (path.exists() and path.stat().st_size):
            # watch the deepest existing folder on the way (the campaign creates its folder first)
            d = path.parent
            while not d.exists():
                d = d.parent
            if d not in watched:  # create, write, close-write, moved-in
                libc.inotify_add_watch(fd, str(d).encode(), 0x100 | 0x2 | 0x8 | 0x80)
                watched.add(d)
                continue  # look again: it may have changed before the watch was set
            ready, _, _ = select.select([fd], [], [], limit_s)
            if not ready:
                return
            os.read(fd, 65536)
    finally:
        os.close(fd)


def test_demo_keeps_a_session_it_did_not_make(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # `station demo --out DIR` deleted DIR/session.h5 whatever it held (a lab's own captures)
    from station.demo import DEMO_NOTES, refuse_foreign_session
    from tests.station.test_storage import make_capture

    theirs = tmp_path / "lab" / "session.h5"
    theirs.parent.mkdir()
    CaptureWriter(theirs).append(make_capture(1, n=400, pre=100), mass_kg=1.0, notes="bench A")
    before = theirs.read_bytes()
    rc, line = _run(["demo", "--out", theirs.parent], capsys)
    assert rc == 2 and "holds captures not made by the demo (1)" in line, line
    assert theirs.read_bytes() == before
    ours = tmp_path / "demo" / "session.h5"
    ours.parent.mkdir()
    CaptureWriter(ours).append(make_capture(2, n=400, pre=100), mass_kg=1.0, notes=DEMO_NOTES)
    refuse_foreign_session(ours)  # an earlier demo's: replaced, as before


def test_diagnose_report_onto_a_full_disk_says_what_was_kept(tmp_path: Path) -> None:
    # the figures hit the file-size limit: was "station: error: File too large" (no path, and
    # nothing said of the model already saved); the model file is whole
    from tests.station.test_sensor_highpass import MASS, _csv

    rec = _csv(tmp_path, None)
    rc, lines, err = _station(["diagnose", rec, "--mass", MASS, "--mechanisms", "coulomb_friction",
                               "--save-model", "m.json", "--report", "rep"], tmp_path, fsize=40_000)
    assert rc == 2 and len(lines) == 1 and "Traceback" not in err, err[-3000:]
    assert lines[0] == ("station: error: rep: cannot write the diagnosis report (File too large); "
                        "the extended model was written to m.json")
    import json

    assert json.loads((tmp_path / "m.json").read_text())["mass"] == MASS


@pytest.mark.slow
def test_campaign_ctrl_c_and_full_disk_are_one_line(tmp_path: Path) -> None:
    # Ctrl-C reaches every process of the group: each Dask worker printed tracebacks under the
    # campaign's line (fails without station.campaign.run._children_ignore_sigint)
    from tests.station.test_sensor_highpass import MASS, _csv

    recs = [_csv(tmp_path, None, seed=s) for s in range(12)]
    rc, lines, err = _station(["campaign", *recs, "--out", "camp", "--mass", MASS, "--workers", "2"], tmp_path,
                              sigint_once=tmp_path / "camp" / "rows.jsonl")  # once the workers are at work
    assert "Traceback" not in err and len(lines) == 1, err[-3000:]
    assert (rc, lines[0]) == (130, "station: interrupted (what was saved is kept)"), err[-3000:]
    assert (tmp_path / "camp" / "results.csv").is_file()  # the rows received, as a table
    # the journal fills the file-size limit: one line naming the folder, the journal kept
    rc, lines, err = _station(["campaign", *recs, "--out", "camp2", "--mass", MASS, "--workers", "1"], tmp_path,
                              fsize=2_500)
    assert rc == 2 and len(lines) == 1 and "Traceback" not in err, err[-3000:]
    assert lines[0].startswith("station: error: camp2: cannot write the campaign's results (File too large)")
    assert not list((tmp_path / "camp2").glob("*.tmp"))


def test_a_session_whose_lock_cannot_be_made_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # a read-only folder (or a lock path that is a folder) named only the sidecar:
    # "Is a directory: .../.s.h5.lock"; now the session file, and that nothing was written
    from tests.station.test_bad_inputs import _csv, _ringdown

    t, force, acc = _ringdown()
    good = _csv(tmp_path / "good.csv", "t,force,acc", np.column_stack([t, force, acc]))
    (tmp_path / ".s.h5.lock").mkdir()
    rc, line = _run(["import", good, "--out", tmp_path / "s.h5", "--mass", "1"], capsys)
    assert rc == 2 and line.startswith(f"station: error: cannot write {tmp_path / 's.h5'}: Is a directory "
                                       f"(its lock file .s.h5.lock cannot be created)"), line
    assert not (tmp_path / "s.h5").exists()
