"""Forward sensitivities of the MDOF simulation (eddi.mdof.sensitivity) and the polish's Jacobian from them."""

from __future__ import annotations

import numpy as np
import pytest

from eddi.mdof.refine import _jacobian_function, _residual_function, _with, refine_mdof
from eddi.mdof.sensitivity import simulate_sensitivities, theta
from eddi.mdof.simulate import simulate_mdof
from simulated_rig.mdof_systems import MdofSystem, mdof_impact_test
from station.mdof_data import condition_multichannel
from station.readers import Measurement


def _records(system: MdofSystem) -> list:
    out = []
    for k, peak in enumerate(system.impacts_n):
        rec = mdof_impact_test(system, peak, seed=3 + k, snr_db=45.0)
        meas = Measurement(t=rec.t, channels=rec.columns(), rate_hz=rec.rate_hz,
                           pretrigger_samples=rec.pretrigger_samples, mass=None, source=f"{peak} N", metadata={})
        out.append(condition_multichannel(meas))
    return out


SYSTEM = MdofSystem.model_validate({
    "name": "sens", "masses_kg": [0.8, 0.3], "driving_point": 1, "record_s": 0.6,
    "impacts_n": [60.0, 200.0],
    "elements": [{"between": [0, 1], "k": 35000.0, "c": 5.0},
                 {"between": [1, 2], "k": 15000.0, "k3": 1.3e10, "c": 1.5}]})


def test_sensitivities_match_central_differences_of_the_simulation_including_nonsmooth_terms():
    model = SYSTEM.model()
    # add a quadratic |v| damping and an x|x| spring: the magnitude factors' derivatives are exercised too
    damping = ({**model.damping[0], "abs(v1)*v1": 0.4}, dict(model.damping[1]))
    stiffness = (dict(model.stiffness[0]), {**model.stiffness[1], "abs(x2)*x2": 2.0e6})
    model = model.model_copy(update={"damping": damping, "stiffness": stiffness})
    t = np.arange(1200) / 2048.0
    force = np.where(t < 2e-3, 150.0 * np.sin(np.pi * t / 2e-3), 0.0)
    x, dx, div = simulate_sensitivities(model, t, force, x_scale=1e-3)
    plain = simulate_mdof(model, t, force, x_scale=1e-3)
    assert not div and np.max(np.abs(x - plain.x)) <= 1e-12 * np.max(np.abs(plain.x))  # same scheme, rounding
    th = theta(model)
    assert dx.shape == (th.size, 2, t.size)
    n_terms = th.size - 2
    worst = 0.0
    for j in range(th.size):
        h = 1e-6 * th[j]  # signed: a coefficient's scale 1 + 1e-6 moves it by 1e-6 * coefficient
        sims = []
        for sign in (1.0, -1.0):
            if j < n_terms:
                scales = np.zeros(n_terms)
                scales[j] = sign * 1e-6
                m = _with(model, scales)
            else:
                mass = list(model.mass)
                mass[j - n_terms] = 1.0 / (th[j] + sign * h)
                m = model.model_copy(update={"mass": tuple(mass)})
            sims.append(simulate_mdof(m, t, force, substeps=plain.substeps).x)
        fd = (sims[0] - sims[1]) / (2 * h)
        worst = max(worst, float(np.max(np.abs(fd - dx[j])) / np.max(np.abs(dx[j]))))
    assert worst < 1e-5


def test_polish_jacobian_matches_finite_differences_and_the_polish_agrees_with_the_old_one():
    records = _records(SYSTEM)
    truth = SYSTEM.model()
    rng = np.random.default_rng(1)
    n_par = sum(len(d) + len(s) for d, s in zip(truth.damping, truth.stiffness))
    start = _with(truth, 0.01 * rng.standard_normal(n_par))  # a start 1 % off, as EDDI leaves it
    build = lambda p: _with(start, p)  # noqa: E731
    residual, _sizes = _residual_function(records, build, 0.5)
    jac = _jacobian_function(records, build, 0.5)(np.zeros(n_par))
    assert jac.shape == (residual(np.zeros(n_par)).size, n_par)
    for k in range(n_par):
        e = np.zeros(n_par)
        e[k] = 1e-6
        fd = (residual(e) - residual(-e)) / 2e-6
        assert np.max(np.abs(fd - jac[:, k])) <= 1e-4 * np.max(np.abs(jac[:, k]))
    new, b_new, a_new = refine_mdof(start, records, max_nfev=8)
    old, b_old, a_old = refine_mdof(start, records, max_nfev=8, jac="2-point")
    assert b_new == b_old and a_new < 0.5 * b_new
    assert a_new == pytest.approx(a_old, rel=0.02)
    with pytest.raises(ValueError, match="jac"):
        refine_mdof(start, records, jac="3-point")
