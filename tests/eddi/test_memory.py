"""eddi.memory: freed large arrays stay with the process (no page faults for the next call's arrays)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

#: A child that conditions a short impact record through the Pipeline (the engine's entry point
#: sets the allocator), then five times makes ten arrays of 4 MB and drops them (as a call's
#: steps do): prints the page faults of the last four rounds.
CHILD = """
import json, resource, sys
import numpy as np
from eddi.fit_record import Pipeline
from simulated_rig.bench import impact_test
import eddi.memory as M
if sys.argv[1] == "pipeline":
    rec = impact_test("duffing-smooth", 600.0, snr_db=45.0, seed=1, rate_hz=2000.0, record_s=4.0)
    Pipeline().condition(rec.t, acc=rec.acc_m_s2, force=rec.force_n, pretrigger_samples=rec.pretrigger_samples)
def round_():
    arrays = [np.ones(500_000) for _ in range(10)]
    return sum(float(a[-1]) for a in arrays)
round_()  # the first touch of the memory the rounds reuse
f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(4):
    round_()
print(json.dumps({"faults": resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0, "set": M._STATE[0]}))
"""


def _child(mode: str, **env: str) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, mode], capture_output=True, text=True, check=True,
                         cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO), **env}).stdout
    return json.loads(out.strip().splitlines()[-1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's allocator")
def test_pipeline_keeps_freed_memory_for_the_next_arrays():
    # 40 arrays of 4 MB (977 pages each): by default glibc trims the 40 MB freed at the heap's top
    # after each round and the next round faults it in again (~39k faults)
    got = _child("pipeline")
    assert got["set"] is True
    assert got["faults"] < 200


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's allocator")
def test_opt_out_leaves_the_allocator_alone():
    got = _child("pipeline", EDDI_KEEP_FREED_MEMORY="0")
    assert got["set"] is False
    assert got["faults"] > 30 * 977  # glibc's default: each round's memory given back and faulted in again


def test_without_a_pipeline_nothing_is_set():
    got = _child("none")
    assert got["set"] is None
