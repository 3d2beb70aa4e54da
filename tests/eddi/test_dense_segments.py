"""simulate_dense's force-free part in segments, each stepped at the local frequency of the
amplitude the previous one reached (eddi.simulate.DENSE_SEGMENTS): a hardening ring-down
slows as it decays, and one grid at the first peak's frequency spent ~2.6x the RK4 steps
the decayed cycles need (the 45 s, 19.2 kHz duffing-smooth validation)."""

import importlib

import numpy as np

from eddi.model import EquationOfMotion

sim_mod = importlib.import_module("eddi.simulate")

#: paper Sec. 3.3.1's smooth Duffing rig (simulated_rig "duffing-smooth"); from v0 = 0.47 m/s
#: (its 600 N blow) the local frequency falls from ~110 rad/s at the first peak to ~25
PAPER = EquationOfMotion.create(mass=0.815, damping={"v": 0.196, "x^2*v": -20441.0, "v^3": 9.96},
                                stiffness={"x": 390.0, "x^2": -1.4e3, "x^3": 1.3e7, "x^4": -5.5e7, "x^5": 6.2e10})
V0, XS = 0.47, 0.0111


def _steps_counted(monkeypatch) -> list[int]:
    """RK4 steps of every force-free segment simulate_dense runs (eddi.simulate._free_runner:
    the simulator's kernel, as simulate would run it)."""
    counted: list[int] = []
    real = sim_mod._free_runner

    def counting(eom):
        run = real(eom)

        def counted_run(m, h, x0, v0, steps):
            counted.append((m - 1) * steps)
            return run(m, h, x0, v0, steps)

        return counted_run

    monkeypatch.setattr(sim_mod, "_free_runner", counting)
    return counted


def test_the_decayed_cycles_are_stepped_at_their_own_frequency(monkeypatch):
    rate, n = 19200.0, 19200 * 20
    t = np.arange(n) / rate
    counted = _steps_counted(monkeypatch)
    dense = sim_mod.simulate_dense(PAPER, t, x0=0.0, v0=V0, x_scale=XS, v_scale=V0)
    assert not dense.diverged and len(counted) == sim_mod.DENSE_SEGMENTS
    omega = sim_mod.local_angular_frequency(PAPER, XS, V0)
    one_grid = (n - 1) / rate * omega / sim_mod.DENSE_STEP_H_OMEGA
    assert sum(counted) < 0.75 * one_grid  # one grid at the first peak: 1.0
    monkeypatch.undo()
    # as exact as before: every sample with 64 sub-steps as the reference
    ref = sim_mod.simulate(PAPER, t, x0=0.0, v0=V0, substeps=4)
    amp = float(np.max(np.abs(ref.x)))
    assert float(np.max(np.abs(dense.x - ref.x))) < 3e-6 * amp
    assert float(np.max(np.abs(dense.v - ref.v))) < 5e-6 * float(np.max(np.abs(ref.v)))  # both: the first cycle (one grid: the same)


def test_one_segment_is_the_single_grid_bit_for_bit(monkeypatch):
    t = np.arange(19200 * 20) / 19200.0
    many = sim_mod.simulate_dense(PAPER, t, x0=0.0, v0=V0, x_scale=XS, v_scale=V0)
    monkeypatch.setattr(sim_mod, "DENSE_SEGMENTS", 1)
    one = sim_mod.simulate_dense(PAPER, t, x0=0.0, v0=V0, x_scale=XS, v_scale=V0)
    # the first segment is the single grid's first eighth, bit for bit; later ones differ slightly
    k = t.size // 8
    assert np.array_equal(one.x[:k], many.x[:k])
    assert float(np.max(np.abs(one.x - many.x))) < 1e-5 * float(np.max(np.abs(one.x)))


def test_a_diverging_model_is_flagged():
    bad = EquationOfMotion.create(mass=0.05, damping={"v": -0.5, "v^3": -50.0}, stiffness={"x": 300.0, "x^3": 3.0e8})
    t = np.arange(20000) / 20000.0
    out = sim_mod.simulate_dense(bad, t, x0=0.0, v0=V0, x_scale=XS, v_scale=V0)
    assert out.diverged
