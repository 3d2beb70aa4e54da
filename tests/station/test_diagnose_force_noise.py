"""A free-response part is not driven by the force sensor's noise after the blow.

Found on the blind unseen8 set's symptoms (session 11: a null of short, noisy captures said
`unexplained` at 1.1x its floor) and rebuilt here: a clean linear 1.7 kg, 18.6 Hz oscillator,
three 0.8 s captures at 2 kHz and 30 dB, blows of 40/60/80 N. The largest capture is judged as a
free response from where it decays into the training range (no extrapolation in amplitude); that
simulation was driven by the force channel after the blow, which is noise (30 dB of 80 N:
~2.5 N RMS), and a lightly damped structure integrates it: the true model of the records was
1.2 off there, the per-fold baseline 0.40 mean against the pipeline's own 0.018, and the verdict
`unexplained`. The pipeline validates with the force during the impact only; the part now too.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from station.cli import main
from tests.eddi.impact_cases import impact_record

MASS = 1.7
F_HZ = 18.0
SYSTEM = dict(mass=MASS, damping={"v": 2 * 0.02 * MASS * 2 * np.pi * F_HZ},
              stiffness={"x": MASS * (2 * np.pi * F_HZ) ** 2}, peak_n=60.0)


def _captures(tmp_path: Path) -> list[str]:
    out = []
    for i, peak in enumerate((40.0, 60.0, 80.0)):
        r = impact_record(SYSTEM, rate_hz=2000.0, duration_s=0.8, pretrigger_s=0.1, pulse_s=1e-3, snr_db=30.0,
                          peak_n=peak, seed=100 * i + 98)
        p = tmp_path / f"b{i}.csv"
        np.savetxt(p, np.column_stack((r.t, r.force, r.acc)), delimiter=",", header="t,force,acc", comments="",
                   fmt="%.9g")
        out.append(str(p))
    return out


def test_a_noisy_force_after_the_blow_drives_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["diagnose", *_captures(tmp_path), "--mass", str(MASS), "--json"])
    obj = json.loads(capsys.readouterr().out)
    assert code == 0
    judged = obj["judged_baseline"]["fold_nrmse"]
    # every fold near the pipeline's own held-out error (0.018), the largest blow's too
    assert max(judged) < 2.5 * obj["baseline"]["nrmse"], judged
    assert obj["cause"] == "none", obj["verdict"]
