"""The prediction floor of held-out folds (:mod:`eddi.mdof.predfloor`, session 19): exact figures."""

from __future__ import annotations

import numpy as np

from eddi.mdof.predfloor import FoldFloors, blow_sigma, jackknife_spread, joint_floors, realized_scale


def test_the_jackknife_spread_is_the_folds_scatter_relative_to_the_capture() -> None:
    t = np.linspace(0.0, 1.0, 500)
    y = np.vstack([np.sin(20 * t), 0.5 * np.cos(33 * t)])
    # two fold models whose gains differ by +-1 %: sqrt(2 * 0.01^2) = 0.0141 on every channel
    got = jackknife_spread([1.01 * y, 0.99 * y], y)
    assert np.allclose(got, np.sqrt(2) * 0.01, rtol=1e-12)
    # four folds (gains e_j about their mean): sqrt(sum (e_j - mean)^2)
    e = np.array([-0.013, 0.024, 0.001, 0.012])
    got = jackknife_spread([(1 + x) * y for x in e], y)
    assert np.allclose(got, np.sqrt(np.sum((e - e.mean()) ** 2)), rtol=1e-12)


def test_a_diverged_fold_is_left_out_and_one_model_has_no_spread() -> None:
    y = np.ones((2, 10))
    bad = np.full((2, 10), np.nan)
    assert np.allclose(jackknife_spread([1.02 * y, bad, 0.98 * y], y), np.sqrt(2) * 0.02)
    assert np.all(jackknife_spread([1.02 * y, bad], y) == 0.0)


def test_the_floors_add_in_quadrature_and_aggregate_as_the_held_out_figures() -> None:
    noise = np.array([[0.003, 0.004], [0.003, 0.004]])
    imp = np.array([[0.004, 0.0], [0.0, 0.003]])
    ident = np.full((2, 2), 0.02)  # the jackknife: evidence, not in the floor
    fl = FoldFloors(noise, imp, ident)
    assert np.allclose(fl.total, [[0.005, 0.004], [0.003, 0.005]])
    # channel floor: mean over the folds, at least the least floor
    assert np.allclose(list(fl.channel_floors(("a", "b"), 0.001).values()), [0.004, 0.0045])
    assert fl.channel_floors(("a", "b"), 0.01) == {"a": 0.01, "b": 0.01}
    assert np.allclose(fl.fold_floors(0.001), [0.0045, 0.004])
    assert np.allclose(fl.take([1]).total, [[0.003, 0.005]])
    assert set(fl.parts(("a", "b"))) == {"noise", "impulse", "blow", "ident"}


def test_the_blows_part_counts_the_training_impulses() -> None:
    u = [0.0098, 0.0084, 0.0039, 0.0045]  # t11-nulln's blows
    # the held-out blow's and the training mean's: sqrt(u0^2 + (u1^2 + u2^2 + u3^2) / 9)
    assert np.isclose(blow_sigma(u, 0), np.sqrt(0.0098**2 + (0.0084**2 + 0.0039**2 + 0.0045**2) / 9))
    assert np.isclose(blow_sigma([0.01, 0.0], 1), 0.01)


