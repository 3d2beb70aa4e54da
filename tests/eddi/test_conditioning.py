"""Conditioning: drift-free integration, impact end, noise floor, velocity-only input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as sps

from eddi import EquationOfMotion, simulate
from eddi.conditioning import (
    anchor_residual, clipped_run, condition, crossings, integrate_about_equilibrium,
    integrate_highpass, spline_cumulative_integral,
)
from eddi.errors import SignalError
from tests.conftest import REPO
from tests.eddi.impact_cases import half_sine_pulse, impact_record, ringdown_rms


def _rel(a: np.ndarray, b: np.ndarray, w: tuple[int, int]) -> float:
    s, e = w
    return float(np.linalg.norm(a[s:e] - b[s:e]) / np.linalg.norm(b[s:e]))


def test_noise_free_acc_integrates_to_exact_x_and_v() -> None:
    r = impact_record("paper_do", snr_db=None)
    c = condition(r.t, acc=r.acc, force=r.force)
    assert _rel(c.x, r.x, c.window) < 1e-3
    assert _rel(c.v, r.v, c.window) < 1e-3
    # the motion starts from rest: nothing before the impact
    assert np.all(c.x[: c.impact_start] == 0.0)


@pytest.mark.parametrize("system", ["paper_do", "heavy_asym", "nl_damping"])
def test_45db_beats_the_papers_highpass_by_a_wide_margin(system: str) -> None:
    r = impact_record(system, snr_db=45.0, seed=5)
    c = condition(r.t, acc=r.acc, force=r.force)
    x_hp, v_hp = integrate_highpass(r.t, r.acc, cutoff_hz=2.0)  # paper Sec. 3.3.1: 3rd order, 2 Hz
    ours, theirs = _rel(c.x, r.x, c.window), _rel(x_hp, r.x, c.window)
    assert ours < 0.01
    assert ours < theirs / 4
    assert _rel(c.v, r.v, c.window) < 0.005


def test_impact_end_and_noise_floor_window() -> None:
    r = impact_record("light_stiff", snr_db=45.0, seed=2)
    c = condition(r.t, acc=r.acc, force=r.force)
    pulse = np.nonzero(r.force > 0.5 * r.force.max())[0]
    pulse_end = r.pretrigger_samples + 10  # 1 ms at 10 kHz
    assert pulse_end <= c.free_start <= pulse_end + 5
    assert c.impact_start <= pulse[0]
    # the window stops where the true acceleration envelope is about 10 noise RMS
    period = int(1e4 / 20.0)
    env_at_stop = np.max(np.abs(r.a[c.free_stop - period: c.free_stop]))
    assert 5 * c.noise_rms < env_at_stop < 20 * c.noise_rms
    assert c.free_stop < r.t.size  # this record sinks into the noise before its end


def test_impact_force_is_zero_outside_the_impact() -> None:
    r = impact_record("paper_do", snr_db=45.0, seed=1)
    c = condition(r.t, acc=r.acc, force=r.force)
    f = c.impact_force
    assert np.all(f[: c.impact_start] == 0) and np.all(f[c.impact_end:] == 0)
    impulse_true = np.sum(half_sine_pulse(r.t, 1.0, 1e-3, 200.0))
    assert abs(np.sum(f) / impulse_true - 1) < 0.01


def test_velocity_only_ringdown_without_pretrigger() -> None:
    # a laser-vibrometer ring-down that starts mid-oscillation: no rest, no force
    r = impact_record("paper_do", snr_db=None)
    start = r.pretrigger_samples + 1234
    t, v, x, a = r.t[start:], r.v[start:], r.x[start:], r.a[start:]
    rng = np.random.default_rng(0)
    v_meas = v + 10 ** (-50 / 20) * np.std(v) * rng.standard_normal(v.size)
    c = condition(t, vel=v_meas)
    assert c.impact_start == 0
    np.testing.assert_array_equal(c.v, v_meas)  # given vel is used as it is
    assert _rel(c.x, x, c.window) < 0.01
    assert _rel(c.a, a, c.window) < 0.03


def test_given_disp_and_vel_are_used_as_they_are() -> None:
    r = impact_record("paper_do", snr_db=None)
    c = condition(r.t, disp=r.x, vel=r.v, force=r.force)
    np.testing.assert_array_equal(c.x, r.x)
    np.testing.assert_array_equal(c.v, r.v)
    assert _rel(c.a, r.a, c.window) < 0.01


def test_ac_coupling_is_inverted() -> None:
    r = impact_record("heavy_asym", snr_db=None)
    fc = 0.5
    b, a = sps.butter(1, fc, btype="highpass", fs=1e4)  # IEPE coupling, bilinear
    acc_ac = sps.lfilter(b, a, r.acc)
    plain = condition(r.t, acc=acc_ac, force=r.force)
    fixed = condition(r.t, acc=acc_ac, force=r.force, ac_coupling_s=1 / (2 * np.pi * fc))
    assert _rel(fixed.v, r.v, fixed.window) < 0.002
    assert _rel(plain.v, r.v, plain.window) > 5 * _rel(fixed.v, r.v, fixed.window)


def test_crossings_with_hysteresis_ignore_noise_chatter() -> None:
    t = np.arange(10_000) / 1e4
    y = np.sin(2 * np.pi * 5 * t) + 0.01 * np.random.default_rng(1).standard_normal(t.size)
    c = crossings(y, 0.05)
    assert c.size == 9  # 5 Hz over 1 s: zeros at k/10 s, k = 1..9
    np.testing.assert_allclose(c / 1e4, np.arange(1, 10) / 10, atol=1e-3)


def test_clipped_run() -> None:
    y = np.sin(np.linspace(0, 20, 2000))
    assert clipped_run(y) is None
    yc = np.clip(y, -0.9, 0.9)
    assert clipped_run(yc) is not None


@pytest.mark.parametrize("bits", [6, 8, 10])
def test_a_coarse_converter_at_a_slow_peak_is_not_clipped(bits: int) -> None:
    # blind unseen9 (session 13): an 8-bit displacement channel at 1 kHz sat 7 samples on its
    # last count at a 7 Hz peak and the record was refused as clipped; the same channel driven
    # 1.3x past the converter's limit still is
    t = np.arange(4000) / 1024.0
    y = np.exp(-0.3 * t) * np.sin(2 * np.pi * 3 * t)
    q = 2.0 / 2**bits
    quantised = np.round(y / q) * q
    assert np.max(np.bincount(np.unique(quantised, return_inverse=True)[1])) >= 5  # it does sit flat
    assert clipped_run(quantised) is None
    at = clipped_run(np.clip(np.round(1.3 * y / q) * q, -1.0, 1.0))
    assert at is not None and 45 <= at <= 52  # the first peak, 12 ms after the start
    # with noise of 3 counts the flanks are no parabola within a count: a limit is a limit
    noisy = y + 3 * q * np.random.default_rng(2).standard_normal(t.size)
    assert clipped_run(np.clip(np.round(noisy / q) * q, -0.8, 0.8)) is not None


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(t=np.arange(100) * 1e-4 + np.r_[np.zeros(50), 3e-5, np.zeros(49)]), "uniform"),
        (dict(t=np.r_[np.arange(50), np.arange(49, -1, -1)] * 1e-4), "increase"),
        (dict(acc=np.r_[np.nan, np.zeros(99)]), "NaN"),
        (dict(acc=None), "at least one of acc, vel, disp"),
        (dict(acc=np.random.default_rng(0).standard_normal(100) * 1e-6 + 1.0), "zero crossings"),
    ],
)
def test_bad_signals_raise_signal_error(kwargs: dict, match: str) -> None:
    args = dict(t=np.arange(100) * 1e-4, acc=np.sin(np.arange(100) * 0.3))
    args.update(kwargs)
    t = args.pop("t")
    with pytest.raises(SignalError, match=match):
        condition(t, **args)


# ----------------------------------------------------------------------------------------
# ring-downs recorded already in motion (no rest, no force)
# ----------------------------------------------------------------------------------------
def _sdof(f_hz: float, zeta: float, k3: float = 0.0) -> EquationOfMotion:
    k = (2 * np.pi * f_hz) ** 2
    stiffness = {"x": k, "x^3": k3} if k3 else {"x": k}
    return EquationOfMotion.create(mass=1.0, damping={"v": 2 * zeta * np.sqrt(k)}, stiffness=stiffness)


def _in_motion(modes: list[tuple[EquationOfMotion, float, float]], rate_hz: float,
               duration_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Sum of free responses of SDOF systems from their initial states ``(eom, x0, v0)``."""
    t = np.arange(int(round(rate_hz * duration_s))) / rate_hz
    x, v, a = np.zeros(t.size), np.zeros(t.size), np.zeros(t.size)
    for eom, x0, v0 in modes:
        sim = simulate(eom, t, x0=x0, v0=v0)
        x += sim.x
        v += sim.v
        a += sim.a
    return t, x, v, a


