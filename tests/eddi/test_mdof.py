"""Multi-DOF: schema, simulator vs solve_ivp, rig systems as data, multi-channel CSV, diagnosis."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from eddi.errors import ModelError, TermError
from eddi.mdof.model import MdofModel
from eddi.mdof.simulate import simulate_mdof
from eddi.mdof.terms import parse_multi_term
from eddi.multimode import load_any_model
from simulated_rig.mdof_systems import load_mdof_system, mdof_impact_test


def test_terms_parse_and_refuse():
    t = parse_multi_term("x1^2*x2", 2)
    assert t.exponents[0].tolist() == [2, 1] and t.text == "x1^2*x2"
    x = np.array([[2.0], [3.0]])
    assert t(x, x)[0] == pytest.approx(12.0)
    with pytest.raises(TermError):
        parse_multi_term("x3", 2)
    with pytest.raises(TermError):
        parse_multi_term("y1", 2)


def test_chain_expands_cubic_spring_and_round_trips():
    m = load_mdof_system("two-mass-cubic").model()
    # k3 (x1 - x2)^3 on mass 1, the opposite on mass 2 (k3 = 2e10 in the data file)
    assert m.stiffness[0]["x1^2*x2"] == pytest.approx(-6e10)
    assert m.stiffness[1]["x1^3"] == pytest.approx(-2e10)
    assert m.stiffness[0]["x1"] == pytest.approx(66000.0)
    back = load_any_model(m.to_json())
    assert isinstance(back, MdofModel) and back == m
    # single-DOF models (schema version 1) still load as before
    eom = load_any_model(json.dumps({"mass": 1.0, "stiffness": {"x": 4.0}}))
    assert eom.mass == 1.0
    bad = json.loads(m.to_json())
    bad["mass"] = [1.0]
    with pytest.raises(ModelError, match="expected 1 entries|one per coordinate"):
        MdofModel.from_json(json.dumps(bad))


def test_simulator_matches_solve_ivp():
    m = load_mdof_system("two-mass-cubic").model()
    t = np.arange(2048) / 2048.0
    sim = simulate_mdof(m, t, x0=np.array([2e-3, -1e-3]), v0=np.zeros(2), x_scale=3e-3)
    mass = np.array(m.mass)

    def rhs(_t, s):
        x, v = s[:2, None], s[2:, None]
        return np.concatenate([s[2:], -m.internal_force(x, v)[:, 0] / mass])

    ref = solve_ivp(rhs, (0, t[-1]), [2e-3, -1e-3, 0, 0], t_eval=t, method="DOP853", rtol=1e-10, atol=1e-14)
    assert np.max(np.abs(sim.x - ref.y[:2])) < 1e-5 * 2e-3


def test_rig_measures_every_mass(tmp_path):
    from station.readers import read_measurement, response_channels

    rec = mdof_impact_test("nes", 60.0, record_s=0.3)
    assert rec.acc_m_s2.shape == (2, rec.t.size)
    meas = read_measurement(str(rec.write_csv(tmp_path / "r.csv")))
    assert list(response_channels(meas.channels)) == ["acc1", "acc2"]
    np.testing.assert_allclose(meas.channels["acc2"], rec.acc_m_s2[1], rtol=1e-8, atol=1e-9)


def test_hdf5_capture_with_several_accelerometers_round_trips(tmp_path):
    from station.mdof_data import channel_names
    from station.readers import read_measurement
    from station.storage import CaptureWriter

    rec = mdof_impact_test("two-mass-cubic", 40.0, record_s=0.2)
    w = CaptureWriter(tmp_path / "s.h5")
    idx = w.append_si(rec.columns(), rate_hz=rec.rate_hz, pretrigger_samples=rec.pretrigger_samples)
    meas = read_measurement(f"{tmp_path / 's.h5'}:{idx}")
    assert channel_names(meas) == ("acc1", "acc2")
    np.testing.assert_array_equal(meas.channels["acc2"], rec.acc_m_s2[1])
    np.testing.assert_array_equal(meas.channels["force"], rec.force_n)


def test_validate_refuses_captures_without_the_models_channels(tmp_path, capsys):
    from station.cli import main

    model = load_mdof_system("two-mass-cubic").model()
    (tmp_path / "m.json").write_text(model.to_json())
    t = np.arange(400) / 2048.0
    force = np.zeros_like(t)
    force[20:24] = [10.0, 20.0, 20.0, 10.0]
    rows = np.column_stack([t, force, np.sin(2 * np.pi * 23 * t)])
    np.savetxt(tmp_path / "one.csv", rows, delimiter=",", header="t,force,acc", comments="")
    assert main(["validate", str(tmp_path / "m.json"), str(tmp_path / "one.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "acc1" in err[0] and "Traceback" not in err[0]


def test_rig_runs_an_mdof_model_json(tmp_path, capsys):
    from simulated_rig.mdof_systems import main
    from station.readers import read_measurement

    model = load_mdof_system("two-mass-cubic").model()
    (tmp_path / "m.json").write_text(model.to_json())
    assert main([str(tmp_path / "m.json"), "--out", str(tmp_path), "--peaks", "30"]) == 0
    path = capsys.readouterr().out.strip()
    meas = read_measurement(path)
    rec = mdof_impact_test("two-mass-cubic", 30.0, seed=0)
    np.testing.assert_allclose(meas.channels["acc2"], rec.acc_m_s2[1], rtol=1e-8, atol=1e-9)
    assert main(["no-such-system", "--out", str(tmp_path)]) == 2
