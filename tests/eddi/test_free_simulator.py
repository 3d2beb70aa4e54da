"""eddi.simulate.free_simulator: simulate() as a function of the initial state, set up once."""

from __future__ import annotations

import numpy as np
import pytest

from eddi.model import Effect, EquationOfMotion
from eddi.simulate import free_simulator, simulate

MODELS = {
    "polynomial": EquationOfMotion.create(mass=0.1, damping={"v": 0.06, "x^2*v": 3.0},
                                          stiffness={"x": 600.0, "x^3": 2e7}),
    "clearance": EquationOfMotion.create(mass=0.1, damping={"v": 0.06}, stiffness={"x": 600.0}).model_copy(
        update={"effects": (Effect(name="clearance", params={"gap_m": 1e-3, "stiffness_n_per_m": 900.0}),)}),
    "hysteresis": EquationOfMotion.create(mass=0.1, damping={"v": 0.06}, stiffness={"x": 600.0}).model_copy(
        update={"effects": (Effect(name="hysteresis", params={
            "yield_force_n": 0.5, "yield_displacement_m": 2e-3, "exponent": 2.0}),)}),
}


@pytest.mark.parametrize("name", sorted(MODELS))
@pytest.mark.parametrize("driven", [False, True])
def test_free_simulator_equals_simulate_bit_for_bit(name: str, driven: bool) -> None:
    eom = MODELS[name]
    t = np.arange(2000) * 1e-4
    force = np.where(t < 2e-3, 20.0 * np.sin(np.pi * t / 2e-3), 0.0) if driven else None
    run = free_simulator(eom, t, force=force, x_scale=0.01, v_scale=0.5)
    for x0, v0 in ((0.0, 0.0), (4e-3, -0.2), (-7e-3, 0.31)):
        ref = simulate(eom, t, force=force, x0=x0, v0=v0, x_scale=0.01, v_scale=0.5)
        x, v = run(x0, v0)
        assert np.array_equal(x, ref.x) and np.array_equal(v, ref.v)
        assert np.any(x != 0.0) or (x0 == v0 == 0.0 and force is None)  # a response, not zeros
