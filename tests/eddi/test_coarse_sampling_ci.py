"""95 % intervals of point-sampled records at ~25 samples per cycle hold the truth as at 6x the rate.

A lab reported true coefficients outside ``ci95`` on coarse (25-40 samples a cycle), point-sampled
records. Session 10 (``benchmarks/bench_ci_coverage_cli.py --set coarse-tune --rate-factor 1|6``)
found no coarse-sampling loss of coverage: the fit's RK4 error, the rig's, the sampling-kernel term
(zero for point samples compared sample by sample) and EDDI's own sampling error (bounded by the
output-error fit) each stay inside the intervals. This guards it: the same system and seeds at 25
and 150 samples a cycle, every coefficient's ``z = (c - c_true) / (ci95 / 1.96)``. Intervals that
missed a coarse-sampling error (a bias of one half width, or intervals 1.5x too narrow) fail it.
"""

from __future__ import annotations

import math

import numpy as np

from eddi.fit_record import Pipeline
from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test
from simulated_rig.hammer import HammerSpec
from simulated_rig.sensors import accelerometer, force_sensor

F_HZ, MASS, ZETA, VP = 80.0, 1.0, 0.005, 0.15
SEEDS = range(6)


def _truth() -> EquationOfMotion:
    w = 2 * math.pi * F_HZ
    k1, b1 = MASS * w * w, 2 * ZETA * MASS * w
    xp = VP / w
    return EquationOfMotion.create(mass=MASS, damping={"v": b1, "v^3": 0.3 * b1 / VP**2},
                                   stiffness={"x": k1, "x^3": 0.3 * k1 / xp**2})


def z_scores(rate_hz: float) -> np.ndarray:
    """``z`` of every coefficient of every seed (rows: seeds), 55 dB white noise, point samples."""
    eom = _truth()
    hammer = HammerSpec(tip="plastic")
    pipe = Pipeline(damping=("v", "v^3"), stiffness=("x", "x^3"))
    out = []
    for seed in SEEDS:
        rec = impact_test(eom, MASS * VP * math.pi / (2 * hammer.width_s), rate_hz=rate_hz, pretrigger_s=0.3,
                          record_s=5.0, sensors=(force_sensor(), accelerometer(snr_db=55.0)), hammer=hammer,
                          seed=seed)
        res = pipe.fit(pipe.condition(rec.t, acc=rec.acc_m_s2, force=rec.force_n), MASS)
        assert res.choices.refinement == "kept"
        got = res.model.eom
        out.append([(getattr(got, g)[t] - c) / (res.ci95[g][t] / 1.959964)
                    for g in ("damping", "stiffness") for t, c in getattr(eom, g).items()])
    return np.array(out)


def test_coarse_point_samples_cover_as_dense_ones() -> None:
    coarse = z_scores(25.0 * F_HZ)
    dense = z_scores(150.0 * F_HZ)
    for z in (coarse, dense):
        assert np.all(np.isfinite(z))
        assert int(np.sum(np.abs(z) > 1.959964)) <= 2, z  # 24 coefficients: 1.2 expected outside
        assert math.sqrt(float(np.mean(z**2))) < 1.35, z  # intervals not too narrow
        assert np.all(np.abs(z.mean(axis=0)) < 1.2), z  # no per-coefficient bias of ~ a half width
    # the coarse intervals are wider by ~sqrt(6) (fewer samples), not narrower than the scatter
    assert math.sqrt(float(np.mean(coarse**2))) < 1.3 * max(1.0, math.sqrt(float(np.mean(dense**2))))


def test_an_analog_antialias_filter_moves_the_cubic_term_as_the_warning_says() -> None:
    """A 1-pole analog filter at rate / 2.56 before point sampling (not modelled): at 25 samples a
    cycle it moves ``x^3`` by ~1 % (tens of intervals); the one warning about the intervals says so
    (session 10: before, it named only a decimator the DAQ need not have)."""
    from scipy import signal

    from eddi.intervals import analog_droop_bias

    eom = _truth()
    hammer = HammerSpec(tip="plastic")
    rate = 25.0 * F_HZ
    rec = impact_test(eom, MASS * VP * math.pi / (2 * hammer.width_s), rate_hz=rate, pretrigger_s=0.3,
                      record_s=5.0, sensors=(force_sensor(), accelerometer(snr_db=55.0)), hammer=hammer, seed=1)
    b, a = signal.bilinear(*signal.butter(1, 2 * math.pi * rate / 2.56, analog=True), rate)
    pipe = Pipeline(damping=("v", "v^3"), stiffness=("x", "x^3"))
    # the DAQ point-samples the filtered signal, and says so (no margin for interval means, session 12)
    res = pipe.fit(pipe.condition(rec.t, acc=signal.lfilter(b, a, rec.acc_m_s2), force=rec.force_n,
                                  adc_sinc_order=0), MASS)
    shift = res.model.eom.stiffness["x^3"] / eom.stiffness["x^3"] - 1.0
    assert abs(shift) > 10 * res.ci95["stiffness"]["x^3"] / eom.stiffness["x^3"]  # far outside its interval
    predicted = analog_droop_bias("x^3", F_HZ / rate)  # at the linear frequency (the response's is ~5 % higher)
    assert 0.6 * predicted < shift < 1.4 * predicted, (shift, predicted)
    assert any("analog" in w and "1-pole" in w for w in res.warnings), res.warnings
