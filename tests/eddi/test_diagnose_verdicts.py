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
from eddi.errors import SignalError
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
    # estimated from the records alone (no metadata): grid 0.1-5 Hz in steps of 1.43x
    hp = next(c for c in d.candidates if c.name == "sensor_highpass")
    assert 0.35 <= hp.params["corner_hz"] <= 0.85
    # the coupling itself makes the cut: its fold models without it are more than twice as far off
    assert hp.params["coupling_cut"] >= 0.5


def test_six_captures_from_two_acquire_runs_give_none() -> None:
    recs = rig_records(5, runs=2, record_s=2.0)
    assert len(recs) == 6
    d = diagnose(recs, SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS, mechanisms=LOOKALIKES)
    contract(d)
    assert d.cause == "none", d.verdict
    assert d.baseline.nrmse <= NONE_FACTOR * d.noise_floor.nrmse
    assert ("follows" in d.symptom) == (d.baseline.nrmse <= d.noise_floor.nrmse), d.symptom
    assert ("uncertain" in d.verdict) == (d.baseline.nrmse > d.noise_floor.nrmse)


def test_hysteretic_spring_is_unexplained_never_drag() -> None:
    d = diagnose(bouc_wen_records(1), SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS,
                 mechanisms=LOOKALIKES)
    contract(d)
    assert d.cause == "unexplained", d.verdict
    assert d.partial != "quadratic_damping"
    # the held-out simulation starts at the impact and is compared over the free response (as
    # the pipeline validates): this baseline grows from there and never passes through the
    # measured amplitudes, so the symptoms at matched amplitude are absent; the growth is said
    kinds = {s.kind: s for s in d.symptoms}
    assert {"growth", "residual_peak"} <= set(kinds)
    assert kinds["growth"].values["ratio"] > 1.5


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
    """A friction ring-down that sticks after a few cycles is data, not an error: it is
    conditioned (3 crossings suffice), judged as a held-out part, and a library it cannot
    support is refused in one line that says what to do."""
    from eddi.model import Effect

    recs = rig_records(seed, forces=(4.0, 5.0, 6.0), record_s=1.5,
                       effects=[Effect(name="coulomb_friction", params={"force_n": 0.03})])
    from eddi.energy import zero_crossings

    crossings = [zero_crossings(r.t[r.free_start:r.free_stop], r.x[r.free_start:r.free_stop],
                                r.v[r.free_start:r.free_stop]).size for r in recs]
    assert min(crossings) < 6  # refused before ("record has 5 zero crossings")
    # a short record holds few half cycles: a small library is what it can support
    d = diagnose(recs, SYSTEM.mass, damping="v", stiffness="x,x^3",
                 mechanisms=["coulomb_friction", "quadratic_damping"])
    contract(d)
    assert d.scheme == "leave-one-record-out" and len(d.parts) == 3
    # used for what they hold: judged, never a wrong physical name (on this seed the floor of
    # such short records, 0.19, is too high to tell the friction: docs/diagnosis.md limits)
    assert d.cause in ("coulomb_friction", "unexplained", "none"), d.verdict
    assert d.noise_floor.nrmse > 0.05  # short, re-conditioned records: a high floor, stated
    with pytest.raises(SignalError, match="give fewer terms"):
        diagnose(recs, SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS, mechanisms=["coulomb_friction"])
