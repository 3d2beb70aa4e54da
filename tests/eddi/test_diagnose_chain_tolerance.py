"""The measurement chain's tolerance in the noise floor (issue 10, session 9).

A blind null (six captures of a strongly stiffening, lightly damped system, ~90 cycles per
record) was ``unexplained`` at 3.7x the noise floor: the captures came from two acquisition
sessions whose accelerometer gains differed by a few tenths of a percent and whose clocks
differed by tens of ppm. A gain error leaves a linear model alone but scales a cubic one, so
the model fitted on one session predicts the other's frequency at a given amplitude slightly
wrong, and the phase drifts over 90 cycles. Own system here (0.2 kg, 55 Hz, x^2 and x^3 both
stiffening, 5 kHz, 55 dB), two sessions 1 % and 100 ppm apart (the stated defaults allow 1 %
and 50 ppm; the gain is read from the impulse/momentum ratios):

* the null is ``none`` with the chain's tolerance in the floor, ``unexplained`` without it
  (the session-8 floor: this is the test that fails on the old code);
* Coulomb friction hidden in the same two-session captures is still named;
* a gain difference does not move a linear model's held-out simulation (it does a cubic
  one's), a clock difference moves both, in proportion to the ppm.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddi.diagnosis import diagnose
from eddi.diagnosis.records import Part
from eddi.diagnosis.tolerance import ChainTolerance, chain_part_nrmse
from eddi.model import EquationOfMotion, Effect
from simulated_rig.bench import impact_test
from simulated_rig.sessions import Chain, session_test
from tests.eddi.diagnose_cases import to_record

MECHS = ["coulomb_friction", "quadratic_damping"]
RATE = 5000.0


def _system(rise: float = 0.75, asym: float = 0.25) -> tuple[EquationOfMotion, float]:
    """0.2 kg, 55 Hz, damping ratio 0.0015; ``x^3`` (``rise k1 / A^2``) and ``x^2`` (``asym k1 / A``)
    sized on the linear peak ``A`` of the strongest blow; and that blow's peak force [N]."""
    m, f1, zeta = 0.2, 55.0, 0.0015
    k1 = m * (2 * math.pi * f1) ** 2
    c = 2 * zeta * math.sqrt(k1 * m)
    top = 64.0
    lin = EquationOfMotion.create(mass=m, damping={"v": c}, stiffness={"x": k1})
    amp = float(np.max(np.abs(impact_test(lin, top, rate_hz=RATE, pretrigger_s=0.05, record_s=0.1,
                                          snr_db=None, seed=0).truth_x)))
    return EquationOfMotion.create(mass=m, damping={"v": c},
                                   stiffness={"x": k1, "x^2": asym * k1 / amp, "x^3": rise * k1 / amp ** 2}), top


