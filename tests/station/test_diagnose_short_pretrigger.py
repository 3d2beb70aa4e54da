"""A heavy, slow structure logged with a short pre-trigger (26 samples at 512 Hz) and a hammer
that bounces a third of a period later: the conditioned state before the blow is the drift
removal's extrapolation, not rest, so a held-out part is simulated from the measured state
after the blows (as the pipeline validates such a record), and the null is `none`."""

from __future__ import annotations

import json
import math

import numpy as np

from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test
from simulated_rig.hammer import HammerSpec
from station.cli import main


def _bouncing_null(folder) -> list[str]:
    m, f1 = 246.0, 4.3
    k1 = m * (2 * math.pi * f1) ** 2
    eom = EquationOfMotion.create(mass=m, damping={"v": 0.02 * math.sqrt(k1 * m)},
                                  stiffness={"x": k1, "x^3": 0.2 * k1 / 1e-4})
    paths = []
    for i, (delay, ratio, peak) in enumerate([(0.0385, 0.26, 15072.0), (0.0286, 0.32, 14361.0),
                                              (0.0342, 0.21, 10592.0), (0.0615, 0.31, 9555.0),
                                              (0.0484, 0.33, 11820.0)]):
        hammer = HammerSpec(pulse_width_s=4e-3, double_hit_delay_s=delay, double_hit_ratio=ratio)
        r = impact_test(eom, peak, rate_hz=512.0, pretrigger_s=0.05, record_s=11.0, hammer=hammer,
                        double_hit=True, seed=10 + i)
        path = folder / f"b-{i}.csv"
        np.savetxt(path, np.c_[r.t, r.force_n, r.acc_m_s2], delimiter=",", header="t,force,acc",
                   comments="", fmt="%.10g")
        paths.append(str(path))
    return paths


def test_a_bouncing_null_with_a_short_pretrigger_is_none(tmp_path, capsys) -> None:
    # before: two parts driven "from rest" at the record's first sample, where the conditioned
    # state was x = -1.7 mm, v = 25 mm/s: held-out 0.34 (the true model 0.74 on one part)
    assert main(["diagnose", *_bouncing_null(tmp_path), "--mass", "246", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["cause"] == "none", d["verdict"]
    assert max(d["baseline"]["fold_nrmse"]) < 0.05
    hits = [s for s in d["symptoms"] if s["kind"] == "double_hit"]
    assert len(hits) == 5 and "hammer bounced" in d["verdict"]
