"""A cubic spring to the ground is no coupling: ``station diagnose`` does not name one.

Session 14 (issue 14). Held-out case h7-ground of ``benchmarks/bench_mdof_nulls.py`` (found by
s13mnull): a 7.30 + 3.75 kg chain (modes 7.07 and 17.0 Hz, 0.8 % damped) whose grounded spring on
mass 1 has a cubic term (2.2 % of its linear force at the largest blow), 41 dB, acc only, no mass
given. Before: ``modal_coupling`` at a held-out gain of 68 %. The baseline (no nonlinear coupling)
has no cubic spring to the ground that fits (uncoupled modes; physical coordinates joined by linear
springs), so it leaves 0.028 on both channels while the coupled model, a lumped fit with the
ground cubic, leaves 0.0045; but the coupled models of the folds hold no nonlinear term between the
masses: only the final fit on every capture held one (a spurious -1.2e11 +- 0.55e11 N/m^3 cubic
between the masses), and the verdict named it. Now the gain must be earned by fold models that
hold a nonlinear coupling (on more than half of the folds): the gain is real, it is not evidence of
a coupling.
"""

from __future__ import annotations

import json

from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test
from station.cli import main


def test_a_cubic_spring_to_the_ground_is_not_named_a_coupling(tmp_path, capsys):
    system = MdofSystem(name="h7-ground", masses_kg=(7.2986201718948305, 3.7525525343101025),
                        elements=(Element(between=(0, 1), k=24961.153188247965, k3=3.014e11, c=9.243938827025472),
                                  Element(between=(1, 2), k=24716.62903693529, c=9.153383463680765)),
                        driving_point=1, rate_hz=5000.0, pretrigger_s=0.02, record_s=4.0,
                        impacts_n=(5.08, 4.72, 11.5, 8.0), tip="rubber")
    files = [str(mdof_impact_test(system, p, snr_db=41.2, seed=7000 + k).write_csv(tmp_path / f"g{k}.csv"))
             for k, p in enumerate(system.impacts_n)]
    assert main(["diagnose", *files, "--json", "--no-refine", "--driving-point", "acc1", "--margin", "0.5"]) == 0
    obj = json.loads(capsys.readouterr().out)
    assert obj["cause"] == "none"  # was modal_coupling (gain 68 %)
    assert obj["raw_gain"] > 0.5  # the gain is real: the ground cubic
    assert any("on 0 of 4 folds only" in n for n in obj["notes"])
    # the cubic spring to the ground (truth 3.014e11 N/m^3) is in the delivered model
    ground = [m for m in obj["mechanisms"] if m["element"] == "k3(0-1)"]
    assert len(ground) == 1 and abs(ground[0]["value"] / 3.014e11 - 1) < 0.1
    assert "mechanism" not in obj or not obj["mechanism"]
