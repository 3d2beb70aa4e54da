"""A whole ``station diagnose`` process: engine loaded with the collector paused and scipy's
docstrings left as written, output flushed, then the process ends without the interpreter's
teardown unless it wrote files (:mod:`station.process`, issue 13 item 2)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test

REPO = Path(__file__).resolve().parents[2]
SYSTEM = EquationOfMotion.create(mass=0.1, damping={"v": 0.06}, stiffness={"x": 600.0, "x^3": 2e7})
FRICTION = {"name": "coulomb_friction", "params": {"force_n": 0.006}}

#: Runs ``station ARGV`` as the executable does (station.cli.run), counting the docstrings
#: scipy parses and reporting on stderr how the process ended (and the forked workers started).
PROBE = """
import atexit, gc, os, sys
import scipy._lib._docscrape as ds
parsed = [0]  # docstrings parsed for scipy's array-API decorator (its note)
real_init = ds.FunctionDoc.__init__
def counting(self, *a, **k):
    parsed[0] += sys._getframe(1).f_globals.get("__name__") == "scipy._lib._array_api"
    return real_init(self, *a, **k)
ds.FunctionDoc.__init__ = counting
import station.forkmap as fm
forked = [0]
real_call = fm.ForkMap.__call__
def call(self, fn, items):
    try:
        return real_call(self, fn, items)
    finally:
        forked[0] += self.forked
        self.forked = 0
fm.ForkMap.__call__ = call
atexit.register(lambda: sys.stderr.write(f"TEARDOWN {parsed[0]} {forked[0]}\\n"))
real_exit = os._exit
main_pid = os.getpid()  # (forked workers end through os._exit too: not reported)
def spy(code):
    if os.getpid() != main_pid:
        real_exit(code)
    sys.stderr.write(f"QUICK {code} {gc.get_freeze_count()} {gc.isenabled()} {parsed[0]} {forked[0]}\\n")
    sys.stderr.flush()
    real_exit(code)
os._exit = spy
sys.argv = ["station", *sys.argv[1:]]
from station.cli import run
run()
"""


def _capture(path: Path, force_n: float, seed: int) -> Path:
    r = impact_test(SYSTEM, force_n, rate_hz=5000.0, pretrigger_s=0.2, record_s=2.0, snr_db=40.0,
                    effects=[FRICTION], seed=seed)
    np.savetxt(path, np.column_stack((r.t, r.force_n, r.acc_m_s2)), delimiter=",",
               header="t,force,acc", comments="", fmt="%.10g")
    return path


def _station(argv: list[str], tmp: Path, **env: str) -> subprocess.CompletedProcess[str]:
    e = {**os.environ, "PYTHONPATH": str(REPO)}
    e.pop("PYTHONUNBUFFERED", None)  # stdout block-buffered, as a pipe is: it must be flushed
    e.pop("STATION_SERIAL", None)  # the caller's environment's; the test's own (below) is kept
    e.pop("STATION_JOBS", None)
    e.update(env)
    return subprocess.run([sys.executable, "-c", PROBE, *argv], capture_output=True, text=True, env=e,
                          timeout=600, cwd=tmp)


def _line(stderr: str, head: str) -> list[str] | None:
    for line in stderr.splitlines():
        if line.startswith(head + " "):
            return line.split()[1:]
    return None


@pytest.fixture(scope="module")
def captures(tmp_path_factory: pytest.TempPathFactory) -> list[str]:
    tmp = tmp_path_factory.mktemp("caps")
    return [str(_capture(tmp / "a.csv", 20.0, 0)), str(_capture(tmp / "b.csv", 30.0, 1))]


def test_diagnose_with_workers_ends_without_teardown_and_parses_no_scipy_docstring(
        captures: list[str], tmp_path: Path) -> None:
    """Fails on the old code: diagnose ended through the teardown (no quick line) and scipy's
    array-API decorator parsed ~650 docstrings while its subpackages imported."""
    argv = ["diagnose", *captures, "--mass", "0.1", "--mechanisms", "coulomb_friction", "--no-refine", "--json"]
    got = _station(argv, tmp_path, STATION_JOBS="2")
    assert got.returncode == 0, got.stderr[-800:]
    quick = _line(got.stderr, "QUICK")
    assert quick is not None and _line(got.stderr, "TEARDOWN") is None, got.stderr[-800:]
    code, frozen, enabled, parsed, forked = quick
    assert code == "0" and int(frozen) > 10000 and enabled == "True"
    assert parsed == "0"  # scipy.signal, stats, optimize, interpolate imported: none parsed for the note
    assert int(forked) >= 1  # the workers ran (and had ended: the output is all there)
    obj = json.loads(got.stdout)
    assert obj["captures"] == ["a.csv", "b.csv"] and obj["pipeline_baseline"]["validation"]["nrmse"] is not None


def test_diagnose_writing_a_model_ends_the_ordinary_way(captures: list[str], tmp_path: Path) -> None:
    """With --save-model the process ends through the teardown (files closed, atexit run), the
    engine still loaded quietly; stdout is what the quick end prints, plus the file's name.
    Fails with diagnose ended quickly whatever it writes."""
    base = ["diagnose", *captures, "--mass", "0.1", "--mechanisms", "coulomb_friction", "--no-refine", "--json"]
    quick = _station(base, tmp_path, STATION_SERIAL="1")
    saved = _station([*base, "--save-model", "m.json"], tmp_path, STATION_SERIAL="1")
    assert quick.returncode == saved.returncode == 0, saved.stderr[-800:]
    assert _line(saved.stderr, "QUICK") is None
    assert _line(saved.stderr, "TEARDOWN") == ["0", "0"]  # no docstring parsed, no worker in one process
    model = json.loads((tmp_path / "m.json").read_text())
    assert model["mass"] == pytest.approx(0.1)
    obj, ref = json.loads(saved.stdout), json.loads(quick.stdout)
    assert obj.pop("saved_model") == "m.json" and obj == ref


def test_plain_scipy_docs_keeps_functions_and_their_docstrings() -> None:
    """In a fresh interpreter: scipy's decorator registers every function as before and the
    docstrings read as written (the note dropped), with no docstring parsed; without the call
    the same imports parse hundreds."""
    code = """
import sys, time
import scipy._lib._docscrape as ds
parsed = [0]
real = ds.FunctionDoc.__init__
def counting(self, *a, **k):
    parsed[0] += sys._getframe(1).f_globals.get("__name__") == "scipy._lib._array_api"
    return real(self, *a, **k)
ds.FunctionDoc.__init__ = counting
if sys.argv[1] == "plain":
    from station.process import plain_scipy_docs
    assert plain_scipy_docs() is True
import scipy.signal, scipy.stats, scipy.optimize, scipy.interpolate, scipy.linalg
from scipy._lib._array_api import xp_capabilities_table
print(parsed[0], len(xp_capabilities_table), scipy.signal.welch in xp_capabilities_table,
      scipy.signal.welch.__doc__.splitlines()[0])
"""
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    out = {}
    for how in ("plain", "as-is"):
        got = subprocess.run([sys.executable, "-c", code, how], capture_output=True, text=True, env=env, timeout=300)
        assert got.returncode == 0, got.stderr[-800:]
        out[how] = got.stdout.split(maxsplit=3)
    parsed, registered, welch, first = out["plain"]
    assert parsed == "0" and welch == "True" and first.strip() == "Estimate power spectral density using Welch's method."
    assert registered == out["as-is"][1]  # the same functions registered
    assert int(out["as-is"][0]) > 300  # what the call saves
