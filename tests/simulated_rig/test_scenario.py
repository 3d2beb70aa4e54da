"""Scenario files: validation with one-line errors, built-ins, hidden effects."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from eddi.model import EFFECTS, EquationOfMotion
from simulated_rig.errors import ScenarioError
from simulated_rig.scenario import Scenario, builtin_scenarios, load_scenario
from simulated_rig.systems import get_system, hide_effect, typical_state


def _write(tmp_path: Path, text: str, name: str = "case.toml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_builtin_scenarios_load_and_the_default_is_the_paper_rig() -> None:
    names = builtin_scenarios()
    assert {"duffing-smooth", "duffing-smooth-friction", "duffing-struts"} <= set(names)
    for n in names:
        load_scenario(n).eom()
    s = load_scenario("duffing-smooth")
    assert s.system == "duffing-smooth" and s.rate_hz == 19200.0  # paper Sec. 3.3.1
    assert s.resolved_record_s() == 45.0 and s.pretrigger_s == 1.0  # paper Sec. 3.3.1
    assert s.resolved_impacts() == (246.0, 600.0, 1110.0)  # paper Fig. 12 + ours
    assert s.eom() == get_system("duffing-smooth")


def test_friction_scenario_hides_coulomb_friction_scaled_as_documented() -> None:
    s = load_scenario("duffing-smooth-friction")
    eff = s.eom().effect("coulomb_friction")
    assert eff is not None
    a, _v = typical_state("duffing-smooth")
    # magnitude 0.02 of k1 * A, times a seed factor in [0.8, 1.2]
    ratio = eff.params["force_n"] / (0.02 * 390.0 * a)
    assert 0.8 <= ratio <= 1.2


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("rate_hz = 2e6", "rate_hz: Input should be less than or equal to 1000000"),
        ("system = 'duffing-rough'", "system: unknown system 'duffing-rough'; known: paper-duffing"),
        ("impacts = [100.0, -5.0]", "impacts: Value error, each peak force must be in (0, 100000] N, got -5.0"),
        ("[sensors.acc]\nadc_bits = 12", "sensors.acc.adc_bits: Input should be 16 or 24"),
        ("[hammer]\ntip = 'wood'", "hammer.tip: Input should be 'steel', 'plastic' or 'rubber'"),
        ("[hammer]\ndouble_hit_delay_s = 0.0001", "double_hit_delay_s: must be >= the pulse width"),
        ("[[effects]]\nname = 'magic'", "unknown effect 'magic'"),
        ("[[effects]]\nname = 'clearance'\nparams = {gap_m = 0.001}", "needs parameter 'stiffness_n_per_m'"),
        ("[[hidden]]\nname = 'coulomb_friction'\nmagnitude = 50.0", "hidden.0.magnitude: Input should be less than or equal to 10"),
        ("sed = 3", "sed: Extra inputs are not permitted"),
        ("system = 'duffing-smooth'\nmodel = 'x.json'", "give either system or model, not both"),
    ],
)
def test_bad_fields_give_one_line_errors_naming_the_field_and_limit(
        tmp_path: Path, text: str, needle: str) -> None:
    p = _write(tmp_path, text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(p)
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith("scenario case.toml: ")
    assert needle.removeprefix("impacts: Value error, ") in msg.replace("Value error, ", "")


def test_bad_toml_and_missing_file_are_one_line_errors(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="not valid TOML"):
        load_scenario(_write(tmp_path, "rate_hz = = 3"))
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenario(tmp_path / "nope.toml")


def test_model_file_relative_to_scenario_loads_an_identified_model(tmp_path: Path) -> None:
    model = EquationOfMotion.create(mass=0.5, damping={"v": 0.3}, stiffness={"x": 800.0, "x^3": 2e6})
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "identified.json").write_text(model.to_json(), encoding="utf-8")
    p = _write(tmp_path, "model = 'models/identified.json'\nimpacts = [40.0]\nrecord_s = 1.0\n"
                         "pretrigger_s = 0.1\n[[effects]]\nname = 'quadratic_damping'\n"
                         "params = {coefficient = 0.5}\n")
    s = load_scenario(p)
    eom = s.eom()
    assert eom.stiffness == {"x": 800.0, "x^3": 2e6}
    assert eom.effect("quadratic_damping").params["coefficient"] == 0.5
    rec = s.impact(0)
    assert rec.eom == eom and rec.n_samples == int(1.1 * 19200)


def test_scenario_impact_reproduces_impact_test_settings() -> None:
    s = Scenario(system="duffing-struts", record_s=0.5, pretrigger_s=0.1, impacts=(11.0, 37.0), seed=4)
    a = s.impact(1)
    b = s.impact(1)
    assert np.array_equal(a.counts, b.counts) and a.seed == 5 and a.peak_force_n == 37.0
    assert a.eom.effect("clearance") is not None  # the struts' assumed clearance


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_hide_effect_sizes_every_effect_by_magnitude(name: str) -> None:
    a, v = 0.01, 0.5
    eom = hide_effect("duffing-smooth", name, 0.1, seed=0, amplitude_m=a, velocity_m_s=v)
    eff = eom.effect(name)
    assert eff is not None
    x = np.array([a])
    vv = np.array([v])
    k1a = 390.0 * a  # paper Sec. 3.3.1: k1 = 390 N/m
    if name == "second_mode":
        assert eff.params["coupling_n_per_m"] / 390.0 == pytest.approx(0.1, rel=0.21)
    elif name == "hysteresis":  # history dependent: the yield force is the size; loading to A nears it
        from eddi.model import effect_force

        fy = eff.params["yield_force_n"]
        assert 0.08 * k1a <= fy <= 0.12 * k1a
        path = np.linspace(0.0, a, 400)
        assert 0.9 * fy <= float(effect_force(eff, path, np.full_like(path, v))[-1]) <= fy
    else:
        from eddi.model import effect_force

        force = abs(float(effect_force(eff, x, vv)[0]))
        assert 0.08 * k1a <= force <= 0.12 * k1a
    # the seed changes the values, the size stays
    other = hide_effect("duffing-smooth", name, 0.1, seed=7, amplitude_m=a, velocity_m_s=v).effect(name)
    assert other != eff


def test_hide_effect_refuses_unknown_effect_and_bad_magnitude() -> None:
    with pytest.raises(ScenarioError, match="known: coulomb_friction"):
        hide_effect("duffing-smooth", "backlash", 0.1)
    with pytest.raises(ScenarioError, match=r"magnitude must be in \(0, 10\]"):
        hide_effect("duffing-smooth", "clearance", 0.0)
