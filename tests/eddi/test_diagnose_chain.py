"""Measurement-chain findings: double hits, clipping, base motion and a wrong mass are reported
with numbers (checked on rig records; no fitting, so these run in seconds), and silent on a
clean capture."""

from __future__ import annotations

import pytest

from eddi.diagnosis.chain import inspect
from eddi.model import EquationOfMotion
from tests.eddi.diagnose_cases import SYSTEM, rig_records


def kinds(symptoms) -> list[str]:
    return [s.kind for s in symptoms]


def test_clean_captures_raise_nothing() -> None:
    recs = rig_records(31, forces=(20.0, 30.0), record_s=1.5)
    assert inspect(recs, SYSTEM.mass, 12.3) == []


def test_double_hit_is_reported_with_its_delay() -> None:
    recs = rig_records(32, forces=(25.0,), record_s=1.5, double_hit=True)
    found = [s for s in inspect(recs, SYSTEM.mass, 12.3) if s.kind == "double_hit"]
    assert len(found) == 1
    # the rig's hammer: second pulse 4 ms after the first, 30 % of its peak
    assert found[0].values["delay_s"] == pytest.approx(4e-3, abs=3e-4)
    assert found[0].values["ratio"] == pytest.approx(0.3, abs=0.05)


def test_clipping_is_reported_on_the_overloaded_channel() -> None:
    recs = rig_records(33, forces=(30.0,), record_s=1.5, acc_range=8.0)
    found = [s for s in inspect(recs, SYSTEM.mass, 12.3) if s.kind == "clipping"]
    assert len(found) == 1 and "acceleration" in found[0].text
    assert found[0].values["samples"] >= 5


def _blow_peak(force: float) -> float:
    """Peak acceleration [m/s^2] of a noise-free blow on SYSTEM at the test rate."""
    import numpy as np

    from simulated_rig.bench import impact_test
    from tests.eddi.diagnose_cases import RATE_HZ

    r = impact_test(SYSTEM, force, rate_hz=RATE_HZ, pretrigger_s=0.05, record_s=0.3, snr_db=None, seed=0)
    return float(np.max(np.abs(r.acc_m_s2)))


def test_short_clipping_of_the_blow_is_reported() -> None:
    """A 1 ms blow at 5 kHz cut at 70 % of its acceleration peak is flat for 2 samples only
    (fewer than clipped_run's 5): two captures flat at the same level are the converter's
    limit (session 7 missed it at 5 kHz); the same captures with the range above the peak
    say nothing."""
    rng = 0.7 * _blow_peak(30.0)
    recs = rig_records(37, forces=(25.0, 30.0), record_s=1.0, acc_range=rng)
    found = [s for s in inspect(recs, SYSTEM.mass, 12.3) if s.kind == "clipping"]
    assert len(found) == 2 and all("acceleration" in s.text for s in found)
    assert all(2 <= s.values["samples"] < 5 for s in found)
    assert all(abs(s.values["level"]) == pytest.approx(rng, rel=0.02) for s in found)
    clean = rig_records(37, forces=(25.0, 30.0), record_s=1.0, acc_range=1.5 * _blow_peak(30.0))
    assert "clipping" not in kinds(inspect(clean, SYSTEM.mass, 12.3))


def test_coarse_quiet_channel_repeating_its_peak_is_not_clipping() -> None:
    """A 12-bit capture with less noise than a quantum repeats values by itself; a 3-sample
    repeat at its peak is not read as clipping there (the plateau needs 100 quanta of noise
    at rest), while the same repeat on the 24-bit noisy capture is."""
    import dataclasses

    import numpy as np

    recs = rig_records(38, forces=(25.0, 30.0), record_s=1.0, snr_db=60.0)
    q = 2 * _blow_peak(30.0) / 2 ** 11  # 12 bits over +-the peak: more than the noise
    coarse = []
    for r in recs:
        a = np.round(r.a / q) * q
        k = int(np.argmax(np.abs(a)))
        a[k + 1:k + 3] = a[k]  # the two samples after the peak equal to it
        coarse.append(dataclasses.replace(r, a=a))
    assert "clipping" not in kinds(inspect(coarse, SYSTEM.mass, 12.3))
    # the same repeat on the 24-bit, noisy captures is read as the converter's limit
    noisy = []
    for r in recs:
        a = r.a.copy()
        k = int(np.argmax(np.abs(a)))
        a[k + 1:k + 3] = a[k]
        noisy.append(dataclasses.replace(r, a=a))
    assert "clipping" in kinds(inspect(noisy, SYSTEM.mass, 12.3))


