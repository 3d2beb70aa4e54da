"""Every benchmark script answers --help without running (and without writing anything)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SCRIPTS = sorted(p.name for p in (REPO / "benchmarks").glob("*.py"))


@pytest.mark.parametrize("script", SCRIPTS)
def test_benchmark_answers_help(script: str) -> None:
    before = {p: p.stat().st_mtime_ns for p in (REPO / "station" / "examples").glob("*")}
    res = subprocess.run([sys.executable, str(REPO / "benchmarks" / script), "--help"], capture_output=True,
                         text=True, timeout=300, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert res.returncode == 0, res.stderr[-1500:]
    assert res.stdout.startswith("usage:") and "Traceback" not in res.stderr
    assert {p: p.stat().st_mtime_ns for p in (REPO / "station" / "examples").glob("*")} == before
