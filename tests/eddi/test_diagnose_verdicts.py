"""Verdicts that are earned: a measurement-chain cause found and corrected, silence on a
multi-capture null, and out-of-catalogue physics that must come out ``unexplained`` (never a
confident wrong name).

Out-of-catalogue cases (the catalogue has no such mechanism): a Bouc-Wen hysteretic spring, a
smooth ``abs(x)*x`` stiffness measured with a baseline library that lacks it (look-alike of a
clearance), and an accelerometer behind two first-order high-passes (the catalogue's
``sensor_highpass`` is first order). The mechanism subsets keep each diagnosis to the
candidates that matter for the case (the hidden second mode, the slowest, is left out).
"""

from __future__ import annotations

import pytest

from eddi.diagnosis import NAMED_FACTOR, NONE_FACTOR, diagnose
from eddi.model import EquationOfMotion
from tests.eddi.diagnose_cases import DAMPING, STIFFNESS, SYSTEM, bouc_wen_records, rig_records

LOOKALIKES = ["coulomb_friction", "quadratic_damping", "clearance", "smooth_stiffening", "sensor_highpass"]


def contract(d) -> None:
    """The JSON contract of issue 10."""
    obj = d.to_dict()
    assert obj["cause"] in ("none", "unexplained") or obj["cause"] in {c["name"] for c in obj["candidates"]}
    for key in ("cause", "noise_floor", "candidates", "symptoms"):
        assert key in obj
    assert obj["noise_floor"]["nrmse"] > 0
    assert obj["baseline"]["nrmse"] >= 0 and obj["extended"]["nrmse"] >= 0
    if obj["cause"] != "none":
        assert "follows" not in obj["symptom"] and "follows" not in obj["verdict"]


def test_ac_coupled_accelerometer_is_named_and_its_corner_estimated() -> None:
    recs = rig_records(6, highpass_hz=0.5)
    d = diagnose(recs, SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS, mechanisms=LOOKALIKES)
    contract(d)
    assert d.cause == "sensor_highpass", d.verdict
    assert d.extended.nrmse <= 0.5 * d.baseline.nrmse
    assert d.extended.nrmse <= NAMED_FACTOR * d.noise_floor.nrmse
    # estimated from the records alone (no metadata): grid 0.1-3.6 Hz in steps of about 1.8x
    hp = next(c for c in d.candidates if c.name == "sensor_highpass")
    assert 0.3 <= hp.params["corner_hz"] <= 1.1


def test_six_captures_from_two_acquire_runs_give_none() -> None:
    recs = rig_records(5, runs=2, record_s=2.0)
    assert len(recs) == 6
    d = diagnose(recs, SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS, mechanisms=LOOKALIKES)
    contract(d)
    assert d.cause == "none", d.verdict
    assert d.baseline.nrmse <= NONE_FACTOR * d.noise_floor.nrmse
    assert "follows" in d.symptom


def test_hysteretic_spring_is_unexplained_never_drag() -> None:
    d = diagnose(bouc_wen_records(1), SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS,
                 mechanisms=LOOKALIKES)
    contract(d)
    assert d.cause == "unexplained", d.verdict
    assert d.partial != "quadratic_damping"
    kinds = {s.kind for s in d.symptoms}
    assert {"frequency_bias", "energy_mismatch", "growth"} <= kinds


def test_smooth_abs_stiffness_is_not_called_clearance() -> None:
    truth = EquationOfMotion.create(mass=0.1, damping={"v": 0.06}, stiffness={"x": 600.0, "abs(x)*x": 1.5e5})
    d = diagnose(rig_records(2, system=truth), SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS,
                 mechanisms=LOOKALIKES)
    contract(d)
    assert d.cause in ("smooth_stiffening", "unexplained"), d.verdict
    names = [c.name for c in d.candidates]
    assert "clearance" in names and "smooth_stiffening" in names  # the look-alikes were compared


def test_two_high_passes_are_not_a_physical_mechanism() -> None:
    recs = rig_records(3, highpass_hz=0.5, second_highpass_hz=0.5)
    d = diagnose(recs, SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS, mechanisms=LOOKALIKES)
    contract(d)
    assert d.cause in ("sensor_highpass", "unexplained"), d.verdict


@pytest.mark.parametrize("seed", [7])
def test_short_sticking_friction_ring_down_is_used(seed: int) -> None:
    """A friction ring-down that sticks after a few cycles is data, not an error."""
    from eddi.model import Effect

    recs = rig_records(seed, forces=(4.0, 5.0, 6.0), record_s=1.5,
                       effects=[Effect(name="coulomb_friction", params={"force_n": 0.03})])
    d = diagnose(recs, SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS,
                 mechanisms=["coulomb_friction", "quadratic_damping"])
    contract(d)
    assert d.cause in ("coulomb_friction", "unexplained"), d.verdict
