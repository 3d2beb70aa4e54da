"""A weak coupling the coupled model catches in part is not called ``none``; its linear null is
(session 18, :mod:`station.mdof_verdict`).

Case t8-up2 of ``benchmarks/bench_mdof_modes.py --set tuning``: a 6.37 kg mass grounded, a 1.73 kg mass
on it through a spring with a cubic term (9.7 % of its linear force at the largest blow), modes
7.27 / 24.5 Hz, struck at the heavy mass, three 1.6 s velocity captures at 40.9 dB, 10 kHz, no mass
given. On main (fa3f89a): ``none (uncertain)`` - the baseline 1.4-1.5x its channels' floors held
out, the coupled model better on 2 of 3 folds (the third a tie), removing 27 % of the error above the
floor (raw gain 15 %, margin 50 %; mode 2 0.046 -> 0.018 against a floor of 0.010). The same profile
as two blind records the scorer expects a coupling on. Now ``unexplained`` with that evidence. The
same chain without the cubic stays ``none``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from bench_mdof_modes import draw, write  # noqa: E402
from station.mdof_commands import diagnose_mdof_object, diagnose_mdof_text  # noqa: E402


def _diagnose(kind: str, tmp_path: Path) -> dict:
    system, snr, quantity, facts = draw(kind, 8, "tuning")
    assert facts["masses_kg"] == [6.3735, 1.7265] and quantity == "vel" and facts["drive"] == 1
    files = [str(write(system, peak, snr, quantity, 8000 + k, tmp_path / f"{kind}-{k}.csv", mm=bool(k % 2)))
             for k, peak in enumerate(system.impacts_n)]
    return diagnose_mdof_object(files, driving_point="vel1", margin=0.5, refine=False)


@pytest.mark.slow
def test_a_weak_coupling_caught_in_part_is_unexplained_not_none(tmp_path: Path) -> None:
    obj = _diagnose("up2", tmp_path)
    assert obj["cause"] == "unexplained" and obj["uncertain"] is False  # main: none (uncertain)
    ev = obj["short_coupling"]
    assert ev is not None and ev["folds"] == 3 and ev["better_folds"] >= 2
    assert 0.2 <= ev["excess_gain"] < 0.5 and obj["raw_gain"] < 0.5
    assert ev["ratio"] > 1.2 and ev["coupling_terms_folds"] >= 2
    assert any(s["kind"] == "coupled_gain_short" for s in obj["symptoms"])
    text = diagnose_mdof_text(obj)
    assert "Cause: unexplained\n" in text + "\n" or "Cause: unexplained " in text
    assert "unexplained, not none" in text and "better on" in text


@pytest.mark.slow
def test_the_same_chain_without_the_cubic_stays_none(tmp_path: Path) -> None:
    obj = _diagnose("lin2", tmp_path)
    assert obj["cause"] == "none" and obj["short_coupling"] is None
