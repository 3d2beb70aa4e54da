"""``station diagnose`` on captures whose fit record is too short to refine (session 14): a verdict
with the pipeline's EDDI estimate and a warning that says why, not a refusal.

The captures are ``bench_diagnose_floor.py --snr 18,25`` coulomb_friction seed 300 (72.9 kg,
18.9 Hz at 256 Hz, 19 dB), written as CSV (time, force, acceleration): the fit record's free
response holds 42 samples for the library's 11 parameters (>= 44 needed). Old code: one line,
"output-error refinement of 11 parameters needs >= 44 compared values, got 42", no verdict.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from station.cli import main

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))


def test_too_short_fit_record_gets_a_verdict_and_a_warning(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from bench_diagnose_floor import recipe

    recs, info = recipe("coulomb_friction", 300, (18.0, 25.0))
    caps = []
    for i, r in enumerate(recs):
        p = tmp_path / f"c{i}.csv"
        np.savetxt(p, np.column_stack((r.t, r.force, r.a)), delimiter=",", header="t,force,acc", comments="",
                   fmt="%.10g")
        caps.append(str(p))
    code = main(["diagnose", *caps, "--mass", str(info["mass_kg"]), "--json"])
    out, err = capsys.readouterr()
    obj = json.loads(out)
    assert obj["cause"] == "unexplained"  # hidden friction: no `none`, no wrong name
    assert code == 1  # EDDI's 11-term model of 42 samples feeds energy in: flagged, as identify flags it
    short = [w for w in obj["warnings"] if w.startswith("the pipeline's model: the record is too short to refine")]
    assert len(short) == 1 and "11 parameters needs >= 44 compared values, got 42" in short[0]
    assert "EDDI's estimate, not refined" in short[0]
