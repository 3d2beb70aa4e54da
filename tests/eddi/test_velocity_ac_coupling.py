"""A velocity sensor's declared AC coupling is inverted, as an accelerometer's is (session 14).

Before, ``ac_coupling_s`` (``--sensor-highpass``, a capture's metadata) was applied to ``acc``
only: on a record measured by force + velocity it was silently left in, and the coupling's phase
lead biased the cubic stiffness by several standard errors while its interval did not know.
The system is draw 3 of ``benchmarks/bench_ci_coverage_coarse.py --family sensor`` with the
draw seed 11 (0.17 kg, 14.0 Hz, hardening), the sensor's corner at 3 % of its frequency.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddi.fit_record import Pipeline
from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test
from simulated_rig.hammer import HammerSpec
from simulated_rig.sensors import accelerometer, active_rms, ac_couple, force_sensor

MASS, F_HZ, RATE, WIDTH, SNR = 0.16762171653134028, 13.983270108236656, 4052.0635891498746, 0.01025723241941957, 48.0
EOM = EquationOfMotion.create(mass=MASS, damping={"v": 0.7333293762446784},
                              stiffness={"x": 1293.9202630110376, "x^3": 285338093.33297205})
CORNER_HZ = 0.03 * F_HZ


def _record(seed: int):
    hammer = HammerSpec(pulse_width_s=WIDTH, double_hit_delay_s=2.0 * WIDTH)
    r = impact_test(EOM, MASS * 0.1 * math.pi / (2.0 * WIDTH), rate_hz=RATE, pretrigger_s=0.1, record_s=3.2,
                    sensors=(force_sensor(), accelerometer(snr_db=SNR)), hammer=hammer, seed=seed)
    coupled = ac_couple(r.truth_v, CORNER_HZ, RATE)
    sigma = active_rms(coupled[r.pretrigger_samples:]) * 10.0 ** (-SNR / 20.0)
    return r.t, r.force_n, coupled + sigma * np.random.default_rng(seed + 7919).standard_normal(r.t.size)


@pytest.fixture(scope="module")
def fitted():
    t, force, vel = _record(9003)
    pipe = Pipeline(damping=tuple(EOM.damping), stiffness=tuple(EOM.stiffness))
    cond = pipe.condition(t, vel=vel, force=force, ac_coupling_s=1.0 / (2.0 * math.pi * CORNER_HZ))
    return pipe.fit(cond, MASS)


def _z(res, group: str, term: str) -> float:
    return (getattr(res.model.eom, group)[term] - getattr(EOM, group)[term]) / (res.ci95[group][term] / 1.959964)


def test_the_coupling_of_a_velocity_record_is_inverted(fitted):
    assert any("AC coupling" in n and "vel" in n for n in fitted.conditioned.notes)


def test_the_coefficients_lie_within_their_intervals(fitted):
    # before (the coupling left in): x^3 z +2.7 here, +3.8 to +4.7 on noise seeds 1-3; inverted -1.3, -0.5 to 1.3
    for group in ("damping", "stiffness"):
        for term in getattr(EOM, group):
            assert abs(_z(fitted, group, term)) <= 1.96, (term, _z(fitted, group, term))
