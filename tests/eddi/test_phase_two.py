"""Phase two: stiffness from the potential route and from the paper's Lagrangian route."""

from __future__ import annotations

import numpy as np
import pytest

from eddi import EquationOfMotion, parse_terms, simulate
from eddi.phase_one import phase_one
from eddi.phase_two import lagrangian_route, potential_route


@pytest.fixture(scope="module")
def hardening():
    """m x'' + c v + k x + k3 x^3 + k2 x^2 = 0 from x0 = 0.02, simulated tightly."""
    eom = EquationOfMotion.create(mass=0.5, damping={"v": 0.4},
                                  stiffness={"x": 800.0, "x^2": 3000.0, "x^3": 2e6})
    sim = simulate(eom, rate_hz=2000.0, n_samples=8000, x0=0.02, v0=0.0, substeps=32)
    p1 = phase_one(sim.t, sim.x, sim.v, 0.5, parse_terms("v"))
    i0, i1 = p1.sample_slice
    return sim, p1, i0, i1


def test_potential_route_recovers_stiffness_including_even_terms(hardening):
    sim, p1, i0, i1 = hardening
    p2 = potential_route(p1, sim.x[i0:i1], parse_terms("x,x^2,x^3"))
    k = p2.as_dict()
    assert p2.route == "potential"
    assert k["x"] == pytest.approx(800.0, rel=1e-5)
    assert k["x^2"] == pytest.approx(3000.0, rel=1e-3)
    assert k["x^3"] == pytest.approx(2e6, rel=1e-5)
    # potential samples follow V(x) = k x^2/2 + k2 x^3/3 + k3 x^4/4
    x = p2.x
    v_exact = 800 * x**2 / 2 + 3000 * x**3 / 3 + 2e6 * x**4 / 4
    assert np.max(np.abs(p2.potential - v_exact)) < 1e-6 * np.max(v_exact)
    assert p2.conservative_force is None


def test_lagrangian_route_gives_the_restoring_force(hardening):
    sim, p1, i0, i1 = hardening
    p2 = lagrangian_route(p1, sim.x[i0:i1], sim.v[i0:i1], 0.5, parse_terms("x,x^2,x^3"))
    k = p2.as_dict()
    assert p2.route == "lagrangian"
    assert k["x"] == pytest.approx(800.0, rel=1e-3)
    assert k["x^3"] == pytest.approx(2e6, rel=1e-3)
    # the conservative force samples are -K(x) (paper Eq. 16)
    x = p2.x
    f_exact = -(800 * x + 3000 * x**2 + 2e6 * x**3)
    assert np.max(np.abs(p2.conservative_force - f_exact)) < 1e-3 * np.max(np.abs(f_exact))
    # every sample is used, the turning points too (the force is m a + B in closed form,
    # nothing is divided by v), and the first quarter cycle before gamma_0
    assert p2.samples_used == i1 - i0 == sim.t.size
    assert np.min(np.abs(sim.v[i0:i1])) < 1e-3 * np.max(np.abs(sim.v))
    # with the re-anchored energy the turning points are left out (its misfit power / v)
    anchored = lagrangian_route(p1, sim.x[i0:i1], sim.v[i0:i1], 0.5, parse_terms("x,x^2,x^3"), anchored=True,
                                v_fraction=0.2)
    assert 0 < anchored.samples_used < i1 - i0
    assert anchored.as_dict()["x^3"] == pytest.approx(2e6, rel=1e-3)


def test_phase_one_energy_covers_the_half_cycle_before_the_first_crossing(hardening):
    sim, p1, i0, i1 = hardening
    # released from a turning point: the first quarter cycle lies before gamma_0
    assert p1.gamma[0] > sim.t[50]
    assert (i0, i1) == (0, sim.t.size)
    e_exact = 0.5 * 0.5 * sim.v**2 + 800 * sim.x**2 / 2 + 3000 * sim.x**3 / 3 + 2e6 * sim.x**4 / 4
    before = p1.t < p1.gamma[0]
    after = p1.t > p1.gamma[-1]
    assert before.sum() > 50 and after.sum() > 0
    for energy in (p1.mechanical_anchored, p1.mechanical):
        assert np.max(np.abs(energy[before] - e_exact[before]) / e_exact[before]) < 1e-6
    assert np.max(np.abs(p1.mechanical_anchored[after] - e_exact[after]) / e_exact[after]) < 1e-5


def test_lagrangian_route_excludes_more_with_a_larger_v_fraction(hardening):
    sim, p1, i0, i1 = hardening
    terms = parse_terms("x,x^3")
    few = lagrangian_route(p1, sim.x[i0:i1], sim.v[i0:i1], 0.5, terms, v_fraction=0.6)
    many = lagrangian_route(p1, sim.x[i0:i1], sim.v[i0:i1], 0.5, terms, v_fraction=0.05)
    assert few.samples_used < many.samples_used


@pytest.mark.parametrize("anchored", [True, False])
def test_energy_rate_is_the_derivative_of_phase_ones_energy(hardening, anchored):
    from eddi.phase_two import energy_rate, mechanical_energy

    sim, p1, i0, i1 = hardening
    rate = energy_rate(p1, sim.x[i0:i1], sim.v[i0:i1], anchored)
    energy = mechanical_energy(p1, anchored)
    # 4th-order central differences inside each half cycle (the anchored energy has kinks at
    # the crossings); their own error here is ~(2 omega h)^4 / 30 ~ 1e-6
    dt = float(p1.t[1] - p1.t[0])
    central = (-energy[4:] + 8 * energy[3:-1] - 8 * energy[1:-3] + energy[:-4]) / (12 * dt)
    inside = np.searchsorted(p1.gamma, p1.t[:-4]) == np.searchsorted(p1.gamma, p1.t[4:])
    scale = float(np.max(np.abs(rate)))
    assert np.max(np.abs(central[inside] - rate[2:-2][inside])) < 1e-5 * scale
    # without re-anchoring it is minus the modelled damping power: -b v^2 here
    if not anchored:
        b = p1.coefficients[0]
        assert np.allclose(rate, -b * sim.v[i0:i1] ** 2, rtol=1e-12, atol=0)


def test_term_matrix_matches_term_evaluation():
    from eddi.energy import term_matrix
    from eddi.terms import evaluate

    rng = np.random.default_rng(0)
    x, v = rng.standard_normal(200), rng.standard_normal(200)
    terms = parse_terms("v,x^2*v,v^3,x,x^2,x^5,abs(v)*v,sign(v),abs(x)^3,x*abs(x),sign(x)*v^2")
    assert np.allclose(term_matrix(terms, x, v), evaluate(terms, x, v), rtol=1e-14, atol=0)
