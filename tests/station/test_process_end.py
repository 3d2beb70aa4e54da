"""A whole ``station identify`` process: engine loaded with the collector paused, output flushed,
then the process ends without the interpreter's teardown (:mod:`station.process`, issue 13)."""

from __future__ import annotations

import gc
import json
import os
import subprocess
import sys
from pathlib import Path

from station.cli import QUICK_EXIT, main

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "station" / "examples" / "duffing-impact.csv"
#: A record whose identified model is flagged (exit code 1, tests/data/resonant-double-beam)
FLAGGED = REPO / "tests" / "data" / "resonant-double-beam" / "ringdown-05.csv"

#: Runs ``station ARGV`` as the executable does (station.cli.run), reporting on stderr how it ended.
PROBE = """
import atexit, gc, os, sys
atexit.register(lambda: sys.stderr.write("TEARDOWN\\n"))
real_exit = os._exit
def spy(code):
    heavy = [m for m in NOT_FOR_IDENTIFY if m in sys.modules]
    sys.stderr.write(f"QUICK {code} {gc.get_freeze_count()} {gc.isenabled()} {','.join(heavy) or '-'}\\n")
    sys.stderr.flush()
    real_exit(code)
os._exit = spy
NOT_FOR_IDENTIFY = {not_for_identify!r}
sys.argv = ["station", *sys.argv[1:]]
from station.cli import run
run()
"""

#: What a whole ``station identify`` process of a CSV record must not import (it draws nothing,
#: fits no SINDy, runs no campaign, reads no HDF5; scipy.signal: modal sums only; the diagnosis
#: loop: the impulse check reads eddi.diagnosis.chain alone). Session 16: nor the scipy
#: subpackages the path does not use (scipy.optimize's own imports bring linalg, sparse, special,
#: fft and spatial; stats ~0.1 s more, integrate: eddi.calculus has its functions, ndimage and io:
#: multi-DOF and .mat records only), nor threadpoolctl (the CLI starts BLAS with one thread,
#: eddi.threads: ~7 ms of look-up). Session 17: nor scipy.optimize and scipy.interpolate (the
#: refinement's Levenberg-Marquardt is eddi.lsq, the splines eddi.bspline: ~0.13 s of imports),
#: nor scipy.linalg (eddi.slow_errors' Cholesky is numpy's). Session 18: nor scipy.sparse (EDDI's drift
#: basis and its normal equations are eddi.bspline.BandedRows), nor scipy itself: its array-API layer
#: (numpy.f2py, numpy.testing, charset_normalizer; station.process no longer imports it for its
#: docstring patch) ~0.09 s quiet.
NOT_FOR_IDENTIFY = ("matplotlib", "pysindy", "dask", "distributed", "pyarrow", "h5py", "scipy.signal",
                    "eddi.diagnosis.loop", "eddi.diagnosis.catalogue", "scipy.stats", "scipy.integrate",
                    "scipy.ndimage", "scipy.io", "threadpoolctl", "scipy.optimize", "scipy.interpolate",
                    "scipy.linalg", "scipy.sparse", "scipy._lib._array_api", "scipy", "numpy.f2py",
                    "numpy.testing")
PROBE = PROBE.replace("{not_for_identify!r}", repr(NOT_FOR_IDENTIFY))

#: The same through main() alone (the ordinary end), for the reference output.
ORDINARY = """
import sys
from station.cli import main
sys.exit(main(sys.argv[1:]))
"""


def _env() -> dict[str, str]:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    env.pop("PYTHONUNBUFFERED", None)  # stdout block-buffered, as a pipe normally is: must be flushed
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        env.pop(var, None)  # the station's own default (one BLAS thread), not the caller's
    return env


