"""A measured velocity's baseline drift is removed from ``v`` too, not only from the integrated ``x``.

Before (session 18): the velocity path removed the anchored drift from ``x`` only and kept the
measured ``v``; a slow baseline on a velocity channel (1 mm/s per s here) then inflated every
dissipation integral ``int v^2 dt`` at the low-amplitude end and phase one's linear damping came
out ~3x low (0.48 N s/m for 1.36; seed 3). The system: 1.03 kg, softening Duffing (k 3120 N/m,
k3 -2.45e8 N/m^3, 8.7 Hz), c 1.36 N s/m, 1 kHz, 5.4 s, a 12-sample blow, velocity noise 2.85e-4 m/s.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddi.conditioning import condition
from eddi.identify import identify
from eddi.model import EquationOfMotion
from eddi.simulate import simulate

M, K, K3, C, RATE, PRE = 1.03, 3120.0, -2.45e8, 1.36, 1000.0, 20


def _record(drift: float, seed: int):
    n, up, width = 5400, 16, 0.012
    peak = 1e-3 * M * math.sqrt(K / M) * math.pi / (2 * width)
    tf = np.arange(n * up) / (RATE * up) - PRE / RATE
    ff = np.where((tf >= 0) & (tf <= width), peak * np.sin(np.pi * np.clip(tf, 0, width) / width), 0.0)
    r = simulate(EquationOfMotion(mass=M, damping={"v": C}, stiffness={"x": K, "x^3": K3}), tf, force=ff)
    rng = np.random.default_rng(seed)
    t = tf[::up]
    v = r.v[::up] + 2.85e-4 * rng.standard_normal(n) + drift * (t - t[0])
    return t, ff[::up] + 0.01 * rng.standard_normal(n), v


@pytest.mark.parametrize("drift", [1e-3, -1e-3])
def test_velocity_baseline_drift_does_not_bias_damping(drift: float) -> None:
    t, f, v = _record(drift, seed=3)
    c = condition(t, vel=v, force=f)
    res = identify(t, c.x, c.v, M, damping="v", stiffness="x,x^3", a=c.a, window=c.window)
    assert abs(res.eom.damping["v"] / C - 1) < 0.03  # without the fix: 0.355 / 0.341 of C
    assert abs(res.eom.stiffness["x"] / K - 1) < 1e-3
