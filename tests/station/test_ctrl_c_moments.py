"""Ctrl-C at several moments of a real ``station`` process: while the command's modules load, while
its engine loads, and in the interpreter's teardown once the command has ended (session 20).

The moments are events, not times: the process runs with ``python -v``, which writes a line to
stderr as each module is imported and as the teardown clears the modules; SIGINT goes to its group
when a chosen line is read. Loading: one line, ``station: interrupted ...``, exit 130, no
traceback. Teardown: before, the process died of SIGINT (-2) with no line and the command's code
lost (the sweep's ``validate`` once in 44, session 19); now the ended command's code stands and the
file it wrote is whole. (Before Python installs its handler, the first milliseconds of any
interpreter, SIGINT kills the process: -2, shown 130 by a shell; nothing of the project has run.)
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from tests.station.test_csv_unicode import MASS, _csv_text

REPO = Path(__file__).resolve().parents[2]
LINE = "station: interrupted"  # (what was saved is kept), once the command runs


def _interrupted_at(argv: list[str], cwd: Path, marker: str) -> tuple[int, list[str], str, bool]:
    """Run ``python -v -m station.cli ARGV``; SIGINT to its group at the first stderr line starting
    with ``marker``. (exit code, the station's own stderr lines, the whole stderr, sent)."""
    def setup() -> None:
        signal.signal(signal.SIGINT, signal.SIG_DFL)  # a background job may start with it ignored

    p = subprocess.Popen([sys.executable, "-v", "-m", "station.cli", *argv], cwd=cwd, text=True,
                         env={**os.environ, "PYTHONPATH": str(REPO)}, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, preexec_fn=setup, start_new_session=True)
    sent, err = False, []
    assert p.stderr is not None and p.stdout is not None
    for line in p.stderr:  # woken by each line the process writes
        err.append(line)
        if not sent and line.startswith(marker):
            os.killpg(p.pid, signal.SIGINT)
            sent = True
    p.stdout.read()
    rc = p.wait(timeout=600)
    ours = [ln.rstrip() for ln in err if ln.startswith("station")]
    return rc, ours, "".join(err), sent


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("ctrlc")
    (d / "c.csv").write_text(_csv_text(3, 20.0))
    (d / "m.json").write_text('{"schema_version": 1, "mass": 0.4, "damping": {"v": 2.5}, "stiffness": {"x": 9870.0}}')
    return d


# the command's module, then its engine (eddi's conditioning for any record; numpy's linear algebra;
# pydantic; the last of them): `import` at eddi.conditioning printed its line and then died of SIGINT (-2) before
LOADING = ["import 'station.commands", "import 'pydantic'", "import 'eddi.conditioning", "import 'numpy.linalg",
           "import 'eddi.validate'", "import 'station.session'"]


@pytest.mark.parametrize("marker", LOADING)
@pytest.mark.parametrize("command", ["validate", "import"])
def test_ctrl_c_while_loading_is_one_line_and_130(files: Path, command: str, marker: str) -> None:
    argv = (["validate", "m.json", "c.csv"] if command == "validate"
            else ["import", "c.csv", "--out", f"s-{abs(hash(marker))}.h5", "--mass", str(MASS)])
    rc, ours, err, sent = _interrupted_at(argv, files, marker)
    assert sent, f"no line {marker!r}: the moment was not reached"
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err[-3000:]
    assert rc == 130 and len(ours) == 1 and ours[0].startswith(LINE), (rc, ours)


def test_ctrl_c_in_the_teardown_keeps_the_commands_code_and_its_file(files: Path) -> None:
    from station.readers import read_measurement

    rc, ours, err, sent = _interrupted_at(["import", "c.csv", "--out", "t.h5", "--mass", str(MASS)], files,
                                          "# clear")  # the interpreter's teardown: the command has ended
    assert sent and "Traceback" not in err, err[-3000:]
    assert (rc, ours) == (0, []), (rc, ours)  # before: -2, killed by SIGINT
    assert read_measurement(f"{files / 't.h5'}:0").t.size > 1000
