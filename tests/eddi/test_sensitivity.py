"""Forward sensitivities (:mod:`eddi.sensitivity`) against finite differences of the simulator,
and the block means the refinement compares (:mod:`eddi.refine`)."""

from __future__ import annotations

import numpy as np
import pytest

from eddi.model import EquationOfMotion
from eddi.refine import block_means, smooth_model
from eddi.sensitivity import free_response_sensitivities
from eddi.simulate import simulate

MODELS = {
    "duffing": EquationOfMotion.create(mass=0.8, damping={"v": 0.2, "x^2*v": -2.0e4, "v^3": 10.0},
                                       stiffness={"x": 390.0, "x^2": -1400.0, "x^3": 1.3e7}),
    "abs": EquationOfMotion.create(mass=0.3, damping={"v": 0.4, "abs(v)*v": 0.3},
                                        stiffness={"x": 900.0, "abs(x)*x": 2.0e3}),
}


@pytest.mark.parametrize("name", sorted(MODELS))
def test_jacobian_matches_finite_differences_of_the_simulator(name: str) -> None:
    eom = MODELS[name]
    dt, n, x0, v0, sub = 1e-3, 3000, 0.004, 0.3, 4
    resp, jac, div = free_response_sensitivities(eom, dt, n, x0, v0, sub)
    assert not div
    sim = simulate(eom, np.arange(n) * dt, x0=x0, v0=v0, substeps=sub)
    assert np.max(np.abs(resp[:, 0] - sim.x)) <= 1e-12 * np.max(np.abs(sim.x))
    assert np.max(np.abs(resp[:, 2] - sim.a)) <= 1e-12 * np.max(np.abs(sim.a))
    names = list(eom.damping) + list(eom.stiffness)
    for k in range(len(names) + 2):
        if k < len(names):  # central differences of one coefficient
            c = {**eom.damping, **eom.stiffness}[names[k]]
            h = 1e-5 * abs(c)

            def sim_at(dc: float):
                d = {t: v + (dc if t == names[k] else 0.0) for t, v in eom.damping.items()}
                s = {t: v + (dc if t == names[k] else 0.0) for t, v in eom.stiffness.items()}
                return simulate(eom.model_copy(update={"damping": d, "stiffness": s}), np.arange(n) * dt,
                                x0=x0, v0=v0, substeps=sub)
            hi, lo = sim_at(h), sim_at(-h)
        else:
            h = 1e-6 * (abs(x0) if k == len(names) else abs(v0))
            dx0, dv0 = (h, 0.0) if k == len(names) else (0.0, h)
            hi = simulate(eom, np.arange(n) * dt, x0=x0 + dx0, v0=v0 + dv0, substeps=sub)
            lo = simulate(eom, np.arange(n) * dt, x0=x0 - dx0, v0=v0 - dv0, substeps=sub)
        for ch, (a, b) in enumerate(((hi.x, lo.x), (hi.v, lo.v), (hi.a, lo.a))):
            fd = (a - b) / (2 * h)
            assert np.linalg.norm(jac[ch, :, k] - fd) <= 1e-4 * np.linalg.norm(fd), (names + ["x0", "v0"])[k]


def test_divergence_leaves_nan_after_the_last_sample_it_reached() -> None:
    # a negative linear damping and a softening cubic: the state runs away; every sample up
    # to the divergence is the simulator's, everything after it NaN (response and Jacobian)
    eom = EquationOfMotion.create(mass=0.1, damping={"v": -0.5}, stiffness={"x": 600.0, "x^3": -3e7})
    n = 4000
    resp, jac, div = free_response_sensitivities(eom, 1e-3, n, 0.004, 0.0, 4)
    assert div
    ok = np.isfinite(resp[:, 0])
    k = int(np.argmin(ok))
    assert 0 < k < n and not np.any(ok[k:])
    assert np.all(np.isnan(resp[k:])) and np.all(np.isnan(jac[:, k:]))
    assert np.all(np.isfinite(jac[:, :k]))
    sim = simulate(eom, np.arange(n) * 1e-3, x0=0.004, v0=0.0, substeps=4)
    assert sim.diverged and np.allclose(resp[:k - 1, 0], sim.x[:k - 1], rtol=1e-9, atol=1e-15)


