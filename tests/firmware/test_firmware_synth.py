"""The firmware's on-chip oscillator (firmware/src/synth.c, built for the host with gcc) against
the equation it claims to integrate, solved independently with scipy's DOP853."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

REPO = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.skipif(shutil.which("gcc") is None or shutil.which("make") is None,
                                reason="needs gcc and make to build the firmware source for the host")


def _firmware_samples(rate: float, n: int, m: float, c: float, k1: float, k3: float) -> np.ndarray:
    proc = subprocess.run(["make", "-s", "-C", str(REPO / "firmware"), "host"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    out = subprocess.run([str(REPO / "firmware" / "build" / "host" / "codec_check")],
                         input=f"synth {rate!r} {n} {m!r} {c!r} {k1!r} {k3!r} 0\n", capture_output=True, text=True,
                         check=True).stdout
    return np.array([[float(v) for v in line.split()] for line in out.splitlines()])


@pytest.mark.parametrize("rate, m, c, k1, k3", [
    (3906.25, 0.5, 0.8, 2000.0, 5.0e6),     # the firmware's default
    (7812.5, 0.8, 1.2, 1200.0, 2.0e6),      # another mass, rate and stiffness
])
def test_firmware_oscillator_follows_its_equation(rate, m, c, k1, k3):
    """First blow (400 N, 2 ms half-sine at 1.5 s) and 2.5 s of ring-down: the firmware's force
    is the half-sine to float32 precision; its acceleration matches an independent DOP853
    solution within 1 % of the peak free response (RK4, one step per sample, across the pulse's
    kinks) and a float64 RK4 of the same scheme within 1e-4 (float32 rounding only)."""
    n = int(4.0 * rate)
    fa = _firmware_samples(rate, n, m, c, k1, k3)
    t = np.arange(n) / rate
    tb, width, peak = round(1.5 * rate) / rate, 2e-3, 400.0

    def force(tt: float) -> float:
        return peak * np.sin(np.pi * (tt - tb) / width) if tb <= tt <= tb + width else 0.0

    def accel(x, v, f):
        return (f - c * v - k1 * x - k3 * x**3) / m

    def rhs(tt, y):
        return [y[1], accel(y[0], y[1], force(tt))]

    # at rest until the blow; the blow with small steps; the free ring-down at the solver's pace
    on = (t >= tb) & (t <= tb + width)
    free = t > tb + width
    blow = solve_ivp(rhs, (tb, tb + width), [0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-14,
                     t_eval=t[on], max_step=width / 200, dense_output=True)
    ring = solve_ivp(rhs, (tb + width, t[-1]), blow.sol(tb + width), method="DOP853", rtol=1e-11, atol=1e-14,
                     t_eval=t[free])
    xv = np.zeros((2, n))
    xv[:, on], xv[:, free] = blow.y, ring.y
    f_ref = np.array([force(tt) for tt in t])
    a_ref = accel(xv[0], xv[1], f_ref)
    assert np.max(np.abs(fa[:, 0] - f_ref)) < 1e-4 * peak
    scale = np.max(np.abs(a_ref[free]))
    assert np.max(np.abs(fa[free, 1] - a_ref[free])) < 0.01 * scale
    h, x, v, a_rk4 = 1.0 / rate, 0.0, 0.0, np.zeros(n)
    for k in range(n):  # the firmware's scheme in float64
        tk = k * h
        f0, fm, f1 = force(tk), force(tk + h / 2), force(tk + h)
        a_rk4[k] = accel(x, v, f0)
        k1x, k1v = v, accel(x, v, f0)
        k2x, k2v = v + h / 2 * k1v, accel(x + h / 2 * k1x, v + h / 2 * k1v, fm)
        k3x, k3v = v + h / 2 * k2v, accel(x + h / 2 * k2x, v + h / 2 * k2v, fm)
        k4x, k4v = v + h * k3v, accel(x + h * k3x, v + h * k3v, f1)
        x += h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x)
        v += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    assert np.max(np.abs(fa[free, 1] - a_rk4[free])) < 1e-4 * scale
