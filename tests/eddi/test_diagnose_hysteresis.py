"""Hysteresis (issue 10, item 5): the Bouc-Wen element, its simulation, and its verdicts.

The element's loop is checked against the elastic-perfectly-plastic closed form, its
simulation against an independent integration (the test cases' own RK4 of the Bouc-Wen
equations); a Bouc-Wen spring must be named ``hysteresis`` with its parameters, and the
look-alikes (quadratic drag, cubic damping) must not be.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.diagnosis import NAMED_FACTOR, diagnose
from eddi.hysteresis import bouc_wen_z
from eddi.model import Effect, EquationOfMotion
from eddi.simulate import simulate
from simulated_rig.systems import hide_effect
from tests.eddi.diagnose_cases import DAMPING, STIFFNESS, SYSTEM, bouc_wen_records, rig_records

MECHS = ["coulomb_friction", "quadratic_damping", "cubic_damping", "clearance", "smooth_stiffening",
         "hysteresis"]


def test_sharp_element_dissipates_the_elastic_plastic_loop() -> None:
    # n large: a spring F_y/d_y in series with a slider of F_y; a cycle of amplitude A > d_y
    # encloses the parallelogram 4 F_y (A - d_y)
    fy, dy, amp = 2.0, 1e-3, 3e-3
    x = amp * np.sin(np.linspace(0.0, 6 * np.pi, 30001))
    z = bouc_wen_z(x, dy, 40.0)
    assert np.max(np.abs(z)) <= 1.0 + 1e-9
    last = x.size * 2 // 3  # the third cycle: the virgin loading is over
    area = np.sum(0.5 * (z[last + 1:] + z[last:-1]) * np.diff(x[last:])) * fy
    assert area == pytest.approx(4 * fy * (amp - dy), rel=0.03)
    # below yield it is an elastic spring of stiffness F_y / d_y: no loop
    small = 0.05 * dy * np.sin(np.linspace(0.0, 4 * np.pi, 4001))
    zs = bouc_wen_z(small, dy, 40.0)
    np.testing.assert_allclose(zs * dy, small, atol=1e-3 * 0.05 * dy)


def _independent_bouc_wen(m, c, k_lin, fy, dy, n_exp, force, dt, sub=8):
    """RK4 of m a + c v + k x + F_y z = F, dz = v/d_y (1 - |z|^n (sign(v z) + 1)/2)."""
    def rhs(s, f):
        x, v, z = s
        dz = v / dy * (1.0 - abs(z) ** n_exp * (0.5 * np.sign(v * z) + 0.5))
        return np.array([v, (f - c * v - k_lin * x - fy * z) / m, dz])

    s = np.zeros(3)
    xs = np.zeros(force.size)
    h = dt / sub
    for j in range(force.size):
        xs[j] = s[0]
        f0, f1 = force[j], force[j + 1] if j + 1 < force.size else 0.0
        for q in range(sub):
            fa, fm, fb = (f0 + (f1 - f0) * r / sub for r in (q, q + 0.5, q + 1))
            k1 = rhs(s, fa)
            k2 = rhs(s + 0.5 * h * k1, fm)
            k3 = rhs(s + 0.5 * h * k2, fm)
            k4 = rhs(s + h * k3, fb)
            s = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return xs


def test_simulation_matches_an_independent_integration_and_round_trips() -> None:
    eom = EquationOfMotion.create(mass=0.1, damping={"v": 0.06}, stiffness={"x": 360.0}).with_effect(
        Effect(name="hysteresis", params={"yield_force_n": 0.144, "yield_displacement_m": 6e-4, "exponent": 1.5}))
    dt = 1 / 5000
    force = np.zeros(4000)
    force[5:15] = 20.0 * np.hanning(10)
    sim = simulate(eom, np.arange(force.size) * dt, force=force, substeps=8)
    ref = _independent_bouc_wen(0.1, 0.06, 360.0, 0.144, 6e-4, 1.5, force, dt)
    assert np.max(np.abs(sim.x - ref)) < 1e-4 * np.max(np.abs(ref))
    back = EquationOfMotion.from_json(eom.to_json())
    assert back.effect("hysteresis").params == eom.effect("hysteresis").params
    np.testing.assert_array_equal(simulate(back, sim.t, force=force, substeps=8).x, sim.x)


def test_bouc_wen_spring_is_named_hysteresis_with_its_parameters() -> None:
    # the test cases' Bouc-Wen spring: F_y = (1 - alpha) k d_y = 0.4 * 600 * 0.6 mm = 0.144 N
    d = diagnose(bouc_wen_records(1), SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS, mechanisms=MECHS)
    assert d.cause == "hysteresis", d.verdict
    assert d.extended.nrmse <= NAMED_FACTOR * d.noise_floor.nrmse
    assert d.extended.nrmse <= 0.5 * d.baseline.nrmse
    p = next(c for c in d.candidates if c.name == "hysteresis").params
    assert p["yield_force_n"] == pytest.approx(0.144, rel=0.15)
    assert p["yield_displacement_m"] == pytest.approx(6e-4, rel=0.2)
    # drag, its look-alike, was compared on the same held-out parts and lost
    drag = next(c for c in d.candidates if c.name == "quadratic_damping")
    assert drag.nrmse > 10 * d.extended.nrmse


def test_hysteresis_hidden_on_the_rig_is_named() -> None:
    truth = hide_effect(SYSTEM, "hysteresis", 0.1, 1, amplitude_m=1.98e-3, velocity_m_s=0.159)
    d = diagnose(rig_records(1, system=truth), SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS,
                 mechanisms=MECHS)
    assert d.cause == "hysteresis", d.verdict
    want = truth.effect("hysteresis").params["yield_force_n"]
    assert next(c for c in d.candidates if c.name == "hysteresis").params["yield_force_n"] == \
        pytest.approx(want, rel=0.3)


def test_drag_is_never_named_hysteresis() -> None:
    # hidden drag (0.06 k1 A, seed 2): the Bouc-Wen candidate, refitted by equation error,
    # cut the EDDI baseline 0.25 -> 0.045 but its own reference by only 25 %; it was named
    # before the full margin over its reference was required
    truth = hide_effect(SYSTEM, "quadratic_damping", 0.06, 2, amplitude_m=1.98e-3, velocity_m_s=0.159)
    d = diagnose(rig_records(2, system=truth), SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS,
                 mechanisms=MECHS)
    assert d.cause in ("quadratic_damping", "unexplained", "none"), d.verdict
    hy = next(c for c in d.candidates if c.name == "hysteresis")
    assert hy.gain < 0.5  # measured against its own fitter's baseline


def test_cubic_damping_is_not_named_hysteresis() -> None:
    a, v = 1.98e-3, 0.159
    truth = EquationOfMotion.create(mass=0.1, damping={"v": 0.06, "v^3": 0.2 * 600 * a / v**3},
                                    stiffness={"x": 600.0, "x^3": 2e7})
    d = diagnose(rig_records(1, system=truth), SYSTEM.mass, damping="v", stiffness=STIFFNESS, mechanisms=MECHS)
    assert d.cause == "cubic_damping", d.verdict