def test_base_motion_is_reported_at_its_frequency() -> None:
    recs = rig_records(34, forces=(25.0,), record_s=3.0,
                       base_motion={"mass_kg": 2.0, "frequency_hz": 1.5, "damping_ratio": 0.05})
    found = [s for s in inspect(recs, SYSTEM.mass, 12.3) if s.kind == "base_motion"]
    assert len(found) == 1
    assert found[0].values["frequency_hz"] == pytest.approx(1.5, abs=0.4)


def test_mass_that_disagrees_with_the_hammer_impulse() -> None:
    recs = rig_records(35, forces=(20.0, 30.0), record_s=1.0)
    assert "impulse_mass" not in kinds(inspect(recs, SYSTEM.mass, 12.3))
    found = [s for s in inspect(recs, 1.5 * SYSTEM.mass, 12.3) if s.kind == "impulse_mass"]
    assert len(found) == 1
    assert found[0].values["impulse_mass_kg"] == pytest.approx(SYSTEM.mass, rel=0.08)
    assert found[0].values["mismatch_pct"] == pytest.approx(-33.3, abs=6.0)


def test_five_percent_mass_error_is_reported_and_the_right_mass_is_not() -> None:
    """The tolerance is 2.5 % (3.5x the worst null bias, 0.72 %, session 8): a stated mass 5 %
    high reads as a -4.8 % mismatch and is reported; the true mass and one 1 % off are not."""
    recs = rig_records(35, forces=(20.0, 25.0, 30.0), record_s=1.0)
    assert "impulse_mass" not in kinds(inspect(recs, SYSTEM.mass, 12.3))
    assert "impulse_mass" not in kinds(inspect(recs, 1.01 * SYSTEM.mass, 12.3))
    found = [s for s in inspect(recs, 1.05 * SYSTEM.mass, 12.3) if s.kind == "impulse_mass"]
    assert len(found) == 1
    assert found[0].values["mismatch_pct"] == pytest.approx(100 * (1 / 1.05 - 1), abs=0.8)


def test_accelerometer_sensitivity_ten_percent_high_is_reported() -> None:
    """A 10 % sensitivity error (the acceleration read 1.1x) reads as a mass 1/1.1 of the
    given one; the former 15 % tolerance did not say it (own look-alike case, s5)."""
    import dataclasses

    recs = [dataclasses.replace(r, x=1.1 * r.x, v=1.1 * r.v, a=1.1 * r.a) for r in rig_records(36, forces=(20.0, 30.0), record_s=1.0)]
    found = [s for s in inspect(recs, SYSTEM.mass, 12.3) if s.kind == "impulse_mass"]
    assert len(found) == 1
    assert found[0].values["mismatch_pct"] == pytest.approx(100 * (1 / 1.1 - 1), abs=2.5)


def test_heavy_base_near_a_quarter_of_f1_is_reported_by_the_whole_loop() -> None:
    """A base of twice the oscillator's mass on a suspension at 0.25 f1 (my own case: 0.1 kg,
    14 Hz, 45 dB). The baseline fitted to these records has a wrong frequency, and the base
    motion used to be looked for below that one: only ``growth`` was said."""
    import math

    from eddi.diagnosis import diagnose

    m, f1 = 0.1, 14.0
    k1 = m * (2 * math.pi * f1) ** 2
    truth = EquationOfMotion.create(mass=m, damping={"v": 2 * 0.005 * math.sqrt(k1 * m)}, stiffness={"x": k1})
    recs = rig_records(36, system=truth, forces=(20.0, 30.0), record_s=2.0, snr_db=45.0,
                       base_motion={"mass_kg": 2 * m, "frequency_hz": 0.25 * f1, "damping_ratio": 0.05})
    d = diagnose(recs, m, damping="v", stiffness="x,x^3", mechanisms=["coulomb_friction"])
    assert d.cause != "none" and d.cause != "coulomb_friction", d.verdict
    found = [s for s in d.symptoms if s.kind == "base_motion"]
    assert len(found) == 2  # one per record, with numbers
    for s in found:
        assert s.values["frequency_hz"] == pytest.approx(0.25 * f1, rel=0.2)
        assert s.values["share_pct"] > 2.0
    obj = d.to_dict()
    assert obj["baseline"]["nrmse"] is not None or obj["baseline"]["nrmse_reason"]


