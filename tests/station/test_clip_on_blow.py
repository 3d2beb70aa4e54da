"""An accelerometer overloaded by the blow alone: read, named, and no mass blamed."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from eddi.conditioning import clip_on_blow, clipped_run
from station.cli import main
from tests.eddi.impact_cases import impact_record

SYSTEM = {"mass": 2.0, "damping": {"v": 2 * 0.01 * 2.0 * 2 * np.pi * 20.0},
          "stiffness": {"x": 2.0 * (2 * np.pi * 20.0) ** 2}, "peak_n": 300.0}


def _clipped_on_blow():
    r = impact_record(SYSTEM, rate_hz=5000.0, duration_s=2.0, pretrigger_s=0.2, pulse_s=3e-3, snr_db=45.0, seed=2)
    acc = r.acc.copy()
    k = int(np.argmax(np.abs(r.force)))
    level = 0.7 * float(np.max(acc[k - 10:k + 10]))
    assert np.max(np.abs(np.delete(acc, np.arange(k - 20, k + 20)))) < level  # the ring-down stays inside
    acc[k - 20:k + 20] = np.minimum(acc[k - 20:k + 20], level)
    return r, acc


def test_a_run_during_the_blow_is_told_from_a_clipped_ring_down():
    r, acc = _clipped_on_blow()
    c = clipped_run(acc)
    assert c is not None and clip_on_blow(acc, r.force, c) is not None
    k = int(np.argmax(np.abs(r.force)))
    ring = np.clip(r.acc, -0.5 * np.max(np.abs(r.acc[k + 50:])), None)  # the ring-down's negative half cut
    c2 = clipped_run(ring)
    assert c2 is not None and clip_on_blow(ring, r.force, c2) is None
    assert clip_on_blow(acc, None, c) is None


def test_identify_reads_it_names_the_overload_and_blames_no_mass(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    # blind unseen10 (session 13): a 194 kg record flat for 7 samples while the force peaked was
    # refused as clipped; let through, the impulse check read a mass 21 % high
    r, acc = _clipped_on_blow()
    p = tmp_path / "blow.csv"
    np.savetxt(p, np.column_stack((r.t, r.force, acc)), delimiter=",", header="t,force,acc", comments="", fmt="%.9g")
    code = main(["identify", str(p), "--mass", str(SYSTEM["mass"]), "--json"])
    out, err = capsys.readouterr()
    assert code in (0, 1), err
    assert "during the hammer blow" in err
    obj = json.loads(out)
    assert obj["conditioning"]["impulse_check"]["fault"] == "clipped"
    warnings = " ".join(obj["warnings"])
    assert "clipped during the hammer blow" in warnings and "gives a mass of" not in warnings
    assert obj["model"]["stiffness"]["x"] == pytest.approx(SYSTEM["stiffness"]["x"], rel=0.02)