def _station(code: str, argv: list[str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, env=_env(),
                          timeout=300)


def _ending(stderr: str) -> tuple[int, int, bool, str] | None:
    """(exit code, frozen objects, collector enabled, forbidden modules imported or "-") of the
    quick end, or None without one."""
    for line in stderr.splitlines():
        if line.startswith("QUICK "):
            code, frozen, enabled, heavy = line.split()[1:]
            return int(code), int(frozen), enabled == "True", heavy
    return None


def test_identify_ends_without_teardown_and_prints_the_same_bytes() -> None:
    """Fails on the old code: the process ended through the teardown (atexit ran, no quick end)."""
    argv = ["identify", str(EXAMPLE), "--mass", "0.815", "--no-refine", "--json"]
    quick, ordinary = _station(PROBE, argv), _station(ORDINARY, argv)
    assert quick.returncode == ordinary.returncode == 0, quick.stderr[-500:]
    assert quick.stdout == ordinary.stdout  # flushed before the end, byte for byte
    assert json.loads(quick.stdout)["validation"]["nrmse"] < 0.1
    ending = _ending(quick.stderr)
    assert ending is not None and "TEARDOWN" not in quick.stderr
    code, frozen, enabled, heavy = ending
    # the engine's modules were frozen out of the collector's walks, and collecting resumed
    assert code == 0 and frozen > 10_000 and enabled
    assert heavy == "-"  # the whole process, quiet load included, imports none of NOT_FOR_IDENTIFY


def test_a_flagged_result_keeps_its_exit_code_and_its_warning_line() -> None:
    argv = ["identify", str(FLAGGED), "--mass", "0.5", "--no-refine", "--json"]
    quick, ordinary = _station(PROBE, argv), _station(ORDINARY, argv)
    assert quick.returncode == ordinary.returncode == 1
    ending = _ending(quick.stderr)
    assert ending is not None and ending[0] == 1 and ending[2]
    assert quick.stdout == ordinary.stdout
    assert "exit code 1" in quick.stderr and quick.stderr.count("station identify:") == 1


def test_a_bad_input_ends_the_ordinary_way_with_one_line() -> None:
    quick = _station(PROBE, ["identify", str(REPO / "no-such-record.csv"), "--mass", "1"])
    assert quick.returncode == 2 and _ending(quick.stderr) is None
    lines = [ln for ln in quick.stderr.splitlines() if ln != "TEARDOWN"]
    assert lines == [f"station: error: {REPO / 'no-such-record.csv'}: no such file"]


def test_identify_help_loads_no_engine_in_a_whole_process() -> None:
    code = PROBE.replace("run()", "import station.cli as c; rc = c.main(sys.argv[1:], whole_process=True)\n"
                         "sys.stderr.write('ENGINE ' + str('scipy' in sys.modules) + '\\n')")
    res = _station(code, ["identify", "--help"])
    assert "usage: station identify" in res.stdout and "ENGINE False" in res.stderr and _ending(res.stderr) is None


def test_main_in_a_callers_interpreter_neither_freezes_nor_ends_it(capsys) -> None:  # type: ignore[no-untyped-def]
    frozen = gc.get_freeze_count()
    rc = main(["identify", str(EXAMPLE), "--mass", "0.815", "--no-refine", "--json"])
    assert rc == 0 and json.loads(capsys.readouterr().out)["mass"] == 0.815
    assert gc.get_freeze_count() == frozen and gc.isenabled()


def test_the_modules_loaded_up_front_are_ones_identify_imports_anyway() -> None:
    """The quiet load only moves imports earlier: an identify through main() alone imports them all."""
    mods = QUICK_EXIT["identify"]
    code = ORDINARY.replace("sys.exit(main(sys.argv[1:]))", "rc = main(sys.argv[1:])\n"
                            f"sys.stderr.write('MISSING ' + ','.join(m for m in {mods!r} "
                            "if m not in sys.modules) + '\\n')")
    res = _station(code, ["identify", str(EXAMPLE), "--mass", "0.815", "--no-refine", "--json"])
    missing = [ln for ln in res.stderr.splitlines() if ln.startswith("MISSING")]
    assert res.returncode == 0 and missing == ["MISSING "], res.stderr[-300:]


def test_validate_ends_the_same_quick_way(tmp_path: Path) -> None:
    """Fails without "validate" in QUICK_EXIT (the ordinary end: no quick line)."""
    model = _station(ORDINARY, ["identify", str(EXAMPLE), "--mass", "0.815", "--no-refine", "--json"])
    path = tmp_path / "model.json"
    path.write_text(json.dumps(json.loads(model.stdout)["model"]), encoding="utf-8")
    argv = ["validate", str(path), str(EXAMPLE), "--json"]
    quick, ordinary = _station(PROBE, argv), _station(ORDINARY, argv)
    assert quick.returncode == ordinary.returncode == 0, quick.stderr[-500:]
    assert quick.stdout == ordinary.stdout and json.loads(quick.stdout)["nrmse"] < 0.1
    ending = _ending(quick.stderr)
    assert ending is not None and ending[0] == 0 and ending[2] and ending[3] == "-"


def test_the_modules_validate_loads_up_front_are_ones_it_imports_anyway(tmp_path: Path) -> None:
    model = _station(ORDINARY, ["identify", str(EXAMPLE), "--mass", "0.815", "--no-refine", "--json"])
    path = tmp_path / "model.json"
    path.write_text(json.dumps(json.loads(model.stdout)["model"]), encoding="utf-8")
    mods = QUICK_EXIT["validate"]
    code = ORDINARY.replace("sys.exit(main(sys.argv[1:]))", "rc = main(sys.argv[1:])\n"
                            f"sys.stderr.write('MISSING ' + ','.join(m for m in {mods!r} "
                            "if m not in sys.modules) + '\\n')")
    res = _station(code, ["validate", str(path), str(EXAMPLE), "--json"])
    missing = [ln for ln in res.stderr.splitlines() if ln.startswith("MISSING")]
    assert res.returncode == 0 and missing == ["MISSING "], res.stderr[-300:]


def test_a_first_run_with_the_jit_still_leaves_numba_s_cache(tmp_path: Path) -> None:
    """numba writes its on-disk cache when it compiles, not at exit: ending without the teardown
    must not cost the next run a compile (index files of the simulation kernels present)."""
    env = {**_env(), "EDDI_JIT": "1", "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
    argv = ["identify", str(EXAMPLE), "--mass", "0.815", "--no-refine", "--json"]
    res = subprocess.run([sys.executable, "-c", PROBE, *argv], capture_output=True, text=True, env=env, timeout=600)
    assert res.returncode == 0 and _ending(res.stderr) is not None, res.stderr[-500:]
    index = sorted(p.name for p in (tmp_path / "numba-cache").rglob("*.nbi"))
    assert any("_rk4" in name for name in index), index
