"""The fold polish judges both kinds alike: coupled folds that won unpolished are polished when the
baseline's polish takes the win away (session 14; fails on the code before: coupled folds never
polished, the verdict compared polished baseline folds with unpolished coupled ones)."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

import station.mdof_polish as polish_mod
from eddi.mdof import verdict


@dataclass(frozen=True)
class _Val:
    nrmse: float
    channel_nrmse: dict


def _fits(baseline, coupled):
    return [{"baseline": (_Val(b, {"acc1": b, "acc2": b}), ("base", k), ()),
             "coupled": (_Val(c, {"acc1": c, "acc2": c}), ("cpl", k), ())}
            for k, (b, c) in enumerate(zip(baseline, coupled))]


def _run(monkeypatch, fits, polished):
    monkeypatch.setattr(verdict, "channel_floor", lambda records, names: {n: 0.02 for n in names})
    monkeypatch.setattr(polish_mod, "polished_fold",
                        lambda ident, train, held, unpolished: _Val(polished[ident], unpolished.channel_nrmse))
    return polish_mod.polish_folds(fits, [None] * len(fits), ("acc1", "acc2"), 0.5)


def test_coupled_folds_polished_when_the_baseline_polish_takes_the_win(monkeypatch):
    # the figures of the quadratic-spring chain of bench_mdof_target.py (tuning 1-18)
    fits = _fits([0.0646, 0.0570, 0.1730], [0.0317, 0.0297, 0.0259])
    polished = {("base", 0): 0.0288, ("base", 1): 0.0280, ("base", 2): 0.0481,
                ("cpl", 0): 0.0235, ("cpl", 1): 0.0165, ("cpl", 2): 0.0204}
    done = _run(monkeypatch, fits, polished)
    assert done == {"baseline": [0, 1, 2], "coupled": [0, 1, 2]}
    assert [f["coupled"][0].nrmse for f in fits] == [0.0235, 0.0165, 0.0204]
    base = [f["baseline"][0].nrmse for f in fits]
    # the raw per-fold gain: polished against polished, not polished baseline against unpolished coupled
    assert verdict.held_out_gain(base, [f["coupled"][0].nrmse for f in fits]) == pytest.approx(0.4114, abs=1e-4)
    assert verdict.held_out_gain(base, [0.0317, 0.0297, 0.0259]) == pytest.approx(0.1433, abs=1e-4)


def test_coupled_folds_left_unpolished_while_they_still_win(monkeypatch):
    fits = _fits([0.20, 0.25, 0.30], [0.021, 0.022, 0.020])
    polished = {("base", 0): 0.10, ("base", 1): 0.12, ("base", 2): 0.15,
                ("cpl", 0): 0.02, ("cpl", 1): 0.02, ("cpl", 2): 0.02}
    done = _run(monkeypatch, fits, polished)
    assert done == {"baseline": [0, 1, 2], "coupled": []}  # the gain stays > 0.5 after the baseline's polish
    assert [f["coupled"][0].nrmse for f in fits] == [0.021, 0.022, 0.020]
