"""The symptoms' measured cycles on a displacement channel whose noise chatters about zero."""

from __future__ import annotations

import numpy as np

from eddi.diagnosis.symptoms import _part_numbers


def _ring_down(noise_sd: float, seed: int = 3):
    # 1.4 Hz, zeta 3 %, 500 Hz, 15 s: by 5 s the ring-down is inside the noise
    t = np.arange(7500) / 500.0
    w = 2 * np.pi * 1.4
    zeta = 0.03
    wd = w * np.sqrt(1 - zeta**2)
    x = 3e-3 * np.exp(-zeta * w * t) * np.sin(wd * t)
    v = np.gradient(x, t)
    xm = x + noise_sd * np.random.default_rng(seed).standard_normal(t.size)
    vm = np.gradient(xm, t)
    return t, xm, vm, x, v


def test_noise_crossings_on_a_measured_displacement_do_not_make_a_frequency_bias():
    # blind unseen8 (session 13): a 30 t, 1.4 Hz displacement set at 500 Hz, 40 dB read a
    # "-50 % frequency bias at large amplitude" from the tail's noise crossings, its model at 1.1x
    # the floor; the measured noise sets a dead band, the model (here the truth) is not biased
    sd = 2.5e-5
    t, xm, vm, x, v = _ring_down(sd)
    chattering = _part_numbers(t, xm, vm, x, v, 30e3, 500.0)
    judged = _part_numbers(t, xm, vm, x, v, 30e3, 500.0, noise=sd)
    assert abs(chattering["frequency_bias_high_pct"]) > 10  # what the station said before
    assert abs(judged["frequency_bias_high_pct"]) < 0.5
    assert abs(judged["frequency_bias_low_pct"]) < 2.0


def test_a_model_that_is_off_in_frequency_is_still_seen_through_the_dead_band():
    sd = 2.5e-5
    t, xm, vm, _x, _v = _ring_down(sd)
    w = 2 * np.pi * 1.4 * 1.02  # a model 2 % stiff in frequency
    xs = 3e-3 * np.exp(-0.03 * w * t) * np.sin(w * np.sqrt(1 - 0.03**2) * t)
    got = _part_numbers(t, xm, vm, xs, np.gradient(xs, t), 30e3, 500.0, noise=sd)
    assert 1.5 < got["frequency_bias_high_pct"] < 2.5


def test_a_coarse_displacement_channel_chattering_between_counts_makes_no_frequency_bias():
    # blind unseen9 (session 13): an 8-bit 1 kHz displacement channel, flat at rest (noise 0),
    # chattered between counts about zero at the end of the ring-down and read a -24 % "small-
    # amplitude frequency bias"; its quantisation q / sqrt(12) sets the dead band
    from types import SimpleNamespace

    from eddi.diagnosis.symptoms import part_noise

    t = np.arange(10240) / 1024.0
    w = 2 * np.pi * 6.9
    x = 3.5e-4 * np.exp(-0.008 * w * t) * np.sin(w * t)
    q = 3.5e-4 / 88
    # noise of a third of a count under the converter: flat at rest, dithered about zero
    xm = np.round((x + 0.3 * q * np.random.default_rng(4).standard_normal(t.size)) / q) * q
    vm = np.gradient(xm, t)
    noise = part_noise(SimpleNamespace(noise_rms=0.0, response="disp"), xm)
    assert noise == np.float64(q / np.sqrt(12.0)) or abs(noise / (q / np.sqrt(12.0)) - 1) < 1e-9
    chattering = _part_numbers(t, xm, vm, x, np.gradient(x, t), 0.7, 1024.0)
    judged = _part_numbers(t, xm, vm, x, np.gradient(x, t), 0.7, 1024.0, noise=noise)
    assert chattering["frequency_bias_low_pct"] < -10  # what the station said before
    assert abs(judged["frequency_bias_low_pct"]) < 1.0
    assert abs(judged["frequency_bias_high_pct"]) < 0.5