def _noisy(y: np.ndarray, snr_db: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return y + 10 ** (-snr_db / 20) * ringdown_rms(y, 0) * rng.standard_normal(y.size)


def _nrmse(est: np.ndarray, true: np.ndarray) -> float:
    return float(np.linalg.norm(est - true) / np.linalg.norm(true))


# two modes close to the double beam's (README of resonant-double-beam: 122.4 and 243.4 Hz,
# 5120 Hz, ~3 s), and two at a non-harmonic ratio of 1.5
TWO_MODES = {
    "beam": ([(_sdof(122.4, 0.002), 1e-3, 0.3), (_sdof(243.4, 0.003), -2e-4, 0.8)], 5120.0, 3.07),
    "ratio_1.5": ([(_sdof(100.0, 0.005), 0.0, 0.6), (_sdof(150.0, 0.005), 1e-3, 0.0)], 5000.0, 2.0),
}
ONE_MODE = {
    "linear_50hz": ([(_sdof(50.0, 0.01), 2e-3, 0.5)], 2000.0, 3.0),
    # hardening: the frequency falls from ~30 to ~20 Hz as it rings down
    "duffing_20hz": ([(EquationOfMotion.create(mass=0.05, damping={"v": 0.15},
                                               stiffness={"x": 800.0, "x^3": 2.0e8}), 3e-3, 0.0)],
                     1e4, 4.0),
}


@pytest.mark.parametrize("case", sorted(TWO_MODES) + sorted(ONE_MODE))
def test_velocity_only_record_in_motion_gives_x_and_a(case: str) -> None:
    t, x, v, a = _in_motion(*{**TWO_MODES, **ONE_MODE}[case])
    exact = condition(t, vel=v)
    assert _nrmse(exact.x, x) < 2e-3
    assert _nrmse(exact.a, a) < 1e-2
    c = condition(t, vel=_noisy(v, 50.0, seed=3))
    assert c.impact_start == 0 and c.free_start == 0
    assert _nrmse(c.x, x) < 0.01
    assert _nrmse(c.a, a) < 0.04  # noise on v, differentiated (SNR 50 dB)
    # no drift: the mean of x over the last 0.5 s (where the one-mode records have sunk
    # into the noise) is a small fraction of the amplitude
    tail = slice(-int(0.5 / (t[1] - t[0])), None)
    assert abs(np.mean(c.x[tail])) < 1e-3 * np.max(np.abs(x))


@pytest.mark.parametrize("case", sorted(TWO_MODES) + sorted(ONE_MODE))
def test_acceleration_only_record_in_motion_gives_x_and_v(case: str) -> None:
    t, x, v, a = _in_motion(*{**TWO_MODES, **ONE_MODE}[case])
    c = condition(t, acc=_noisy(a, 50.0, seed=4))
    assert _nrmse(c.x, x) < 0.01
    assert _nrmse(c.v, v) < 0.005


def test_two_modes_are_integrated_about_the_equilibrium_one_mode_is_anchored() -> None:
    t, x, v, a = _in_motion(*TWO_MODES["beam"])
    assert anchor_residual(x, v, a) > 0.3  # a = 0 says nothing about x with two modes
    assert "about the equilibrium (zero mean" in condition(t, vel=v).method
    eq = integrate_about_equilibrium(t, vel=v)
    assert eq.modes_hz[0] == pytest.approx(122.4, rel=2e-3)
    t, x, v, a = _in_motion(*ONE_MODE["duffing_20hz"])
    assert anchor_residual(x, v, a) < 0.05
    assert "anchored" in condition(t, vel=v).method
    # the lowest-mode frequency is tracked as the hardening system slows down
    eq = integrate_about_equilibrium(t, vel=v)
    assert eq.f1_hz[0] > 1.3 * eq.f1_hz[-1]


def test_spline_integral_keeps_the_amplitude_the_trapezoid_rule_shrinks() -> None:
    from scipy.integrate import cumulative_trapezoid

    rate, f = 5120.0, 243.4  # 21 samples a period
    t = np.arange(5120) / rate
    y = np.cos(2 * np.pi * f * t)
    exact = np.sin(2 * np.pi * f * t) / (2 * np.pi * f)
    assert _nrmse(spline_cumulative_integral(t, y), exact) < 1e-4
    assert _nrmse(cumulative_trapezoid(y, t, initial=0.0), exact) > 5e-3  # (w h)^2 / 12


@pytest.mark.parametrize("name", ["ringdown-01.csv", "ringdown-05.csv"])
def test_measured_double_beam_displacement_has_no_drift(name: str) -> None:
    raw = np.loadtxt(REPO / "tests" / "data" / "resonant-double-beam" / name, delimiter=",", skiprows=1)
    c = condition(raw[:, 0], vel=raw[:, 1])
    assert "about the equilibrium (zero mean" in c.method
    half = int(0.5 * c.rate_hz)
    for part in (slice(None, half), slice(-half, None)):
        # mean over 0.5 s within 0.5 % of the amplitude there (measured 0.00-0.28 %); the
        # plain integral of the published velocity drifts by several amplitudes
        assert abs(np.mean(c.x[part])) < 5e-3 * np.max(np.abs(c.x[part]))
    plain = spline_cumulative_integral(c.t, raw[:, 1])
    assert abs(np.mean(plain[-half:] - plain[:half])) > 1.0 * np.max(np.abs(c.x[-half:]))


def test_drift_spline_evaluated_piecewise_equals_the_bspline() -> None:
    """The drift spline's Horner evaluation per knot interval equals scipy's B-spline (value and
    slope) on a long uniform record, knots off the sample grid, clamped ends; 0 before ``start``."""
    from scipy.interpolate import BSpline

    from eddi.conditioning.kinematics import _drift_spline_eval

    t = np.arange(200_003) / 19200.0
    start = 1234
    inner = np.linspace(t[start], t[-1], 38)
    knots = np.concatenate(([t[start]] * 3, inner, [t[-1]] * 3))
    spl = BSpline(knots, np.random.default_rng(3).normal(size=knots.size - 4), 3, extrapolate=False)
    d, dd = _drift_spline_eval(spl, t, start)
    np.testing.assert_allclose(d[start:], spl(t[start:]), rtol=0, atol=1e-13)
    np.testing.assert_allclose(dd[start:], spl.derivative()(t[start:]), rtol=0, atol=1e-11)
    assert not d[:start].any() and not dd[:start].any()


def _crossings_by_index_list(y, hysteresis, start=0):
    """The former form of eddi.conditioning.levels.crossings (every beyond-threshold index listed)."""
    seg = np.asarray(y[start:], float)
    nz = np.flatnonzero((seg > hysteresis) | (seg < -hysteresis))
    if seg.size < 3 or nz.size < 2:
        return np.zeros(0)
    s = seg[nz] > hysteresis
    flips = nz[1:][s[1:] != s[:-1]]
    neg = np.signbit(seg)
    sign_change = np.flatnonzero(neg[:-1] != neg[1:])
    if flips.size == 0 or sign_change.size == 0:
        return np.zeros(0)
    pos = np.searchsorted(sign_change, flips, side="left") - 1
    i = sign_change[pos[pos >= 0]]
    y0, y1 = seg[i], seg[i + 1]
    return start + i + np.clip(np.where(y1 != y0, y0 / (y0 - y1), 0.5), 0.0, 1.0)


@pytest.mark.parametrize("block", [8, 64, 1 << 16])
def test_crossings_are_the_index_lists_without_listing_every_sample(block, monkeypatch) -> None:
    """The same crossings as listing every beyond-threshold sample (random walks with noise, any
    block size), and on a long ring-down no index array of most of its samples (session 12: their
    page faults were half the call)."""
    import eddi.conditioning.levels as levels

    monkeypatch.setattr(levels, "CROSSING_BLOCK", block)
    rng = np.random.default_rng(block)
    for _ in range(200):
        n = int(rng.integers(3, 3000))
        y = np.cumsum(rng.standard_normal(n)) * rng.uniform(0.1, 3.0) + rng.standard_normal(n)
        h, start = float(rng.uniform(0.0, 2.0)), int(rng.integers(0, 3))
        want = _crossings_by_index_list(y, h, start)
        assert np.array_equal(levels.crossings(y, h, start=start), want)  # the compiled scan
        strided = np.repeat(y, 2)[::2]  # not contiguous: the numpy passes (session 16 kept them)
        assert np.array_equal(levels.crossings(strided, h, start=start), want)
    t = np.arange(400_000) / 19_200.0
    ring = np.exp(-0.1 * t) * np.sin(2 * np.pi * 15.0 * t) + 1e-3 * rng.standard_normal(t.size)
    sizes = []
    real = np.flatnonzero

    def listed(a):
        out = real(a)
        sizes.append(out.size)
        return out

    monkeypatch.setattr(np, "flatnonzero", listed)
    got = levels.crossings(ring, 3e-3)
    assert not sizes  # the compiled scan lists nothing
    got_np = levels.crossings(np.repeat(ring, 2)[::2], 3e-3)
    monkeypatch.setattr(np, "flatnonzero", real)
    want = _crossings_by_index_list(ring, 3e-3)
    assert np.array_equal(got, want) and np.array_equal(got_np, want) and got.size > 600
    assert max(sizes) <= max(block, 0.1 * t.size)


def test_crossing_between_plus_and_minus_zero_is_halfway_without_a_warning():
    """+0.0 then -0.0 differ in sign bit, not in value: the crossing is halfway and no 0/0 is
    formed (its RuntimeWarning reached a user's stderr on clean CSV records, blind unseen11 X2)."""
    import warnings

    from eddi.conditioning.levels import crossings

    y = np.array([1.0, 2.0, 0.0, -0.0, -1.0, -2.0, -1.0, 0.0, 1.0, 2.0, 1.0, 0.0, -1.0, -2.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        c = crossings(y, 0.5)
    np.testing.assert_array_equal(c, [2.5, 7.0, 11.0])
