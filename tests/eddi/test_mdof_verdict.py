"""The multi-channel verdict is earned: ``none`` only within each channel's noise floor."""

from types import SimpleNamespace

import numpy as np
import pytest

from eddi.diagnosis.settings import MIN_FLOOR, NAMED_FACTOR, NONE_FACTOR
from eddi.mdof.verdict import channel_floor, earned_verdict, residual_peak

RATE = 1000.0
T = np.arange(0, 4.0, 1 / RATE)


def _val(measured, simulated):
    return SimpleNamespace(diverged=False, t=T, measured=np.atleast_2d(measured), simulated=np.atleast_2d(simulated))


def _decay(f, amp=1e-3, zeta=0.01):
    return amp * np.exp(-zeta * 2 * np.pi * f * T) * np.sin(2 * np.pi * f * T)


def test_residual_peak_names_the_frequency_the_model_lacks():
    meas = _decay(10.0) + 0.2 * _decay(31.0)
    f, share = residual_peak([_val(meas, _decay(10.0))], 0)
    assert f == pytest.approx(31.0, abs=0.5)
    assert share > 0.5


def test_none_above_floor_becomes_unexplained_with_the_missing_frequency():
    meas = np.vstack([_decay(10.0) + 0.5 * _decay(31.0), _decay(10.0)])
    sim = np.vstack([_decay(10.0), _decay(10.0)])
    v = _val(meas, sim)
    err = float(np.linalg.norm(meas[0] - sim[0]) / np.linalg.norm(meas[0]))
    assert err > NONE_FACTOR * MIN_FLOOR  # the premise: a channel well above the floor
    out = earned_verdict("none", {"a": err, "b": 0.0}, {"a": MIN_FLOOR, "b": MIN_FLOOR}, [v], [10.0])
    assert out.cause == "unexplained"
    (s,) = out.symptoms
    assert s["channel"] == "a" and not s["at_model_mode"]
    assert s["residual_peak_hz"] == pytest.approx(31.0, abs=0.5)
    assert "31" in s["text"] and out.note


def test_none_within_the_floor_stays_none_and_says_nothing():
    rng = np.random.default_rng(3)
    meas = _decay(10.0)
    sim = meas + 0.01 * np.std(meas) * rng.standard_normal(T.size)
    err = float(np.linalg.norm(meas - sim) / np.linalg.norm(meas))
    out = earned_verdict("none", {"a": err}, {"a": MIN_FLOOR}, [_val(meas, sim)], [10.0])
    assert out.cause == "none" and out.symptoms == () and out.note is None


def test_coupling_stays_named_up_to_the_named_factor_only():
    meas, sim = _decay(10.0), 0.9 * _decay(10.0)
    v = [_val(meas, sim)]
    inside = earned_verdict("modal_coupling", {"a": 0.5 * NAMED_FACTOR * MIN_FLOOR}, {"a": MIN_FLOOR}, v, [10.0])
    outside = earned_verdict("modal_coupling", {"a": 2 * NAMED_FACTOR * MIN_FLOOR}, {"a": MIN_FLOOR}, v, [10.0])
    assert inside.cause == "modal_coupling" and len(inside.symptoms) == 1  # above 3.5x: a symptom, still named
    assert inside.symptoms[0]["at_model_mode"]
    assert outside.cause == "unexplained" and "best partial" in outside.note


def test_channel_floor_follows_the_measured_noise():
    from eddi.mdof.validate import noise_floor

    x = np.vstack([_decay(10.0), _decay(10.0)])
    a = -(2 * np.pi * 10.0) ** 2 * x
    rms = float(np.sqrt(np.mean(x[0] ** 2)))

    def rec(scale):
        return SimpleNamespace(t=T, x=x, a=a, window=(0, T.size), highpass_hz=2.0,
                               noise=np.array([scale * rms, 1e-4 * rms]))

    low, high = channel_floor([rec(1.0)] * 2, ("a", "b")), channel_floor([rec(2.0)] * 2, ("a", "b"))
    assert low["a"] == pytest.approx(float(noise_floor(rec(1.0))[0]), rel=1e-12)
    assert low["a"] > MIN_FLOOR and high["a"] == pytest.approx(2 * low["a"], rel=1e-9)
    assert low["b"] == MIN_FLOOR
