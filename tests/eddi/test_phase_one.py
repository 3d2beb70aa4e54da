"""Phase one: zero crossings, quadrature, and damping from the crossing energy balance."""

from __future__ import annotations

import numpy as np
import pytest

from eddi import EquationOfMotion, IdentificationError, parse_terms, simulate
from eddi.energy import cumulative_energy, integrated_term, noise_level, zero_crossings
from eddi.phase_one import phase_one
from eddi.terms import parse_term


def test_zero_crossings_of_a_sine_are_exact_to_sub_sample():
    f, phase = 3.3, 0.1
    t = np.arange(1001) / 1000.0  # 300 samples per period
    x = np.sin(2 * np.pi * f * t + phase)
    v = 2 * np.pi * f * np.cos(2 * np.pi * f * t + phase)
    g = zero_crossings(t, x, v)
    exact = (np.arange(1, 7) * np.pi - phase) / (2 * np.pi * f)
    assert g.size == 6
    assert np.max(np.abs(g - exact)) < 1e-9  # sample step is 1e-3 s


def test_zero_crossing_at_a_sample_counts_once():
    t = np.arange(5.0)
    x = np.array([-1.0, 0.0, 1.0, 2.0, 3.0])
    g = zero_crossings(t, x, np.ones(5))
    assert g.tolist() == [1.0]


def test_dead_band_ignores_chatter():
    t = np.arange(8.0)
    x = np.array([-1.0, -0.1, 0.05, -0.05, 0.1, 1.0, 1.0, -1.0])
    v = np.gradient(x, t)
    assert zero_crossings(t, x, v).size == 4
    g = zero_crossings(t, x, v, hysteresis=0.5)
    assert g.size == 2  # one passage up (the last sign change, in [3, 4]) and one down
    assert 3.0 < g[0] < 4.0 and 6.0 < g[1] < 7.0


def test_noise_level_recovers_white_noise_sigma():
    rng = np.random.default_rng(1)
    t = np.arange(20000) / 1e4
    y = np.sin(2 * np.pi * 5 * t) + rng.normal(0, 1e-3, t.size)
    assert noise_level(y) == pytest.approx(1e-3, rel=0.05)


@pytest.mark.parametrize(
    "text, exact",
    [("x", lambda x: x**2 / 2), ("x^3", lambda x: x**4 / 4), ("x^2", lambda x: x**3 / 3),
     ("abs(x)*x", lambda x: np.abs(x) ** 3 / 3), ("sign(x)", np.abs), ("abs(x)", lambda x: np.sign(x) * x**2 / 2)],
)
def test_integrated_term_is_the_antiderivative_from_zero(text, exact):
    x = np.linspace(-2, 2, 41)
    assert np.allclose(integrated_term(parse_term(text), x), exact(x), rtol=0, atol=1e-14)


def test_cumulative_energy_integrates_between_arbitrary_points():
    t = np.arange(401) / 100.0
    power = np.cos(3 * t) ** 2
    antider = cumulative_energy(t, power)
    a, b = 0.123, 3.217  # not on the grid
    exact = (b - a) / 2 + (np.sin(6 * b) - np.sin(6 * a)) / 12
    assert antider(b) - antider(a) == pytest.approx(exact, rel=1e-9)


def _linear_free_response(c=0.3, k=400.0, m=1.2, n=6000, rate=1000.0):
    eom = EquationOfMotion.create(mass=m, damping={"v": c}, stiffness={"x": k})
    sim = simulate(eom, rate_hz=rate, n_samples=n, x0=0.01, v0=0.0, substeps=16)
    return sim.t, sim.x, sim.v, m


def test_linear_damping_recovered_from_crossings():
    t, x, v, m = _linear_free_response()
    p1 = phase_one(t, x, v, m, parse_terms("v,v^3"))
    assert p1.as_dict()["v"] == pytest.approx(0.3, rel=1e-6)
    assert abs(p1.as_dict()["v^3"]) < 1e-6
    # E(gamma_i) = T(gamma_i), and D matches R at the crossings
    assert np.allclose(p1.dissipated_model_at_gamma, p1.r_vector, rtol=0, atol=1e-9 * p1.kinetic_at_gamma[0])
    # consecutive crossings half a damped period apart
    wd = np.sqrt(400.0 / 1.2 - (0.3 / 2.4) ** 2)
    assert np.allclose(np.diff(p1.gamma), np.pi / wd, rtol=1e-6)


@pytest.mark.parametrize("weighting", ["relative", "paper"])
def test_both_weightings_agree_on_exact_data(weighting):
    t, x, v, m = _linear_free_response()
    p1 = phase_one(t, x, v, m, parse_terms("v"), weighting=weighting)
    assert p1.weighting == weighting
    assert p1.coefficients[0] == pytest.approx(0.3, rel=1e-6)


def test_too_few_crossings_says_how_many():
    t = np.arange(200) / 100.0
    x = np.sin(np.pi * t + 0.3)[:150]  # one crossing in the record
    v = (np.pi * np.cos(np.pi * t + 0.3))[:150]
    with pytest.raises(IdentificationError, match=r"found 1 zero crossing of x; need at least 4"):
        phase_one(t[:150], x, v, 1.0, parse_terms("v,x^2*v,v^3"))