def test_dry_friction_falls_back_to_finite_differences() -> None:
    # sign(v) switches the force at each reversal: the sensitivities would miss the jumps
    assert smooth_model(MODELS["abs"]) and smooth_model(MODELS["duffing"])
    assert not smooth_model(EquationOfMotion.create(mass=0.3, damping={"v": 0.4, "sign(v)": 0.05},
                                                    stiffness={"x": 900.0}))


def test_block_means_carry_a_quarter_of_the_noise_and_the_curvature_correction() -> None:
    rng = np.random.default_rng(1)
    noise = rng.normal(0.0, 1.0, 16 * 20000)
    b = block_means(noise, 15)
    assert b.size == noise.size // 15
    assert abs(np.var(b) * 15 - 1.0) < 0.05  # white noise: variance / block
    # a sinusoid at 20 samples a block-period: centre value + curvature within (w h)^4
    dt, blk = 1e-4, 15
    t = np.arange(15 * 400) * dt
    w = 0.2 / (blk * dt)
    y = np.sin(w * t)
    m = block_means(y, blk)
    c = y[(blk - 1) // 2::blk][: m.size]
    d2 = np.zeros_like(c)
    d2[1:-1] = c[2:] - 2 * c[1:-1] + c[:-2]
    corrected = c + (blk**2 - 1) / (24 * blk**2) * d2
    assert np.max(np.abs(m - c)[1:-1]) > 1e-3  # the uncorrected centre is off by (w h)^2 / 24
    assert np.max(np.abs(m - corrected)[1:-1]) < 5e-6


def test_dense_simulation_matches_every_sample_and_falls_back_for_sharp_models() -> None:
    from eddi.simulate import simulate_dense

    eom = MODELS["duffing"]
    t = np.arange(200000) / 20000.0  # 10 s at 20 kHz, ~4 Hz
    force = np.where(t < 2e-3, 300.0 * np.sin(np.pi * t / 2e-3), 0.0)
    ref = simulate(eom, t, force=force, x_scale=0.012, v_scale=0.5)
    dense = simulate_dense(eom, t, force=force, x_scale=0.012, v_scale=0.5)
    amp = np.max(np.abs(ref.x))
    assert np.max(np.abs(dense.x - ref.x)) < 1e-5 * amp
    assert np.max(np.abs(dense.v - ref.v)) < 1e-5 * np.max(np.abs(ref.v))
    assert np.array_equal(dense.x[:40], ref.x[:40])  # the impact itself on every sample
    dry = eom.model_copy(update={"damping": {"v": 0.2, "sign(v)": 0.01}})
    assert np.array_equal(simulate_dense(dry, t, force=force, x_scale=0.012, v_scale=0.5).x,
                          simulate(dry, t, force=force, x_scale=0.012, v_scale=0.5).x)


def test_compiled_internal_force_equals_the_model_s() -> None:
    from eddi.simulate import internal_force

    rng = np.random.default_rng(2)
    x, v = rng.normal(0, 0.01, 500), rng.normal(0, 0.3, 500)
    for eom in MODELS.values():
        ref = eom.restoring_force(x, v)
        assert np.max(np.abs(internal_force(eom, x, v) - ref)) <= 1e-12 * np.max(np.abs(ref))


def test_local_substeps_follow_the_decay_and_keep_the_peak_rule() -> None:
    from eddi.refine import local_substeps

    eom = MODELS["duffing"]
    t = np.arange(4000) * 2e-3
    env = 0.012 * np.exp(-t / 2.0)  # a ring-down's envelope
    steps = local_substeps(eom, 2e-3, env, 30.0 * env, most=6)
    assert steps.shape == (3999,) and steps.min() >= 1 and steps.max() <= 6
    # hardening: ~88 rad/s at the peak (2 steps of omega h <= 0.1: 0.176 / 0.1 rounded up; 4 before
    # session 17's LOCAL_H_OMEGA 0.05 -> 0.1), 22 rad/s at the end (1)
    assert steps[0] == 2 and steps[-1] == 1
    assert np.all(np.diff(steps) <= 0)  # never more steps as the amplitude falls
    assert local_substeps(eom, 2e-3, env, 30.0 * env, most=1).max() == 1  # the peak's rule caps it