def _two_sessions(eom: EquationOfMotion, top: float, seed: int = 1) -> list:
    chains = [Chain(pretrigger_s=0.2), Chain(acc_gain=0.01, clock_ppm=-100.0, acc_offset=0.05,
                                             force_offset=0.02, pretrigger_s=0.1, jitter_samples=2)]
    levels = np.geomspace(1 / 1.6, 1.0, 6)[[3, 0, 5, 1, 4, 2]]
    out = []
    for i, lev in enumerate(levels):
        r = session_test(eom, top * float(lev), chains[i // 3], rate_hz=RATE, record_s=1.6, snr_db=55.0,
                         seed=100 * seed + i)
        out.append(to_record(r.t, r.acc_m_s2, r.force_n, r.pretrigger_samples, f"session {i // 3 + 1} #{i % 3}"))
    return out


@pytest.fixture(scope="module")
def null_records():
    eom, top = _system()
    return eom, _two_sessions(eom, top)


def test_two_session_null_of_a_stiffening_system_is_none(null_records):
    eom, recs = null_records
    d = diagnose(recs, eom.mass, mechanisms=MECHS)
    fl = d.noise_floor
    assert d.cause == "none", d.verdict
    # the chain's share is stated per part, with the tolerances used
    assert len(fl.chain_nrmse) == len(d.parts) and max(fl.chain_nrmse) > 0.05
    assert fl.chain["gain_tolerance"] == 0.01 and fl.chain["clock_ppm"] == 50.0
    # the gains assumed per part are what the impulse/momentum ratios measured: ~1 % for all
    assert all(0.005 < g <= 0.01 for g in fl.chain["gain_per_part"])
    assert "measurement chain's tolerance" in d.verdict
    assert fl.to_dict()["chain_nrmse"] == list(fl.chain_nrmse)
    # without the chain in the floor (the session-8 floor) the same records were a false alarm
    old = diagnose(recs, eom.mass, mechanisms=MECHS, chain=None)
    assert old.cause == "unexplained"
    assert old.judging.nrmse / old.noise_floor.nrmse > 3.5


def test_friction_hidden_in_two_session_captures_is_still_named():
    eom, top = _system()
    k1 = eom.linear_stiffness()
    amp = 64.0 / (eom.mass * 2 * math.pi * 55.0) * 1e-3  # order of the peak displacement [m]
    truth = eom.with_effect(Effect(name="coulomb_friction", params={"force_n": 0.004 * k1 * amp,
                                                                     "velocity_scale": 1e-4}))
    d = diagnose(_two_sessions(truth, top, seed=2), eom.mass, mechanisms=MECHS)
    assert d.cause == "coulomb_friction", d.verdict


def test_gain_leaves_a_linear_model_alone_and_the_clock_does_not():
    m, f1 = 0.2, 55.0
    k1 = m * (2 * math.pi * f1) ** 2
    lin = EquationOfMotion.create(mass=m, damping={"v": 0.2}, stiffness={"x": k1})
    cub, _ = _system(rise=0.75, asym=0.0)
    out = {}
    for name, eom in (("linear", lin), ("cubic", cub)):
        r = impact_test(eom, 64.0, rate_hz=RATE, pretrigger_s=0.2, record_s=1.6, snr_db=None, seed=0)
        rec = to_record(r.t, r.acc_m_s2, r.force_n, r.pretrigger_samples, name)
        part = Part(0, rec.free_start, rec.free_stop, True, name)
        from eddi.diagnosis.show import simulate_part

        xb = simulate_part(eom, rec, part)
        out[name] = [chain_part_nrmse(eom, rec, part, xb, 0.01, e) for e in (50e-6, 100e-6)]
    (lg, lc50), (_, lc100) = out["linear"]
    (cg, cc50), (_, cc100) = out["cubic"]
    assert lg < 1e-3 < 0.05 < cg  # 1 % gain: nothing on the linear model, a phase drift on the cubic one
    # ~88 cycles at 100 ppm: a phase of 2 pi 88 1e-4 = 0.055 rad at the end of a decaying record
    assert 0.005 < lc100 < 0.06
    assert lc100 / lc50 == pytest.approx(2.0, rel=0.1) and cc100 / cc50 == pytest.approx(2.0, rel=0.1)
    with pytest.raises(ValueError):
        ChainTolerance(gain=-0.01)


def test_station_diagnose_states_the_tolerances_and_refuses_bad_ones(tmp_path, capsys):
    import json

    from station.cli import main

    eom, top = _system()
    caps = []
    for i, rec in enumerate(_two_sessions(eom, top, seed=3)[:3]):
        p = tmp_path / f"c{i}.csv"
        np.savetxt(p, np.column_stack((rec.t, rec.force, rec.a)), delimiter=",", header="t,force,acc",
                   comments="", fmt="%.10g")
        caps.append(str(p))
    for bad in (["--gain-tolerance", "-1"], ["--gain-tolerance", "60"], ["--clock-ppm", "abc"]):
        code = main(["diagnose", *caps, "--mass", "0.2", *bad])
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    code = main(["diagnose", *caps, "--mass", "0.2", "--mechanisms", "coulomb_friction", "--no-refine",
                 "--gain-tolerance", "0.5", "--gain-as-stated", "--clock-ppm", "100", "--json"])
    obj = json.loads(capsys.readouterr().out)
    assert code == 0
    chain = obj["noise_floor"]["chain"]
    assert chain["gain_tolerance"] == 0.005 and chain["clock_ppm"] == 100.0
    assert chain["gain_per_part"] == [0.005] * 3  # as stated: not lowered by the ratios
    assert len(obj["noise_floor"]["chain_nrmse"]) == 3


def test_a_name_must_come_near_the_noise_floor_not_the_chain_allowance():
    """The chain's tolerance excuses silence, not a name (fair test: a preload named
    smooth_stiffening at 13x the noise's floor once the chain had raised the floor)."""
    from eddi.diagnosis.decide import decide
    from eddi.diagnosis.results import Candidate, NoiseFloor

    model = EquationOfMotion.create(mass=0.1, damping={"v": 0.05}, stiffness={"x": 600.0})
    base = (0.8, 0.8, 0.8)
    cand = Candidate("smooth_stiffening", 0.4, (0.4, 0.4, 0.4), 0.5, True, True, {"k": 1.0}, {"k": 0.0}, model, "s")
    noise = NoiseFloor(nrmse=0.03, fold_nrmse=(0.03,) * 3, noise_rms=(0,) * 3, conditioning_nrmse=(0,) * 3,
                       method="test")
    chained = NoiseFloor(nrmse=0.05, fold_nrmse=(0.05,) * 3, noise_rms=(0,) * 3, conditioning_nrmse=(0,) * 3,
                         method="test", chain_nrmse=(0.04,) * 3, noise_fold_nrmse=(0.03,) * 3)
    assert decide([cand], base, noise, 0.4, 3.5, 10.0).cause == "unexplained"  # 0.4 > 10 x 0.03
    dec = decide([cand], base, chained, 0.4, 3.5, 10.0)  # 0.4 < 10 x 0.05, but > 10 x the noise's 0.03
    assert dec.cause == "unexplained" and "of the noise alone" in dec.reason
    loose = NoiseFloor(nrmse=0.05, fold_nrmse=(0.05,) * 3, noise_rms=(0,) * 3, conditioning_nrmse=(0,) * 3,
                       method="test", noise_fold_nrmse=(0.05,) * 3)
    assert decide([cand], base, loose, 0.4, 3.5, 10.0).cause == "smooth_stiffening"
