"""The output-error fit's own RK4 error is corrected (:func:`eddi.intervals.integration_shift`).

An exact (analytic) free response of a damped linear oscillator, sampled at ~33 samples a
cycle: the refinement integrates at ``omega h ~ 0.095``, where RK4's frequency is
``(omega h)^4 / 120`` low, and the fitted ``k1`` ended ``(omega h)^4 / 60 ~ 1.3e-6`` high
and ``b1`` 2.2e-5 low (RK4's amplitude error), far beyond their 95 % half widths on a clean
long record. Corrected, both are within them.
"""

from __future__ import annotations

import math

import numpy as np

from eddi.model import EquationOfMotion
from eddi.refine import refine_output_error


def exact_free_response(m: float, c: float, k: float, t: np.ndarray, x0: float, v0: float):
    """``x, v, a`` of ``m x'' + c x' + k x = 0`` (analytic)."""
    wn = math.sqrt(k / m)
    zeta = c / (2.0 * math.sqrt(k * m))
    wd = wn * math.sqrt(1.0 - zeta**2)
    s = zeta * wn
    b = (v0 + s * x0) / wd
    e = np.exp(-s * t)
    x = e * (x0 * np.cos(wd * t) + b * np.sin(wd * t))
    v = e * ((-s * x0 + wd * b) * np.cos(wd * t) + (-s * b - wd * x0) * np.sin(wd * t))
    a = -(c * v + k * x) / m
    return x, v, a


def test_k1_free_of_the_fits_integration_error() -> None:
    m, f, zeta = 2.0, 30.0, 0.002
    k = m * (2 * math.pi * f) ** 2
    c = 2 * zeta * math.sqrt(k * m)
    rate = 1000.0  # 33 samples a cycle: the fit's RK4 at omega h ~ 0.095
    t = np.arange(int(8.0 * rate)) / rate
    x, v, a = exact_free_response(m, c, k, t, 1e-3, 0.0)
    rng = np.random.default_rng(3)
    a_meas = a + 1e-6 * float(np.max(np.abs(a))) * rng.standard_normal(t.size)  # 120 dB
    start = EquationOfMotion.create(mass=m, damping={"v": c * 1.01}, stiffness={"x": k * 0.999})
    eom, info = refine_output_error(start, t, x, v, a_meas, channel="a")
    err = eom.stiffness["x"] / k - 1.0
    half = info.ci95["stiffness"]["x"] / k
    assert abs(err) < 2e-7, err  # uncorrected: +1.3e-6
    assert abs(err) <= half, (err, half)
    derr = eom.damping["v"] / c - 1.0
    assert abs(derr) < 3e-7, derr  # uncorrected: -2.2e-5 (RK4's amplitude error)
    assert abs(derr) <= info.ci95["damping"]["v"] / c
