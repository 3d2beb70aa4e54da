"""The discrepancy loop finds a hidden mechanism, and stays silent when nothing is hidden.

Every case goes through the whole acceleration-only chain: the simulated rig hits the system
three times (hammer, accelerometer and force sensor with noise, 24-bit ADC), the acceleration
is conditioned (drift-free integration) and only then diagnosed. The true physics is never
handed to the diagnosis.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddi.conditioning import condition
from eddi.diagnosis import ALL_NAMES, NAMED_FACTOR, NONE_FACTOR, REFERENCE_MARGIN, Record, diagnose, energy_per_cycle, backbone
from eddi.errors import SignalError, TermError, ModelError
from eddi.model import Effect, EquationOfMotion
from eddi.simulate import simulate
from simulated_rig.bench import impact_test

#: 12.3 Hz, zeta 0.4 %, mildly hardening (about 8 % frequency shift at 1.6 mm).
SYSTEM = EquationOfMotion.create(mass=0.1, damping={"v": 0.06}, stiffness={"x": 600.0, "x^3": 2e7})
DAMPING = "v,x^2*v,v^3"
STIFFNESS = "x,x^2,x^3,x^4,x^5"
FORCES_N = (20.0, 25.0, 30.0)
RATE_HZ = 5000.0
RECORD_S = 4.0
SNR_DB = 40.0


def hidden(name: str, seed: int) -> Effect:
    """The mechanism ``name`` with a magnitude chosen by ``seed`` (factor 1 to 2)."""
    s = float(np.random.default_rng(seed).uniform(1.0, 2.0))
    params = {
        "coulomb_friction": {"force_n": 0.004 * s},
        "quadratic_damping": {"coefficient": 2.5 * s},
        "clearance": {"gap_m": 0.4e-3 * s, "stiffness_n_per_m": 150.0 * s},
        "asymmetric_stiffness": {"k2": 3e4 * s},
        "second_mode": {"mass_kg": 0.05, "stiffness_n_per_m": 1777.0 - 250.0 * s,
                        "damping_n_s_per_m": 0.1, "coupling_n_per_m": 250.0 * s},
    }[name]
    return Effect(name=name, params=params)


def records(effects: list[Effect], seed: int, *, forces: tuple[float, ...] = FORCES_N,
            with_force: bool = True, record_s: float = RECORD_S,
            system: EquationOfMotion = SYSTEM) -> list[Record]:
    out = []
    for i, f in enumerate(forces):
        r = impact_test(system, f, rate_hz=RATE_HZ, pretrigger_s=0.2, record_s=record_s,
                        snr_db=SNR_DB, effects=effects, seed=100 * seed + i)
        c = condition(r.t, acc=r.acc_m_s2, force=r.force_n if with_force else None,
                      pretrigger_samples=r.pretrigger_samples)
        out.append(Record.from_conditioned(c, label=f"impact {i + 1}", pretrigger_samples=r.pretrigger_samples))
    return out


@pytest.mark.parametrize("name,seed", [
    ("coulomb_friction", 1),
    ("quadratic_damping", 1),
    ("clearance", 2),
    ("asymmetric_stiffness", 1),
    ("second_mode", 1),
])
def test_hidden_mechanism_is_named_and_halves_the_error(name: str, seed: int) -> None:
    eff = hidden(name, seed)
    # asymmetric stiffness is only missing from a library without even powers
    stiff = "x,x^3" if name == "asymmetric_stiffness" else STIFFNESS
    # drag is told from its look-alike |x| v within the cycle (eddi/diagnosis/lookalike.py);
    # with v^3 and x^2*v in the library both extensions take the same shape (within-cycle z
    # 0.07 on this case: `unexplained`, drag and |x| v the partial explanations), with `v` it is 73
    damp = "v" if name == "quadratic_damping" else DAMPING
    d = diagnose(records([eff], seed), SYSTEM.mass, damping=damp, stiffness=stiff)
    assert d.cause == name, d.verdict
    assert d.scheme == "leave-one-record-out" and len(d.parts) == 3
    assert d.extended.nrmse <= 0.5 * d.baseline.nrmse
    assert d.gain >= 0.5
    assert d.candidates[0].gain > REFERENCE_MARGIN  # over its own reference (second mode: equation error)
    assert all(e < b for e, b in zip(d.extended.fold_nrmse, d.baseline.fold_nrmse))
    found = d.extended.model.effect(name)
    assert found is not None
    p, truth = found.params, eff.params
    if name == "coulomb_friction":
        assert p["force_n"] == pytest.approx(truth["force_n"], rel=0.15)
    elif name == "quadratic_damping":
        assert p["coefficient"] == pytest.approx(truth["coefficient"], rel=0.3)
    elif name == "clearance":
        assert p["gap_m"] == pytest.approx(truth["gap_m"], rel=0.1)
        assert p["stiffness_n_per_m"] == pytest.approx(truth["stiffness_n_per_m"], rel=0.2)
    elif name == "asymmetric_stiffness":
        assert p["k2"] == pytest.approx(truth["k2"], rel=0.2)
    else:  # only the second frequency and k_c^2/m2 are observable from x (docs/effects.md)
        f2 = math.sqrt((p["stiffness_n_per_m"] + p["coupling_n_per_m"]) / p["mass_kg"]) / (2 * math.pi)
        f2_true = math.sqrt((truth["stiffness_n_per_m"] + truth["coupling_n_per_m"])
                            / truth["mass_kg"]) / (2 * math.pi)
        assert f2 == pytest.approx(f2_true, rel=0.03)
        assert p["coupling_n_per_m"] ** 2 / p["mass_kg"] == pytest.approx(
            truth["coupling_n_per_m"] ** 2 / truth["mass_kg"], rel=0.3)
    # the candidate table holds every mechanism of the catalogue once
    assert sorted(c.name for c in d.candidates) == sorted(ALL_NAMES)
    # named only within the stated factor of the noise floor measured from the records
    assert d.noise_floor is not None and d.extended.nrmse <= NAMED_FACTOR * d.noise_floor.nrmse
    assert d.candidates[0].name == name


#: A strongly hardening system with nonlinear damping (about 40 % frequency shift).
HARD = EquationOfMotion.create(mass=0.1, damping={"v": 0.05, "x^2*v": 2000.0},
                               stiffness={"x": 600.0, "x^3": 1.5e8})


@pytest.mark.parametrize("system,seed", [("mild", 11), ("mild", 12), ("mild", 13), ("hard", 14), ("hard", 15)])
def test_nothing_hidden_gives_none(system: str, seed: int) -> None:
    eom = SYSTEM if system == "mild" else HARD
    recs = records([], seed, system=eom)
    d = diagnose(recs, SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS)
    assert d.cause == "none", d.verdict
    assert d.gain == 0.0
    assert d.extended.model == d.baseline.model
    assert d.baseline.nrmse <= NONE_FACTOR * d.noise_floor.nrmse
    # "follows" only at or below the floor (issue 10 item 1), never above it
    assert ("follows" in d.symptom) == (d.baseline.nrmse <= d.noise_floor.nrmse), d.symptom
    # the largest capture is judged only inside the training amplitudes, from its measured state
    peaks = [float(np.max(np.abs(r.x[r.free_start:r.free_stop]))) for r in recs]
    big = int(np.argmax(peaks))
    for p in d.parts:
        r = recs[p.record]
        if p.record == big:
            assert not p.from_rest and p.start > r.free_start
            assert np.max(np.abs(r.x[p.start:p.stop])) <= sorted(peaks)[-2]
        else:  # compared over the free response, simulated from rest before it (as the pipeline)
            assert p.from_rest and p.start == r.free_start and r.impact_end > r.impact_start


def test_single_capture_is_judged_on_amplitude_bands() -> None:
    eff = hidden("coulomb_friction", 3)
    recs = records([eff], 3, forces=(30.0,), record_s=4.0)
    d = diagnose(recs, SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS)
    assert d.scheme == "amplitude-bands" and len(d.parts) == 3
    # bands are disjoint, in time order, inside the free response
    starts = [p.start for p in d.parts]
    assert starts == sorted(starts)
    assert all(a.stop <= b.start for a, b in zip(d.parts, d.parts[1:]))
    # each band is a free response simulated from a state fitted over its first two cycles
    # (session 6; before, from the measured state at one sample, the friction model stayed
    # above 10x the floor and the verdict was `unexplained` with friction as its partial)
    assert d.cause == "coulomb_friction", d.verdict
    best = d.candidates[0]
    assert best.name == "coulomb_friction" and best.wins_every_part
    assert best.nrmse <= 0.5 * d.baseline.nrmse and best.nrmse <= NAMED_FACTOR * d.noise_floor.nrmse
    assert best.params["force_n"] == pytest.approx(eff.params["force_n"], rel=0.3)
    assert "follows" not in d.verdict + d.symptom


def test_given_base_model_keeps_its_coefficients() -> None:
    eff = hidden("coulomb_friction", 4)
    d = diagnose(records([eff], 4), base=SYSTEM)
    assert d.baseline.model == SYSTEM
    assert d.cause == "coulomb_friction"
    ext = d.extended.model
    assert ext.damping == SYSTEM.damping and ext.stiffness == SYSTEM.stiffness
    assert ext.effect("coulomb_friction").params["force_n"] == pytest.approx(
        eff.params["force_n"], rel=0.1)


def test_extended_model_round_trips_to_json_and_simulates() -> None:
    eff = hidden("clearance", 2)
    d = diagnose(records([eff], 2), SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS,
                 mechanisms=["clearance", "coulomb_friction"])
    back = EquationOfMotion.from_json(d.extended.model.to_json())
    assert back == d.extended.model
    assert back.effect("clearance") is not None
    # the rig accepts it as the physics of a bench
    r = impact_test(back, 20.0, rate_hz=RATE_HZ, pretrigger_s=0.1, record_s=0.5, snr_db=None, seed=0)
    assert np.all(np.isfinite(r.truth_x)) and np.max(np.abs(r.truth_x)) > 1e-4


def test_bad_input_is_refused_in_one_line() -> None:
    good = records([], 21)
    with pytest.raises(SignalError, match="different sample rates"):
        r = good[0]
        t2 = r.t[::2]
        other = Record.create(t2, r.x[::2], r.v[::2], r.a[::2], force=r.force[::2])
        diagnose([good[1], other], SYSTEM.mass)
    with pytest.raises(SignalError, match="too short to split"):
        r = good[0]
        stop = r.free_start + int(0.4 * RATE_HZ)
        short = Record.create(r.t[:stop], r.x[:stop], r.v[:stop], r.a[:stop], force=r.force[:stop])
        diagnose([short], SYSTEM.mass)
    with pytest.raises(SignalError, match="zero crossings"):
        t = np.arange(5000) / RATE_HZ
        x = 1e-3 * np.exp(-t)
        flat = Record.create(t, x, -x, x)
        diagnose([flat, flat], SYSTEM.mass)
    with pytest.raises(TermError, match="unknown mechanism"):
        diagnose(good, SYSTEM.mass, mechanisms=["magic"])
    with pytest.raises(ModelError, match="mass"):
        diagnose(good, -1.0)
    with pytest.raises(ModelError, match="fit must be one of"):
        diagnose(good, SYSTEM.mass, fit="magic")


def test_equation_error_fit_is_still_available() -> None:
    # 2.5x the usual friction: at 1x the equation-error baseline is already within 5x the noise
    # floor (nrmse 0.089, floor 0.02) and the verdict is rightly none
    eff = hidden("coulomb_friction", 5)
    eff = Effect(name=eff.name, params={"force_n": 2.5 * eff.params["force_n"]})
    d = diagnose(records([eff], 5), SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS,
                 fit="equation-error", mechanisms=["coulomb_friction", "quadratic_damping"])
    assert d.cause == "coulomb_friction", d.verdict
    assert "least squares on the equation of motion" in d.baseline.model.notes
    assert d.extended.model.effect("coulomb_friction").params["force_n"] == pytest.approx(
        eff.params["force_n"], rel=0.15)


def test_energy_per_cycle_of_exact_oscillators() -> None:
    """Exact energy lost per cycle: viscous ``pi c w A^2``, dry friction ``4 F A``."""
    m, k = 0.1, 600.0
    w = math.sqrt(k / m)
    rate = 20000.0
    t = np.arange(int(2.0 * rate)) / rate
    # viscous, light damping: dE = pi c w A^2 to first order in zeta
    c = 0.01
    visc = EquationOfMotion.create(mass=m, damping={"v": c}, stiffness={"x": k})
    s = simulate(visc, t, v0=0.1)
    amp, de = energy_per_cycle(t, s.x, s.v, m)
    assert amp.size > 30
    np.testing.assert_allclose(de, math.pi * c * w * amp**2, rtol=0.02)
    amp_b, f_b, z_b = backbone(t, s.x, s.v, m)
    np.testing.assert_allclose(f_b, w / (2 * math.pi) * math.sqrt(1 - (c / (2 * m * w)) ** 2), rtol=1e-3)
    np.testing.assert_allclose(z_b, c / (2 * m * w), rtol=0.03)
    # dry friction: a half cycle from A_i to A_i+1 = A_i - 2F/k loses F (A_i + A_i+1), so the
    # cycle that starts at peak A loses 2 F (2 A - 2 F/k) = 4 F (A - F/k)
    f = 0.02
    dry = EquationOfMotion.create(mass=m, stiffness={"x": k},
                                  effects=[Effect(name="coulomb_friction", params={"force_n": f, "velocity_scale": 1e-6})])
    s = simulate(dry, t, v0=0.1, substeps=8)
    amp, de = energy_per_cycle(t, s.x, s.v, m)
    keep = amp > 10 * f / k
    assert keep.sum() > 10
    np.testing.assert_allclose(de[keep], 4 * f * (amp[keep] - f / k), rtol=0.02)
