"""The prediction floor of held-out folds (:mod:`eddi.mdof.predfloor`, session 19): exact figures."""

from __future__ import annotations

import numpy as np

from eddi.mdof.predfloor import FoldFloors, jackknife_spread


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
    ident = np.array([[0.0, 0.003], [0.004, 0.0]])
    fl = FoldFloors(noise, imp, ident)
    assert np.allclose(fl.total, [[0.005, 0.005], [0.005, 0.005]])
    # channel floor: mean over the folds, at least the least floor
    assert fl.channel_floors(("a", "b"), 0.001) == {"a": 0.005, "b": 0.005}
    assert fl.channel_floors(("a", "b"), 0.01) == {"a": 0.01, "b": 0.01}
    assert np.allclose(fl.fold_floors(0.001), [0.005, 0.005])
    assert np.allclose(list(fl.training_floors(("a", "b"), 0.0).values()), [np.mean([0.005, 0.003]), 0.0045])
    assert np.allclose(fl.take([1]).total, [[0.005, 0.005]])
    assert set(fl.parts(("a", "b"))) == {"noise", "impulse", "ident"}
