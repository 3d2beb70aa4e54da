"""A linear null's ``none`` is judged against what the true equations leave, not the noise alone
(session 18; since session 19 the folds' floor of :mod:`eddi.mdof.predfloor`).

t13-nulln of ``benchmarks/bench_mdof_nulls.py --set tuning`` (a linear 0.78 + 0.29 kg chain, 4.06 / 9.83 Hz,
36 dB, four acceleration captures, no mass given): on main (fa3f89a) ``none (uncertain)``, the baseline
at 1.01x acc2's noise floor (0.0101 against the 0.01 clamp). The true equations leave 0.006-0.014 on
these captures, noise-free ones too: the measured impulse's uncertainty (force_floor 0.020-0.023 per
capture) that ``station validate`` counts and the verdict's noise floor did not.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from bench_mdof_nulls import draw  # noqa: E402
from simulated_rig.mdof_systems import mdof_impact_test  # noqa: E402
from station.mdof_commands import diagnose_mdof_object, diagnose_mdof_text  # noqa: E402


@pytest.mark.slow
def test_a_linear_null_within_its_prediction_floor_is_a_plain_none(tmp_path: Path) -> None:
    system, snr, row = draw("nulln", 13, "tuning")
    assert row["masses_kg"] == [0.7807, 0.2916]
    files = [str(mdof_impact_test(system, p, snr_db=snr, seed=13000 + k).write_csv(tmp_path / f"n{k}.csv"))
             for k, p in enumerate(system.impacts_n)]
    obj = diagnose_mdof_object(files, driving_point=f"acc{system.driving_point}", margin=0.5)
    assert obj["cause"] == "none" and obj["short_coupling"] is None
    assert obj["uncertain"] is False  # main: True (1.01x the noise floor)
    base, noise, pred = obj["baseline"]["channel_nrmse"], obj["noise_floor"], obj["prediction_floor"]
    assert max(base[c] / noise[c] for c in base) > 1.0  # above the noise floor alone
    assert all(pred[c] > 1.5 * noise[c] for c in pred)  # the impulse part counted
    assert all(base[c] < pred[c] for c in base)
    assert "Prediction floor per channel (nrmse, what a model identified from the other captures leaves held out " \
        "by the noise and the blows' impulse errors; the floor every verdict rule judges on): acc1 " in diagnose_mdof_text(obj)
