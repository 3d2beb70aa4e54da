"""A free decay measured by a velocity sensor: the refinement's judge starts each model from its
fitted state, not from the first sample's (an integration constant and one noisy sample).

Session 14 (s14ci95): on ``benchmarks/bench_ci_coverage_coarse.py --family sensor --record
free-vel`` the judge rejected the refinement on 26 of 80 records; EDDI's estimate came back
with the interval ``|c_EDDI - c_OE| + ci95_OE`` (honest, 6-10x wider). This record is draw 18
of seed 1 there (0.37 kg, 19.5 Hz, 9.4 kHz, 47 dB).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddi.fit_record import Pipeline
from eddi.model import EquationOfMotion
from eddi.simulate import simulate
from simulated_rig.sensors import active_rms

MASS, F_HZ, ZETA, RATE, SNR = 0.3671497666355694, 19.523487222941558, 0.025304565610688532, 9407.062036252935, 46.98


def _truth() -> EquationOfMotion:
    w = 2.0 * math.pi * F_HZ
    return EquationOfMotion.create(mass=MASS, damping={"v": 2.0 * ZETA * MASS * w}, stiffness={"x": MASS * w * w})


@pytest.fixture(scope="module")
def fitted():
    eom = _truth()
    w = 2.0 * math.pi * F_HZ
    n = int(round(min(40.0 / F_HZ, 60000 / RATE, max(40.0 / F_HZ, 7.0 / (ZETA * w))) * RATE))
    res = simulate(eom, rate_hz=RATE, n_samples=n, x0=0.1 / w, v0=0.0, substeps=None)
    sigma = active_rms(res.v) * 10.0 ** (-SNR / 20.0)
    vel = res.v + sigma * np.random.default_rng(1018).standard_normal(n)
    pipe = Pipeline(damping=("v",), stiffness=("x",))
    return eom, pipe.fit(pipe.condition(res.t, vel=vel), MASS)


def test_the_refinement_is_kept_on_a_free_velocity_decay(fitted):
    # before: rejected ("raised the velocity (measured) nrmse ... +23.8 noise sd") with both models
    # started from the first sample's integrated x and measured v
    _, res = fitted
    assert res.choices.refinement == "kept", res.choices.refinement_reason


def test_its_intervals_hold_the_truth_and_are_the_output_error_ones(fitted):
    eom, res = fitted
    for group in ("damping", "stiffness"):
        for term, c in getattr(eom, group).items():
            got, half = getattr(res.model.eom, group)[term], res.ci95[group][term]
            assert abs(got - c) <= half, (term, got, c, half)
    # EDDI's estimate came back before, x 6.8e-5 off with an interval of 8.0e-5 (relative)
    assert res.ci95["stiffness"]["x"] / eom.stiffness["x"] < 2.5e-5
