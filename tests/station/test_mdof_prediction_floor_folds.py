"""Every MDOF verdict rule judges against the prediction floor of the held-out folds (session 19,
:mod:`eddi.mdof.predfloor`): the noise and the blows' impulse errors as each fold meets them (the
held-out blow's and the training blows' mean, expected or as realized within 3 sigma).

t11-nulln of ``benchmarks/bench_mdof_nulls.py --set tuning`` (a linear 0.45 + 0.11 kg chain, 6.27 /
17.76 Hz, 36.6 dB, four acceleration captures of 0.5-1.3 N, no mass given): the true model is in the
identified class, yet on main (ce394eb) ``none (uncertain)`` at 1.2-1.3x the session-18 prediction
floor. The training blows' impulse errors (force noise) reach every fold's modal masses, and the
draws (1.4 and 2.9 u on the first two blows) are no expectation: the fold holding out the first blow
leaves 0.019, its floor now 0.019 (session 18: 0.01). t14-weakn (the same family with a 4.1 % cubic
coupling spring) is still named.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from bench_mdof_nulls import draw  # noqa: E402
from simulated_rig.mdof_systems import mdof_impact_test  # noqa: E402
from station.mdof_commands import diagnose_mdof_object  # noqa: E402


def _diagnose(kind: str, seed: int, tmp_path: Path) -> dict:
    system, snr, _row = draw(kind, seed, "tuning")
    files = [str(mdof_impact_test(system, p, snr_db=snr, seed=1000 * seed + k).write_csv(tmp_path / f"{kind}{k}.csv"))
             for k, p in enumerate(system.impacts_n)]
    return diagnose_mdof_object(files, driving_point=f"acc{system.driving_point}", margin=0.5)


@pytest.mark.slow
def test_a_linear_null_is_judged_against_the_blows_as_the_folds_meet_them(tmp_path: Path) -> None:
    obj = _diagnose("nulln", 11, tmp_path)
    assert obj["cause"] == "none" and obj["short_coupling"] is None
    base, pred, parts = obj["baseline"]["channel_nrmse"], obj["prediction_floor"], obj["floor_parts"]
    noise = obj["noise_floor"]  # what every rule but the none judgement compared with on main (the 0.01 clamp)
    assert max(base[c] / noise[c] for c in base) > 1.2  # main: 1.24-1.29x
    assert max(base[c] / pred[c] for c in base) < 1.06  # now 1.04 (the folds' scatter of frequencies and
    assert all(pred[c] > 1.15 * noise[c] for c in base)  # damping is not counted: docs/multi-dof.md)
    assert all(parts["realized"][c] > 0.0 and parts["blow"][c] > 0.01 for c in base)


@pytest.mark.slow
def test_a_weak_coupling_of_the_same_family_is_still_named(tmp_path: Path) -> None:
    obj = _diagnose("weakn", 14, tmp_path)
    assert obj["cause"] == "modal_coupling"
    assert obj["prediction_floor"] and obj["floor_parts"]["blow"]