def test_the_realized_impulse_error_counts_within_three_of_its_uncertainty() -> None:
    t = np.linspace(0.0, 1.0, 400)
    y = np.vstack([np.sin(25 * t), 0.3 * np.sin(61 * t)])
    # a prediction 2 % small (e.g. the held-out blow's measured impulse 2 % low): s = 1 / 0.98 - 1
    got = realized_scale(0.98 * y, y, sigma=0.01)
    assert np.allclose(got, (1 / 0.98 - 1) * 0.98, rtol=1e-9)  # 0.02 of each channel, within 3 sigma
    assert np.allclose(realized_scale(0.98 * y, y, sigma=0.005), 3 * 0.005 * 0.98, rtol=1e-9)  # capped
    assert np.all(realized_scale(0.98 * y, y, sigma=0.0) == 0.0)  # no force noise: no impulse error
    # a frequency error is no scale: a prediction 1 % fast leaves its error above the floor
    fast = np.vstack([np.sin(25.25 * t), 0.3 * np.sin(61.61 * t)])
    err = np.linalg.norm(fast - y, axis=1) / np.linalg.norm(y, axis=1)
    assert np.all(realized_scale(fast, y, sigma=0.01) < 0.5 * err)
    z = np.zeros((2, 2))
    fl = FoldFloors(z + 0.003, z + 0.004, z, realized=z + 0.012)
    assert np.allclose(fl.total, np.hypot(0.003, 0.012))  # the realized part, the larger
    joint = joint_floors({"baseline": FoldFloors(z, z, z + 0.013, z + 0.02),
                          "coupled": FoldFloors(z, z, z + 0.007, z + 0.01)})
    assert np.allclose(joint["baseline"].ident, 0.007) and np.allclose(joint["baseline"].realized, 0.02)


def test_the_noise_spread_counts_the_few_values_of_integrated_noise() -> None:
    """Session 20: the doubly integrated, high-passed acceleration noise has the equivalent bandwidth
    1.45 f_c, so a window of T seconds holds nu = 2.9 f_c T independent values; its RMS spreads by
    0.5 sqrt(2 / nu) about the expectation."""
    from types import SimpleNamespace

    from eddi.mdof.predfloor import noise_spread

    t = np.arange(0.0, 4.0, 1 / 2048)
    rec = SimpleNamespace(t=t, window=(200, 200 + 3 * 2048), highpass_hz=1.5)
    nu = 2 * 1.4489 * 1.5 * 3.0
    assert np.isclose(noise_spread(rec), 0.5 * np.sqrt(2 / nu), rtol=2e-3)
    # a longer window or a higher cut-off: more independent values, less spread
    assert noise_spread(SimpleNamespace(t=t, window=(0, 8000), highpass_hz=6.0)) < noise_spread(rec)
    assert noise_spread(SimpleNamespace(t=t, window=(10, 10), highpass_hz=1.5)) == 0.0


def test_the_noise_chance_raises_the_channel_floor_not_the_fold_floors() -> None:
    """The floor of a channel: the folds' mean plus NOISE_SIGMAS standard deviations of that mean
    (each capture's noise spread through d total / d noise = noise / total); the per-fold floors of the
    excess gain are unchanged."""
    from eddi.mdof.predfloor import NOISE_SIGMAS

    noise = np.array([[0.03, 0.004], [0.03, 0.004], [0.03, 0.004], [0.03, 0.004]])
    imp = np.array([[0.0, 0.003]] * 4)
    sd = np.array([0.2, 0.2, 0.3, 0.1])
    fl = FoldFloors(noise, imp, np.zeros_like(noise), noise_sd=sd)
    got = fl.channel_floors(("a", "b"), 0.001)
    # channel a: noise alone, total 0.03, chance 0.03 sd_k; channel b: 0.004^2 / 0.005 sd_k
    assert np.isclose(got["a"], 0.03 + NOISE_SIGMAS * 0.03 * np.sqrt(np.sum(sd**2)) / 4, rtol=1e-12)
    assert np.isclose(got["b"], 0.005 + NOISE_SIGMAS * 0.0032 * np.sqrt(np.sum(sd**2)) / 4, rtol=1e-12)
    # session 19's floor (no spread counted): the mean alone
    assert np.allclose(list(FoldFloors(noise, imp, np.zeros_like(noise)).channel_floors(("a", "b"), 0.001).values()),
                       [0.03, 0.005])
    assert np.allclose(fl.fold_floors(0.001), [0.0175] * 4)
    assert np.isclose(fl.parts(("a", "b"))["chance"]["a"], got["a"] - 0.03)
    assert fl.take([0, 2]).noise_sd.tolist() == [0.2, 0.3]
