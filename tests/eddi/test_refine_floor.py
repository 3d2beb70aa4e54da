"""The output-error fit's model floor: its own RK4 error is corrected
(:func:`eddi.intervals.integration_shift`) and block means are compared to fourth order
(:func:`eddi.intervals.sampling_quartic`), so a clean long record's 95 % intervals hold.

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
from eddi.simulate import simulate


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
    assert abs(derr) < 1.5e-6, derr  # uncorrected: -2.2e-5 (RK4's amplitude error; 3.3 % of it left)
    assert abs(derr) <= info.ci95["damping"]["v"] / c


def test_heavy_slow_structure_every_coefficient_inside_its_interval() -> None:
    """800 kg at 2 Hz with ``v^3`` and ``x^3``, sampled at 10 kHz (the refinement compares
    blocks of 99 samples): the free response simulated with 4 RK4 steps a sample (its own
    error far below the noise), 100 dB. Before the block means were compared through the
    fourth difference and the fit's RK4 error was corrected, ``k1`` ended 2.8e-7 off on a
    half width of 2.1e-8 (z ~ 26) and ``k3`` 4.4e-6 on 3.8e-6."""
    m, f = 800.0, 2.0
    w = 2 * math.pi * f
    k1, b1 = m * w * w, 2 * 0.005 * m * w
    vp = 0.03
    xp = vp / w
    eom = EquationOfMotion.create(mass=m, damping={"v": b1, "v^3": 0.4 * b1 / vp**2},
                                  stiffness={"x": k1, "x^3": 0.02 * k1 / xp**2})
    rate = 10000.0
    n = int(20 * rate)
    sim = simulate(eom, np.arange(n) / rate, x0=0.0, v0=vp, substeps=4)
    rng = np.random.default_rng(1)
    a = sim.a + 1e-5 * float(np.max(np.abs(sim.a))) * rng.standard_normal(n)
    got, info = refine_output_error(eom, sim.t, sim.x, sim.v, a, channel="a")
    assert info.block > 50
    for group in ("damping", "stiffness"):
        for term, c in getattr(eom, group).items():
            err = getattr(got, group)[term] - c
            assert abs(err) <= info.ci95[group][term], (term, err / c, info.ci95[group][term] / abs(c))
