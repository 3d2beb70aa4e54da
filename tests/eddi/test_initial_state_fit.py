"""eddi.initial_state: the fitted initial state is the same bit for bit as scipy's least_squares
gives, from fewer simulations (session 12: the Jacobians least_squares discards, the crossings
of the whole window)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares

import eddi.initial_state as ist
from eddi.energy import zero_crossings
from eddi.model import EquationOfMotion
from eddi.simulate import free_simulator, simulate


def _reference(eom, t, x, v, force, s, e, x_scale, v_scale):
    """fitted_state as it was before session 12 (scipy's least_squares on the whole window's
    crossings)."""
    x0, v0 = float(x[s]), float(v[s])
    n = max(8, int(ist.STATE_FRACTION * (e - s)))
    g = zero_crossings(t[s:s + n], x[s:s + n], v[s:s + n], hysteresis=0.05 * x_scale)
    if g.size < 2 * ist.STATE_CYCLES + 1:
        return x0, v0
    w = int(np.searchsorted(t[s:s + n], g[2 * ist.STATE_CYCLES])) + 1
    tw = t[s:s + w] - t[s]
    f = force[s:s + w] if force is not None else None
    xm, vm = x[s:s + w], v[s:s + w]
    run = free_simulator(eom, tw, force=f, x_scale=x_scale, v_scale=v_scale)

    def res(p):
        xs, vs = run(p[0] * x_scale, p[1] * v_scale)
        out = np.concatenate([(xs - xm) / x_scale, (vs - vm) / v_scale])
        return np.where(np.isfinite(out), out, 10.0)

    sol = least_squares(res, [x0 / x_scale, v0 / v_scale], method="lm", xtol=1e-8, max_nfev=60)
    if not (sol.success and np.all(np.isfinite(sol.x)) and sol.cost <= 0.5 * float(np.sum(res(
            np.array([x0 / x_scale, v0 / v_scale])) ** 2))):
        return x0, v0
    return float(sol.x[0] * x_scale), float(sol.x[1] * v_scale)


def _record(eom, rate, seconds, x0, noise, seed, wrong=None):
    """A noisy free response of ``eom`` (and the model ``wrong`` whose state is fitted)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(rate * seconds)) / rate
    sim = simulate(eom, t, x0=x0, v0=0.0)
    x = sim.x + noise * x0 * rng.normal(size=t.size)
    v = sim.v + noise * float(np.max(np.abs(sim.v))) * rng.normal(size=t.size)
    return t, x, v


CASES = [
    # (true model, fitted model, rate, seconds, x0, noise, start sample)
    (EquationOfMotion.create(mass=1.0, damping={"v": 2.0}, stiffness={"x": 4.0e5, "x^3": 5e12}),
     EquationOfMotion.create(mass=1.0, damping={"v": 1.0}, stiffness={"x": 4.3e5}), 5120.0, 1.0, 1e-3, 0.03, 7),
    (EquationOfMotion.create(mass=0.2, damping={"v": 0.05}, stiffness={"x": 800.0, "x^3": 3e6}),
     EquationOfMotion.create(mass=0.2, damping={"v": 0.05, "v^3": 0.01}, stiffness={"x": 790.0, "x^3": 4e6}),
     2000.0, 6.0, 0.02, 0.01, 3),
    (EquationOfMotion.create(mass=3.0, damping={"v": 0.4}, stiffness={"x": 9.6e3}),
     EquationOfMotion.create(mass=3.0, damping={"v": 0.4}, stiffness={"x": 9.6e3, "x^5": -1e10}),
     8000.0, 3.0, 5e-3, 0.05, 0),
    (EquationOfMotion.create(mass=0.5, damping={"v": 0.3}, stiffness={"x": 8e3}, effects=[
        {"name": "hysteresis", "params": {"yield_force_n": 2.0, "yield_displacement_m": 2e-4, "exponent": 1.5}}]),
     EquationOfMotion.create(mass=0.5, damping={"v": 0.3}, stiffness={"x": 8e3}, effects=[
         {"name": "hysteresis", "params": {"yield_force_n": 1.5, "yield_displacement_m": 3e-4, "exponent": 2.0}}]),
     5000.0, 2.0, 1e-3, 0.02, 11),
]


