"""A lab's export with a force channel and only 23 samples before the blow (the pre-trigger not
stated; 256 Hz): the quiet head before the force pulse is a rest, so the record is integrated
from rest and a friction ring-down that sticks after a few cycles is used for what it holds
(issue 10, item 4). Before, fewer than 32 quiet samples sent it to the integration about the
equilibrium, which needs 8 cycles: "no spectral peak with at least 8 cycles"."""

from __future__ import annotations

import math

import numpy as np

from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test
from station.cli import main


def test_a_sticking_ring_down_after_a_short_quiet_head_is_used(tmp_path, capsys) -> None:
    m, k1 = 834.0, 167820.0
    eom = EquationOfMotion.create(mass=m, damping={"v": 2 * 0.002 * math.sqrt(k1 * m)}, stiffness={"x": k1})
    r = impact_test(eom, 4000.0, rate_hz=256.0, pretrigger_s=0.09, record_s=60.0, seed=3,
                    effects=[{"name": "coulomb_friction", "params": {"force_n": 5.0}}])
    assert int(np.sum(r.t < 0)) < 32
    path = tmp_path / "export.csv"
    np.savetxt(path, np.c_[r.t, r.force_n, r.acc_m_s2], delimiter=",", header="t,force,acc", comments="",
               fmt="%.10g")
    code = main(["identify", str(path), "--mass", str(m), "--json"])
    err = capsys.readouterr().err
    assert code in (0, 1), err  # a result (flagged or not), not a refusal
    assert "no spectral peak" not in err and "Warning" not in err
