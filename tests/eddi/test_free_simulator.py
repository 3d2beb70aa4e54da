"""eddi.simulate.free_simulator: simulate() as a function of the initial state, set up once."""

from __future__ import annotations

import numpy as np
import pytest

from eddi.errors import SignalError
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


class _CountingKernels:
    """The simulator's kernels, counting the runs of each."""

    def __init__(self, inner: object) -> None:
        self.inner = inner
        self.calls: dict[str, int] = {}

    def __getattr__(self, name: str):  # type: ignore[no-untyped-def]
        fn = getattr(self.inner, name)

        def counted(*args, **kw):  # type: ignore[no-untyped-def]
            self.calls[name] = self.calls.get(name, 0) + 1
            return fn(*args, **kw)
        return counted


@pytest.mark.parametrize("name", ["polynomial", "hysteresis"])
def test_free_simulator_runs_nothing_until_called(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Setting up runs no simulation (session 12 ran a probe at rest for its sub-steps: one
    simulation of the window per fitted initial state); each call runs exactly one."""
    import sys

    import eddi.hysteresis as hysteresis

    simulate_module = sys.modules["eddi.simulate"]  # (eddi.simulate, the attribute, is the function)
    eom = MODELS[name]
    t = np.arange(2000) * 1e-4
    counting = {m: _CountingKernels(m._KERNELS) for m in (simulate_module, hysteresis)}
    for m, k in counting.items():
        monkeypatch.setattr(m, "_KERNELS", k)
    run = free_simulator(eom, t, x_scale=0.01, v_scale=0.5)
    runs = lambda: sum(c.calls.get(k, 0) for c in counting.values() for k in ("_rk4", "_rk4_hyst"))  # noqa: E731
    assert runs() == 0
    run(4e-3, -0.2)
    run(-7e-3, 0.31)
    assert runs() == 2


def test_free_simulator_checks_the_grid_and_force_as_simulate() -> None:
    eom = MODELS["polynomial"]
    t = np.arange(100) * 1e-4
    bad_t = t.copy()
    bad_t[50] += 3e-5
    with pytest.raises(SignalError, match="uniform"):
        free_simulator(eom, bad_t, x_scale=0.01, v_scale=0.5)
    with pytest.raises(SignalError, match="NaN"):
        free_simulator(eom, t, force=np.full(100, np.nan), x_scale=0.01, v_scale=0.5)
