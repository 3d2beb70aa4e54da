"""A model saved over an older one is written whole or not at all (station.output_safety).

``diagnose --save-model`` (one- and multi-DOF) and the demo's model.json were written in place: a
full disk or a file-size limit truncated the model saved before and left a part of the new one.
The write limit here is RLIMIT_FSIZE in a child process (Python ignores SIGXFSZ: the write fails
with EFBIG), as a full disk would fail it.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from station.output_safety import sniff, write_text_atomic

REPO = Path(__file__).resolve().parents[2]
OLD = json.dumps({"schema_version": 1, "mass": 1.0, "damping": {"v": 0.1}, "stiffness": {"x": 100.0}}, indent=2)


def _limited(limit: int) -> None:
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))


def test_a_write_that_fails_midway_keeps_the_model_saved_before(tmp_path: Path) -> None:
    model = tmp_path / "m.json"
    model.write_text(OLD)
    code = ("import sys; from station.output_safety import write_text_atomic\n"
            "try:\n    write_text_atomic(sys.argv[1], '{\"schema_version\": 1, ' + ' ' * 100000 + '}')\n"
            "except OSError as exc:\n    print(exc.strerror, exc.filename); sys.exit(2)\n")
    p = subprocess.run([sys.executable, "-c", code, str(model)], capture_output=True, text=True, cwd=REPO,
                       env={**os.environ, "PYTHONPATH": str(REPO)}, preexec_fn=lambda: _limited(4096))
    assert p.returncode == 2, p.stderr
    assert p.stdout.strip().endswith(str(model))  # names the model, not a temporary file
    assert model.read_text() == OLD  # the model saved before, whole
    assert sorted(x.name for x in tmp_path.iterdir()) == ["m.json"]  # no temporary file left


def test_an_interrupted_write_leaves_no_temporary_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    model = tmp_path / "m.json"
    model.write_text(OLD)

    def interrupted(*_: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_text_atomic(model, "{}")
    assert model.read_text() == OLD and sorted(x.name for x in tmp_path.iterdir()) == ["m.json"]
    monkeypatch.undo()
    write_text_atomic(model, '{"schema_version": 2}')
    assert model.read_text() == '{"schema_version": 2}'


def test_json_outputs_are_told_apart(tmp_path: Path) -> None:
    cases = {"model.json": OLD, "modal.json": '{\n  "kind": "modal_sum", "modes": []}',
             "sep.json": json.dumps([{"name": "force", "data": [0.0], "fs": 1.0}]), "other.json": '{"a": 1}',
             "list.json": "[1, 2]"}
    for name, text in cases.items():
        (tmp_path / name).write_text(text)
    assert {n: sniff(tmp_path / n) for n in cases} == {"model.json": "model", "modal.json": "model",
                                                       "sep.json": "sep005", "other.json": "json",
                                                       "list.json": "json"}


@pytest.fixture
def read_only_folder(tmp_path: Path) -> Path:
    d = tmp_path / "ro"
    d.mkdir()
    d.chmod(0o500)
    if os.access(d, os.W_OK):  # root: permissions do not bind, a read-only mount does
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k,ro", "tmpfs", str(d)], capture_output=True)
        if r.returncode != 0:
            pytest.skip("no read-only folder can be made here (root without mount)")
        yield d
        subprocess.run(["umount", str(d)], capture_output=True)
        return
    yield d
    d.chmod(0o700)


def test_an_output_in_a_read_only_folder_is_refused_before_the_work(read_only_folder: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    # diagnose --save-model / --report on a read-only folder failed only after the whole diagnosis
    # (37 s at load 18); now at once, as a missing folder is
    from station.cli import main
    from tests.station.test_demo import demo_run

    demo, _ = demo_run()
    cap = f"{demo / 'session.h5'}:1"
    for argv in (["diagnose", cap, "--save-model", str(read_only_folder / "m.json")],
                 ["diagnose", cap, "--report", str(read_only_folder / "rep")],
                 ["report", cap, "--out", str(read_only_folder / "rep")],
                 ["export", cap, "--sep005", str(read_only_folder / "s.json")]):
        assert main(argv) == 2
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1 and "cannot be written (read-only or not permitted)" in lines[0], (argv, lines)


def test_a_model_behind_a_symbolic_link_is_written_through_it(tmp_path: Path) -> None:
    (tmp_path / "models").mkdir()
    target = tmp_path / "models" / "v3.json"
    target.write_text(OLD)
    (tmp_path / "m.json").symlink_to(target)
    write_text_atomic(tmp_path / "m.json", '{"schema_version": 1}')
    assert (tmp_path / "m.json").is_symlink() and target.read_text() == '{"schema_version": 1}'