@pytest.mark.parametrize("case", range(len(CASES)))
def test_the_fitted_state_is_least_squares_bit_for_bit_from_fewer_simulations(case, monkeypatch) -> None:
    true, fitted, rate, seconds, x0, noise, s = CASES[case]
    t, x, v = _record(true, rate, seconds, x0, noise, seed=case)
    e = t.size
    xs, vs = float(np.max(np.abs(x[s:]))), float(np.max(np.abs(v[s:])))
    runs = {"ref": 0, "new": 0}
    real = free_simulator

    def counting(key):
        def make(*a, **k):
            run = real(*a, **k)

            def counted(*b):
                runs[key] += 1
                return run(*b)
            return counted
        return make

    globals()["free_simulator"] = counting("ref")
    try:
        want = _reference(fitted, t, x, v, None, s, e, xs, vs)
    finally:
        globals()["free_simulator"] = real
    monkeypatch.setattr(ist, "free_simulator", counting("new"))
    got = ist.fitted_state(fitted, t, x, v, None, s, e, xs, vs)
    assert got == want  # exactly the same numbers
    assert got != (float(x[s]), float(v[s]))  # the state was fitted (not the fallback)
    # least_squares' initial and final Jacobians (2 + 2 simulations) are not computed
    assert runs["new"] <= runs["ref"] - 2 and runs["ref"] >= 6


def test_levenberg_marquardt_is_least_squares_lm_bit_for_bit() -> None:
    rng = np.random.default_rng(3)
    tt = np.linspace(0.0, 4.0, 60)
    for k in range(25):
        a, b, c = rng.uniform(0.5, 2.0), rng.uniform(0.2, 3.0), rng.uniform(-1.0, 1.0)
        y = a * np.exp(-b * tt) * np.cos(3.0 * tt + c) + 0.02 * rng.normal(size=tt.size)

        def res(p):
            return p[0] * np.exp(-p[1] * tt) * np.cos(3.0 * tt + p[2]) - y

        p0 = np.array([1.0, 1.0, 0.0]) + rng.normal(0, 0.3, 3) * (k % 3)
        max_nfev = 60 if k % 5 else 6  # some stop at the evaluation cap (not a success)
        sol = least_squares(res, p0, method="lm", xtol=1e-8, max_nfev=max_nfev)
        p, cost, ok = ist.levenberg_marquardt(res, p0, xtol=1e-8, max_nfev=max_nfev)
        assert np.array_equal(p, sol.x) and cost == sol.cost and ok == sol.success


def test_the_first_crossings_are_the_whole_windows_from_a_prefix(monkeypatch) -> None:
    rng = np.random.default_rng(5)
    t = np.arange(20000) / 5000.0
    for k in range(6):
        x = np.exp(-0.3 * t) * np.sin(2 * np.pi * (7.0 + 9.0 * k) * t + k) + 0.02 * rng.normal(size=t.size)
        v = np.gradient(x, t)
        whole = zero_crossings(t, x, v, hysteresis=0.05)
        sizes = []

        def spy(tt, *a, **kw):
            sizes.append(tt.size)
            return zero_crossings(tt, *a, **kw)

        monkeypatch.setattr(ist, "zero_crossings", spy)
        got = ist._first_crossings(t, x, v, 0.05, 5)
        assert np.array_equal(got, whole[:5])
        assert sizes[-1] < t.size  # found in a prefix, not the whole window
    # a window with too few crossings: the whole window's
    x = np.exp(-t)
    assert ist._first_crossings(t, x, -x, 0.05, 5).size == 0
