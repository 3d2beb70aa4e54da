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
    # turning points (small |v|) are left out
    assert 0 < p2.samples_used < i1 - i0


def test_lagrangian_route_excludes_more_with_a_larger_v_fraction(hardening):
    sim, p1, i0, i1 = hardening
    terms = parse_terms("x,x^3")
    few = lagrangian_route(p1, sim.x[i0:i1], sim.v[i0:i1], 0.5, terms, v_fraction=0.6)
    many = lagrangian_route(p1, sim.x[i0:i1], sim.v[i0:i1], 0.5, terms, v_fraction=0.05)
    assert few.samples_used < many.samples_used
