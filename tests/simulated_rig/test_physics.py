"""Physics of the simulated rig checked against closed-form values."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal as sps

from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test
from simulated_rig.errors import ScenarioError
from simulated_rig.hammer import TIP_PULSE_WIDTH_S, HammerSpec, hammer_force, pulse_impulse
from simulated_rig.sensors import accelerometer, active_rms, force_sensor
from simulated_rig.systems import SYSTEMS, get_system, system_info

M, C, K = 0.5, 0.4, 2000.0  # a linear oscillator: f_n = 10.07 Hz, zeta = 0.00632
LINEAR = EquationOfMotion.create(mass=M, damping={"v": C}, stiffness={"x": K})


def _zero_crossing_period(t: np.ndarray, x: np.ndarray) -> float:
    s = np.signbit(x)
    idx = np.nonzero(s[1:] & ~s[:-1])[0]  # + to - crossings
    tc = t[idx] + (t[idx + 1] - t[idx]) * x[idx] / (x[idx] - x[idx + 1])
    return float(np.mean(np.diff(tc)))


def test_linear_impulse_response_frequency_and_decay_match_m_c_k() -> None:
    rec = impact_test(LINEAR, 50.0, rate_hz=5000.0, pretrigger_s=0.1, record_s=4.0,
                      snr_db=None, hammer=HammerSpec(tip="steel"))
    after = rec.t > 0.01
    t, x = rec.t[after], rec.truth_x[after]
    wn = math.sqrt(K / M)
    zeta = C / (2 * math.sqrt(K * M))
    wd = wn * math.sqrt(1 - zeta**2)
    assert _zero_crossing_period(t, x) == pytest.approx(2 * math.pi / wd, rel=1e-4)
    # decay: log envelope of the analytic signal falls at zeta * wn
    env = np.abs(sps.hilbert(x))
    sl = slice(len(t) // 10, len(t) * 9 // 10)
    slope = np.polyfit(t[sl], np.log(env[sl]), 1)[0]
    assert -slope == pytest.approx(zeta * wn, rel=0.02)
    # amplitude: a short pulse gives v0 = impulse / m, x_peak ~ v0 / wd
    v0 = pulse_impulse(50.0, TIP_PULSE_WIDTH_S["steel"]) / M
    assert np.max(np.abs(rec.truth_v)) == pytest.approx(v0, rel=0.01)


def test_truth_acceleration_satisfies_the_equation_of_motion() -> None:
    rec = impact_test("duffing-smooth", 600.0, record_s=2.0, pretrigger_s=0.05, snr_db=None)
    lhs = rec.eom.mass * rec.truth_a + rec.eom.restoring_force(rec.truth_x, rec.truth_v)
    np.testing.assert_allclose(lhs, rec.truth_force_n, atol=1e-9 * 600.0)


@pytest.mark.parametrize("tip", sorted(TIP_PULSE_WIDTH_S))
def test_hammer_pulse_integral_equals_impulse(tip: str) -> None:
    hammer = HammerSpec(tip=tip)
    rate = 1.0e6
    t = np.arange(-100, 20000) / rate
    f = hammer_force(t, 300.0, hammer)
    assert np.trapezoid(f, t) == pytest.approx(2 * 300.0 * hammer.width_s / math.pi, rel=1e-5)
    assert f.max() == pytest.approx(300.0, rel=1e-4)
    assert np.all(f[t < 0] == 0) and np.all(f[t > hammer.width_s] == 0)


def test_double_hit_adds_a_second_smaller_pulse() -> None:
    hammer = HammerSpec(tip="plastic", double_hit_delay_s=5e-3, double_hit_ratio=0.25)
    t = np.arange(0, 20000) / 1.0e6
    f = hammer_force(t, 400.0, hammer, double_hit=True)
    second = f[t >= 5e-3]
    assert second.max() == pytest.approx(100.0, rel=1e-4)
    assert np.trapezoid(f, t) == pytest.approx(1.25 * pulse_impulse(400.0, 1e-3), rel=1e-4)
    rec = impact_test(LINEAR, 50.0, rate_hz=19200.0, pretrigger_s=0.01, record_s=0.1,
                      snr_db=None, hammer=hammer, double_hit=True)
    assert rec.truth_force_n[rec.t >= 5e-3].max() > 12.0


def test_unknown_tip_is_refused_with_the_known_ones() -> None:
    with pytest.raises(ScenarioError, match="known: steel, plastic, rubber"):
        HammerSpec(tip="wood")


def test_measured_snr_equals_requested() -> None:
    rec = impact_test("duffing-smooth", 600.0, record_s=20.0, snr_db=40.0, force_snr_db=30.0, seed=3)
    n0 = rec.pretrigger_samples
    for measured, truth, wanted in ((rec.acc_m_s2, rec.truth_a, 40.0),
                                    (rec.force_n, rec.truth_force_n, 30.0)):
        noise = measured - truth
        snr = 20 * math.log10(active_rms(truth[n0:]) / np.std(noise))
        assert snr == pytest.approx(wanted, abs=0.5)


def test_noise_free_record_is_exact_to_quantisation_and_step_is_range_over_2_pow_bits() -> None:
    for bits in (16, 24):
        rec = impact_test("duffing-smooth", 246.0, record_s=3.0, snr_db=None, adc_bits=bits)
        for ch, measured, truth in zip(rec.channels, (rec.force_n, rec.acc_m_s2),
                                       (rec.truth_force_n, rec.truth_a)):
            assert ch.adc_bits == bits
            assert ch.scale == pytest.approx(ch.range_si / 2 ** (bits - 1), rel=1e-15)
            assert np.max(np.abs(measured - truth)) <= 0.5 * ch.scale * (1 + 1e-9)
            # automatic range: 1.5 x the peak of the noise-free signal
            assert ch.range_si == pytest.approx(1.5 * np.max(np.abs(truth)), rel=1e-12)
            k = measured / ch.scale
            np.testing.assert_allclose(k, np.rint(k), atol=1e-6)
        assert rec.clipped == ()


def test_values_beyond_range_clip_to_adc_limits_and_record_says_so() -> None:
    sensors = (force_sensor(), accelerometer(range_si=100.0, adc_bits=16))
    rec = impact_test("duffing-smooth", 600.0, record_s=2.0, sensors=sensors, seed=1)
    assert rec.clipped == ("acc",)
    acc = rec.channel("acc")
    assert rec.counts[:, 1].max() == acc.max_count == 32767
    assert acc.min_count == -32768 and rec.counts[:, 1].min() >= acc.min_count
    assert np.sum(rec.counts[:, 1] == acc.max_count) > 10
    assert np.max(np.abs(rec.acc_m_s2)) <= 100.0


def test_iepe_coupling_is_a_first_order_highpass() -> None:
    # a step of acceleration seen through a 0.5 Hz AC coupling decays as exp(-2 pi 0.5 t)
    sensors = (force_sensor(noise_rms_si=0.0), accelerometer(snr_db=None, iepe_highpass_hz=0.5))
    rec = impact_test(LINEAR, 50.0, rate_hz=2000.0, pretrigger_s=0.1, record_s=5.0,
                      sensors=sensors, hammer=HammerSpec(tip="steel"))
    b, a = sps.butter(1, 0.5, btype="highpass", fs=2000.0)
    np.testing.assert_allclose(rec.acc_m_s2, sps.lfilter(b, a, rec.truth_a),
                               atol=rec.channel("acc").scale)
    # the coupling removes a constant: its gain at DC is 0 and ~1 at the 10 Hz mode
    w, h = sps.freqz(b, a, worN=[0.0, 10.07], fs=2000.0)
    assert abs(h[0]) < 1e-12 and abs(h[1]) == pytest.approx(1.0, abs=2e-3)


def test_time_base_starts_at_minus_pretrigger_and_pulse_at_zero() -> None:
    rec = impact_test(LINEAR, 10.0, rate_hz=1000.0, pretrigger_s=0.25, record_s=0.5, snr_db=None)
    assert rec.pretrigger_samples == 250
    assert rec.t[0] == pytest.approx(-0.25) and rec.t[250] == 0.0
    assert rec.n_samples == 750
    # the sample at t=0 averages the pulse over [-dt/2, dt/2] (see hammer.half_sine)
    assert np.all(rec.truth_force_n[:250] == 0) and rec.truth_force_n[250] > 0
    assert np.all(rec.truth_x[:250] == 0) and rec.truth_x[250] > 0


def test_same_seed_same_record_other_seed_other_noise() -> None:
    a = impact_test("duffing-struts", 11.0, record_s=0.5, seed=5)
    b = impact_test("duffing-struts", 11.0, record_s=0.5, seed=5)
    c = impact_test("duffing-struts", 11.0, record_s=0.5, seed=6)
    assert np.array_equal(a.counts, b.counts)
    assert not np.array_equal(a.counts, c.counts)


def test_systems_by_name_carry_the_paper_values() -> None:
    assert set(SYSTEMS) == {"paper-duffing", "paper-pendulum", "duffing-smooth", "duffing-struts"}
    smooth = get_system("duffing-smooth")  # paper Sec. 3.3.1, Eqs. 21-22
    assert smooth.mass == 0.815
    assert smooth.damping == {"v": 0.196, "x^2*v": -20441.0, "v^3": 9.96}
    assert smooth.stiffness["x^5"] == 6.2e10
    struts = get_system("duffing-struts")  # paper Sec. 3.3.2, Eqs. 24-25
    assert struts.mass == 0.088 and struts.stiffness["x^3"] == -4.4e7
    assert struts.effect("clearance") is not None
    pend = get_system("paper-pendulum")  # paper Table 4: mgl = 15.696
    assert pend.stiffness["x"] == pytest.approx(15.696)
    assert pend.stiffness["x^3"] == pytest.approx(-2.616)
    theta = np.linspace(-math.pi / 2, math.pi / 2, 101)
    taylor = pend.restoring_force(theta, np.zeros_like(theta))
    np.testing.assert_allclose(taylor, 15.696 * np.sin(theta), atol=1e-4)


def test_unknown_system_lists_known_names() -> None:
    with pytest.raises(ScenarioError, match="known: paper-duffing, paper-pendulum"):
        get_system("duffing-rough")


@pytest.mark.parametrize("name", ["duffing-smooth", "duffing-struts", "paper-duffing"])
def test_demo_force_levels_are_stable_and_decay(name: str) -> None:
    info = system_info(name)
    top = info.demo_forces_n[-1] * 2.5  # headroom beyond the highest demo level
    rec = impact_test(name, top, snr_db=None, pretrigger_s=0.0)
    x = rec.truth_x
    assert np.all(np.isfinite(x))
    tenth = len(x) // 10
    assert np.max(np.abs(x[-tenth:])) < 0.2 * np.max(np.abs(x[:tenth]))


def test_duffing_smooth_demo_levels_are_strongly_nonlinear() -> None:
    # the ring-down frequency at the start of the 1110 N blow (paper Fig. 12b) is well above
    # the linear 3.48 Hz of k1 = 390 N/m, m = 0.815 kg (paper Sec. 3.3.1)
    rec = impact_test("duffing-smooth", 1110.0, record_s=3.0, pretrigger_s=0.0, snr_db=None)
    f_lin = math.sqrt(390.0 / 0.815) / (2 * math.pi)
    first = rec.t < 0.6
    f_start = 1 / _zero_crossing_period(rec.t[first], rec.truth_x[first])
    assert f_start > 2.0 * f_lin
