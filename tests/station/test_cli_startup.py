"""``station --help`` / ``--version``: plain text, and no heavy import on paths that do not need it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from station.cli import COMMANDS, main

REPO = Path(__file__).resolve().parents[2]
HEAVY = ("numpy", "scipy", "numba", "matplotlib", "pysindy", "h5py", "pydantic", "scipy.signal", "dask",
         "distributed", "pyarrow", "eddi.diagnosis.loop", "eddi.diagnosis.catalogue")
#: What analysis commands' ``--help`` must not import (numpy is allowed): the engine's libraries.
ENGINE = {"scipy", "numba", "pydantic", "matplotlib", "pysindy", "dask", "distributed", "h5py", "pyarrow"}


def _modules_after(argv: list[str]) -> tuple[int, set[str], str]:
    """Run ``station ARGV`` in a fresh interpreter; (exit code, heavy modules it imported, stdout)."""
    code = (
        "import sys, json\n"
        "from station.cli import main\n"
        "try:\n"
        f"    rc = main({argv!r})\n"
        "except SystemExit as e:\n"
        "    rc = e.code\n"
        f"print(json.dumps([rc, sorted(m for m in {HEAVY!r} if m in sys.modules)]), file=sys.stderr)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    rc, heavy = json.loads(res.stderr.strip().splitlines()[-1])
    return rc, set(heavy), res.stdout


def test_top_level_help_imports_no_command_and_no_heavy_library() -> None:
    rc, heavy, out = _modules_after(["--help"])
    assert rc == 0 and heavy == set()
    for name in COMMANDS:
        assert f"\n    {name} " in out, name


@pytest.mark.parametrize("command", ["acquire", "demo", "rig", "devices"])
def test_acquisition_commands_help_imports_no_engine(command: str) -> None:
    rc, heavy, out = _modules_after([command, "--help"])
    assert rc == 0 and f"usage: station {command}" in out
    assert not heavy & {"numba", "matplotlib", "pysindy", "scipy"}, heavy


@pytest.mark.parametrize("command", ["identify", "validate", "diagnose", "report", "replay", "campaign", "export"])
def test_analysis_commands_help_imports_no_engine(command: str) -> None:
    """Issue 13: ``--help`` of a command that runs the engine does not load it (~1 s of CPU)."""
    rc, heavy, out = _modules_after([command, "--help"])
    assert rc == 0 and f"usage: station {command}" in out
    assert not heavy & ENGINE, heavy


def test_identify_on_a_csv_imports_only_what_it_uses() -> None:
    """A CSV record: no HDF5, no figures, no SINDy, no Dask, no scipy.signal (modal sums only)."""
    csv = REPO / "station" / "examples" / "duffing-impact.csv"
    rc, heavy, out = _modules_after(["identify", str(csv), "--mass", "0.815", "--no-refine", "--json"])
    assert rc == 0 and json.loads(out)["validation"]["nrmse"] < 0.1
    assert "numpy" in heavy  # it did identify and simulate (numba: unless the kernels are
    # built ahead of time, tests/eddi/test_kernels.py)
    # session 18: no scipy at all (EDDI's drift basis is eddi.bspline.BandedRows, not scipy.sparse)
    assert not heavy & {"matplotlib", "pysindy", "dask", "distributed", "h5py", "pyarrow", "scipy"}, heavy
    # the impulse check reads eddi.diagnosis.chain alone: not the diagnosis loop and its mechanisms
    # (session 12: ~40-60 ms of every identify process; eddi.diagnosis's names load on first use)
    assert not heavy & {"eddi.diagnosis.loop", "eddi.diagnosis.catalogue"}, heavy


def test_diagnose_help_constants_are_the_engines() -> None:
    """``station diagnose`` writes three engine constants out so that ``--help`` stays light."""
    from eddi import diagnosis
    from station.commands import diagnose

    assert diagnose.ALL_NAMES == diagnosis.ALL_NAMES
    assert diagnose.FITS == diagnosis.FITS
    assert diagnose.DEFAULT_MARGIN == diagnosis.DEFAULT_MARGIN


def test_version_is_printed_and_exits_0(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--version"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("station ") and len(out.split()) == 2


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_help_of_every_command_is_plain_text(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main([command, "--help"]) == 0
    out = capsys.readouterr().out
    assert f"usage: station {command}" in out
    for markup in (":mod:`", ":func:`", ":class:`", ":data:`", ":meth:`", "``"):
        assert markup not in out, (command, markup)


def test_unknown_command_is_one_line_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["idnetify", "x.csv"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "invalid choice: 'idnetify'" in err


def test_without_matplotlib_report_is_one_line_and_the_demo_text_says_skipped(tmp_path: Path) -> None:
    """matplotlib is the ``report`` extra: a command that needs it says so in one line."""
    csv = REPO / "station" / "examples" / "duffing-impact.csv"
    code = ("import sys; sys.modules['matplotlib'] = None\n"
            "from station.cli import main\n"
            f"sys.exit(main(['report', {str(csv)!r}, '--mass', '0.815', '--out', {str(tmp_path / 'r')!r}]))\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PYTHONPATH": str(REPO)})
    assert res.returncode == 2, res.stderr[-2000:]
    assert res.stderr.count("\n") == 1 and 'pip install "eddi-station[report]"' in res.stderr
    from station.demo import NO_REPORT, demo_text

    obj = {"device": "sim://x", "captures": 3, "levels_n": [1.0], "paths": {"session": "s.h5", "model": "m.json",
           "report": None, "figures": []}, "dropped_samples": 0, "link_dropped_samples": 0, "crc_errors": 0,
           "fit_capture": "s.h5:1", "method": "EDDI", "identified": {"equation": "eq", "damping": {}, "stiffness": {}},
           "validation": {"held_out": [], "nrmse": None}, "elapsed_s": {"total": 1.0}}
    assert demo_text(obj).splitlines()[-2] == NO_REPORT


def test_identify_help_imports_no_numpy() -> None:
    """Its default terms come from eddi.term_defaults, not eddi.terms (numpy: ~0.05 s of CPU).
    Fails when the command reads them from eddi.terms again."""
    rc, heavy, out = _modules_after(["identify", "--help"])
    assert rc == 0 and "v,x^2*v,v^3" in out and "x,x^2,x^3,x^4,x^5" in out
    assert heavy == set(), heavy
