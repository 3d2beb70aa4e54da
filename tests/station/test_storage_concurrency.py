"""Nothing saved is lost: concurrent writers (real processes), output options, session consistency."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

from station.cli import main
from station.locks import WriterLock
from station.storage import CaptureWriter, check_file, list_captures, read_capture, read_measurement
from test_storage import make_capture
from test_storage_import import write_csv

REPO = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(REPO)}


def _station(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "station.cli", *args], cwd=REPO, env=ENV, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def test_six_concurrent_imports_keep_every_capture_or_refuse(tmp_path: Path) -> None:
    out = tmp_path / "s.h5"
    csvs = [write_csv(tmp_path / f"r{i}.csv", 2000 + 100 * i, 2000.0, i) for i in range(6)]
    procs = [_station("import", str(c), "--out", str(out), "--mass", "1.5") for c in csvs]
    results = [(p.wait(timeout=240), *p.communicate()) for p in procs]
    ok = [i for i, (rc, _, _) in enumerate(results) if rc == 0]
    for rc, _, err in results:
        assert rc in (0, 2), err
        if rc == 2:  # refused: one line, never a traceback
            assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert check_file(out) == len(ok) >= 1
    # each successful import is in the file exactly once, bit-exact (the order is the lock's)
    lengths = sorted(c.n_samples for c in list_captures(out))
    assert lengths == sorted(2000 + 100 * i for i in ok)
    for c in list_captures(out):
        i = (c.n_samples - 2000) // 100
        m = read_measurement(out, str(c.index))
        ref = np.loadtxt(csvs[i], delimiter=",", skiprows=1)
        np.testing.assert_array_equal(m.channels["acc"], ref[:, 2])


WRITER = textwrap.dedent(
    """
    import sys
    sys.path.insert(0, {tests!r})
    from test_storage import make_capture
    from station.storage import CaptureWriter
    path, seed, n = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    w = CaptureWriter(path, lock_wait_s=120)
    with w:  # held for the whole run, as station acquire does
        for i in range(n):
            w.append(make_capture(seed + i, n=3000))
    print("done", flush=True)
    """
)


def test_two_concurrent_writers_keep_all_captures(tmp_path: Path) -> None:
    """Two acquisition-like runs into one file: the second waits for the first; 8 of 8 kept."""
    out = tmp_path / "s.h5"
    script = tmp_path / "w.py"
    script.write_text(WRITER.format(tests=str(Path(__file__).parent)))
    procs = [subprocess.Popen([sys.executable, str(script), str(out), str(seed), "4"], cwd=REPO, env=ENV,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for seed in (0, 100)]
    for p in procs:
        assert p.wait(timeout=240) == 0, p.communicate()[1]
    assert check_file(out) == 8
    seeds = sorted(read_capture(out, i).trigger_sample - 10_000 - 1000 for i in range(8))
    assert seeds == [0, 1, 2, 3, 100, 101, 102, 103]
    # one run's captures are contiguous: the lock was held for the whole run
    order = [read_capture(out, i).trigger_sample - 11_000 for i in range(8)]
    assert order in ([0, 1, 2, 3, 100, 101, 102, 103], [100, 101, 102, 103, 0, 1, 2, 3])


def test_second_writer_refused_with_one_line_after_bounded_wait(tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "s.h5"
    CaptureWriter(out).append(make_capture(1))
    csv = write_csv(tmp_path / "a.csv", 500, 19200.0, 3)
    holder = WriterLock(out)
    holder.acquire()
    try:
        rc = main(["import", str(csv), "--out", str(out), "--lock-wait", "0"])
    finally:
        holder.release()
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1
    assert f"pid {os.getpid()}" in err and "nothing was written" in err
    assert check_file(out) == 1


def test_import_refuses_records_that_disagree_with_the_session(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "s.h5"
    CaptureWriter(out).append(make_capture(1), mass_kg=0.815)  # 19.2 kHz, force + acc, 0.815 kg
    other_rate = write_csv(tmp_path / "5k.csv", 800, 5000.0, 1)
    same_rate = write_csv(tmp_path / "19k.csv", 800, 19200.0, 2)
    acc_only = tmp_path / "acc.csv"
    acc_only.write_text("t,acc\n" + "".join(f"{i / 19200.0!r},{np.sin(i / 7):.6f}\n" for i in range(800)))
    cases = [([str(other_rate), "--mass", "0.815"], "rate 5000 Hz disagrees"),
             ([str(same_rate), "--mass", "1"], "mass 1 kg disagrees"),
             ([str(acc_only)], "channels acc disagree")]
    for argv, text in cases:
        assert main(["import", *argv, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert text in err and "--new-session" in err and len(err.strip().splitlines()) == 1
    assert check_file(out) == 1
    assert main(["import", str(same_rate), "--mass", "0.815", "--out", str(out)]) == 0  # agrees
    assert main(["import", str(other_rate), "--mass", "1", "--out", str(out), "--new-session"]) == 0
    with h5py.File(out, "r") as f:
        assert [int(f["captures"][k].attrs["session_index"]) for k in sorted(f["captures"])] == [0, 0, 1]


# ------------------------------------------------------------------------ output options
def test_outputs_never_overwrite_an_input_or_another_kind(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    session = tmp_path / "v.h5"
    CaptureWriter(session).append(make_capture(1, n=400, pre=100))
    before = session.read_bytes()
    model = tmp_path / "m.json"
    model.write_text('{"kind": "x"}\n')
    csv = write_csv(tmp_path / "a.csv", 500, 19200.0, 3)
    link = tmp_path / "alias.h5"
    link.symlink_to(session)
    hard = tmp_path / "hard.h5"
    os.link(session, hard)
    cases = [
        ["export", str(session), "--uff", str(session)],
        ["export", f"{session}:0", "--uff", str(link)],
        ["export", str(session), "--uff", str(hard)],
        ["export", str(session), "--sep005", str(session)],
        ["export", str(session), "--uff", str(model)],
        ["export", str(session), "--uff", str(tmp_path / "missing" / "x.uff")],
        ["export", str(session), "--uff", str(tmp_path)],
        ["import", str(csv), "--out", str(csv)],
        ["import", str(csv), "--out", str(model)],
        ["diagnose", str(session), "--mass", "1", "--save-model", str(session)],
        ["diagnose", str(session), "--mass", "1", "--save-model", str(csv)],
        ["report", str(session), "--out", str(session)],
        ["report", str(csv), "--out", str(model)],
        ["acquire", "--device", "sim://duffing-smooth", "--impacts", "1", "--out", str(model)],
    ]
    for argv in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, (argv, err)
    assert session.read_bytes() == before and model.read_text() == '{"kind": "x"}\n'
    # replacing a file of the same kind is what was asked
    uff = tmp_path / "o.uff"
    assert main(["export", str(session), "--uff", str(uff)]) == 0
    assert main(["export", str(session), "--uff", str(uff)]) == 0


def test_rig_link_replaces_only_its_own_symlink(tmp_path: Path) -> None:
    from simulated_rig.errors import RigError
    from simulated_rig.serve import _replace_own_link

    regular = tmp_path / "data.h5"
    regular.write_bytes(b"precious")
    with pytest.raises(RigError, match="not a symbolic link"):
        _replace_own_link(str(regular), "/dev/pts/99")
    assert regular.read_bytes() == b"precious"
    other = tmp_path / "to-data"
    other.symlink_to(regular)
    with pytest.raises(RigError, match="not to a pty"):
        _replace_own_link(str(other), "/dev/pts/99")
    own = tmp_path / "rig"
    own.symlink_to("/dev/pts/98")  # a previous server's link
    _replace_own_link(str(own), "/dev/pts/99")
    assert os.readlink(own) == "/dev/pts/99"


def test_two_concurrent_station_acquire_keep_all_captures_or_refuse(tmp_path: Path) -> None:
    """Two real ``station acquire`` runs on the simulated rig into one file (issue: 7 of 8 kept)."""
    cfg = tmp_path / "bench.toml"
    cfg.write_text("[trigger]\npretrigger_s = 0.1\nrecord_s = 0.4\n[specimen]\nmass_kg = 0.815\n")
    out = tmp_path / "s.h5"
    procs = [_station("acquire", "--device", "sim://duffing-smooth", "--impacts", "2", "--out", str(out),
                      "--config", str(cfg), "--json") for _ in range(2)]
    results = [(p.wait(timeout=300), *p.communicate()) for p in procs]
    saved = 0
    for rc, stdout, err in results:
        assert rc in (0, 2) and "Traceback" not in err, err
        if rc == 0:
            saved += json.loads(stdout)["captures"]
        else:
            assert len(err.strip().splitlines()) == 1 and "another process" in err
    assert saved >= 2 and check_file(out) == saved
    assert [c.index for c in list_captures(out)] == list(range(saved))
    for i in range(saved):
        assert read_capture(out, i).n_samples == round(0.5 * 19200)  # every capture complete, checksums pass


def test_acquire_refuses_a_run_that_disagrees_with_the_session(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    """A 2 kHz imported session: the 19.2 kHz simulated rig may not be appended to it."""
    out = tmp_path / "s.h5"
    assert main(["import", str(write_csv(tmp_path / "a.csv", 2000, 2000.0, 1)), "--out", str(out)]) == 0
    before = out.read_bytes()
    capsys.readouterr()
    rc = main(["acquire", "--device", "sim://duffing-smooth", "--impacts", "1", "--out", str(out), "--json"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert "rate 19200 Hz disagrees with the session's 2000 Hz" in err[0] and "another file" in err[0]
    assert out.read_bytes() == before