def test_spring_during_the_blow_is_not_a_mass_error() -> None:
    """A stiff null (0.8 kg, 60 Hz, 3 kHz, 1 ms blow): during the blow the spring already takes
    ``m w1^2 integral x dt`` of the impulse, +12 % of the momentum here, which the check once
    called a mass error (a false alarm on a null of session 7's fair test). With the spring's
    share taken out the ratio is within 3 %, and a true 25 % mass error is still seen."""
    import math

    from eddi.conditioning import condition
    from eddi.diagnosis import Record
    from eddi.diagnosis.chain import impulse_mass_ratio
    from simulated_rig.bench import impact_test

    m, f1 = 0.8, 60.0
    k1 = m * (2 * math.pi * f1) ** 2
    eom = EquationOfMotion.create(mass=m, damping={"v": 2 * 0.005 * math.sqrt(k1 * m)}, stiffness={"x": k1})

    def recs(true_mass: float) -> list:
        out = []
        for i, f in enumerate((160.0, 240.0)):
            r = impact_test(eom.model_copy(update={"mass": true_mass}), f, rate_hz=3000.0, pretrigger_s=0.2,
                            record_s=1.0, snr_db=40.0, seed=40 + i)
            c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
            out.append(Record.from_conditioned(c, label=f"impact {i + 1}", pretrigger_samples=r.pretrigger_samples))
        return out

    null = recs(m)
    assert impulse_mass_ratio(null, m, 0.0)[0] > 1.08  # the spring's share left in: a false alarm
    assert impulse_mass_ratio(null, m)[0] == pytest.approx(1.0, abs=0.03)
    assert "impulse_mass" not in kinds(inspect(null, m, f1))
    found = [s for s in inspect(recs(1.25 * m), m, f1) if s.kind == "impulse_mass"]
    assert len(found) == 1 and found[0].values["mismatch_pct"] == pytest.approx(25.0, abs=4.0)


def test_damping_during_the_blow_is_not_a_mass_error() -> None:
    """The damper pushes back during the blow: ``integral F = m dv + integral R + c dx``. Left
    out, a 90 Hz null at 4 % damping with 1 ms blows read +2.7 % (a mass error beyond the 2.5 %
    tolerance: a blind null named so, session 9); with it, +0.6 %, and a 5 % error is still said."""
    import math

    from simulated_rig.bench import impact_test
    from tests.eddi.diagnose_cases import to_record

    m, w, zeta = 0.8, 2 * math.pi * 90.0, 0.04
    eom = EquationOfMotion.create(mass=m, damping={"v": 2 * zeta * m * w}, stiffness={"x": m * w * w})
    recs = []
    for i, peak in enumerate((120.0, 180.0, 240.0)):
        r = impact_test(eom, peak, rate_hz=10000.0, pretrigger_s=0.05, record_s=0.6, seed=40 + i)
        recs.append(to_record(r.t, r.acc_m_s2, r.force_n, r.pretrigger_samples, f"impact {i + 1}", ()))
    assert "impulse_mass" not in kinds(inspect(recs, m, 90.0))
    found = [s for s in inspect(recs, 1.05 * m, 90.0) if s.kind == "impulse_mass"]
    assert len(found) == 1 and found[0].values["mismatch_pct"] == pytest.approx(100 * (1 / 1.05 - 1), abs=1.2)


def test_impulse_mass_of_a_named_coupling_is_judged_with_it_inverted() -> None:
    """A first-order AC coupling lowers the momentum the measured acceleration gives over the
    blow (+2.9 % at 5 Hz on this 12.7 Hz system, beyond the 2.5 % tolerance): when
    ``sensor_highpass`` wins, the impulse check is made on the records with it inverted (within
    0.1 %), so the finding does not forbid the correction that explains it; any other winner
    keeps the finding as measured."""
    from eddi.diagnosis.decide import Decision
    from eddi.diagnosis.loop import _impulse_through_coupling
    from eddi.diagnosis.results import Candidate

    recs = rig_records(5, highpass_hz=5.0, record_s=1.5)
    measured = inspect(recs, SYSTEM.mass, 12.3)
    assert "impulse_mass" in kinds(measured)

    def decision(name: str) -> Decision:
        c = Candidate(name, 0.01, (0.01,), 0.9, True, True, {"corner_hz": 5.0}, {}, None)
        return Decision(name, c, None, False, "")

    assert "impulse_mass" not in kinds(_impulse_through_coupling(decision("sensor_highpass"), recs, SYSTEM.mass,
                                                                 12.3, list(measured)))
    assert "impulse_mass" in kinds(_impulse_through_coupling(decision("clearance"), recs, SYSTEM.mass, 12.3,
                                                             list(measured)))
