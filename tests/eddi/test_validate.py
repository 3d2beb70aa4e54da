"""Validation: simulation of identified models against measurements; spectra; Morlet CWT."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from eddi import EquationOfMotion, SignalError, cwt_map, identify, simulate, spectra, validate

# paper Eq. 17
M, B, B_NL, K, K_NL = 0.05, 0.5, 4000.0, 300.0, 3e8


@pytest.fixture(scope="module")
def duffing():
    def rhs(_t, y):
        x, v = y
        return [v, -(B * v + B_NL * x * x * v + K * x + K_NL * x**3) / M]

    t = np.arange(10001) / 1e4
    sol = solve_ivp(rhs, (0.0, 1.0), [0.0, 10.0], method="DOP853", rtol=1e-12, atol=1e-14, t_eval=t)
    return t, sol.y[0], sol.y[1]


def test_identified_paper_duffing_reproduces_the_response(duffing):
    t, x, v = duffing
    model = identify(t, x, v, M, damping="v,v^2,v^3,x^2*v", stiffness="x,x^2,x^3,x^4,x^5")
    val = validate(model.eom, t, x, v=v)
    assert not val.diverged
    assert val.window == (0, t.size)
    assert val.x_simulated[0] == x[0] and val.v_simulated[0] == v[0]
    assert val.nrmse < 1e-3  # brief target
    assert val.nrmse < 5e-5  # measured: 1.1e-5 (RK4 step error dominates)
    assert val.nmte < 1e-5


def test_a_wrong_model_is_caught(duffing):
    t, x, v = duffing
    wrong = EquationOfMotion.create(mass=M, damping={"v": B, "x^2*v": B_NL}, stiffness={"x": K, "x^3": 0.9 * K_NL})
    assert validate(wrong, t, x, v=v).nrmse > 0.1


def test_window_starts_from_the_measured_state(duffing):
    t, x, v = duffing
    exact = EquationOfMotion.create(mass=M, damping={"v": B, "x^2*v": B_NL}, stiffness={"x": K, "x^3": K_NL})
    val = validate(exact, t, x, v=v, window=(3000, 6000))
    assert val.window == (3000, 6000)
    assert val.t.size == 3000 and val.t[0] == t[3000]
    assert val.x_simulated[0] == x[3000]
    assert val.nrmse < 1e-4


def test_forced_validation_from_rest():
    eom = EquationOfMotion.create(mass=1.0, damping={"v": 2.0}, stiffness={"x": 1e4})
    t = np.arange(4000) / 2000.0
    force = np.where(t < 0.002, 100.0 * np.sin(np.pi * t / 0.002), 0.0)
    ref = simulate(eom, t, force=force, substeps=16)
    val = validate(eom, t, ref.x, v=ref.v, force=force)
    assert val.nrmse < 1e-4  # same model, RK4 sub-steps chosen automatically vs 16
    # without the force the same model from rest stays at rest: a complete miss
    val0 = validate(eom, t, ref.x, v=ref.v, x0=0.0, v0=0.0)
    assert val0.nrmse == pytest.approx(1.0)


def test_diverging_model_is_flagged():
    t = np.arange(2000) / 1000.0
    x = np.exp(-t) * np.sin(40 * t)
    bad = EquationOfMotion.create(mass=1.0, damping={"v": -400.0}, stiffness={"x": 1600.0})
    val = validate(bad, t, x, v=np.gradient(x, t), x0=1.0, v0=0.0)
    assert val.diverged
    assert val.nrmse == float("inf")


def test_validate_rejects_bad_signals():
    eom = EquationOfMotion.create(mass=1.0, stiffness={"x": 1.0})
    t = np.arange(10.0)
    with pytest.raises(SignalError, match="NaN"):
        validate(eom, t, np.full(10, np.nan))
    with pytest.raises(SignalError, match="window"):
        validate(eom, t, np.ones(10), window=(8, 3))


def test_spectra_peak_at_the_tone():
    t = np.arange(4000) / 1000.0
    a = 2.0 * np.sin(2 * np.pi * 25.0 * t)
    b = 0.5 * np.sin(2 * np.pi * 40.0 * t)
    s = spectra(t, a, b)
    assert s["freq_hz"][np.argmax(s["measured"])] == pytest.approx(25.0)
    assert s["freq_hz"][np.argmax(s["simulated"])] == pytest.approx(40.0)
    assert s["measured"].max() == pytest.approx(2.0, rel=1e-9)
    assert s["simulated"].max() == pytest.approx(0.5, rel=1e-9)


def test_cwt_map_localises_a_chirp_step_in_time_and_frequency():
    t = np.arange(4000) / 1000.0
    x = np.where(t < 2.0, 3.0 * np.sin(2 * np.pi * 10 * t), 1.0 * np.sin(2 * np.pi * 40 * t))
    freqs = np.array([10.0, 40.0])
    w = cwt_map(t, x, freqs)
    assert w.shape == (2, 4000)
    early, late = 1000, 3000
    assert w[0, early] == pytest.approx(3.0, rel=0.02)  # amplitude-normalised
    assert w[1, late] == pytest.approx(1.0, rel=0.02)
    assert w[1, early] < 0.01 and w[0, late] < 0.01
    with pytest.raises(SignalError, match="positive"):
        cwt_map(t, x, np.array([0.0, 10.0]))
