"""A multi-channel ``none`` above the noise floor that the coupled model consistently improves is
``unexplained`` (session 18, :mod:`station.mdof_verdict`).

The two profiles are the lead's description of two blind two-channel records (no data seen): R1
(modes 7.99 / 18.67 Hz; baseline folds 0.075 / 0.076 / 0.129, coupled better on 2 of 3, allowance
excess gain 0.42, per-mode excess 0.385 / 0.438) and R2 (modes 20.3 / 67.7 Hz; better on 3 of 3,
per-mode excess 0.33 / 0.21). Main printed ``Cause: none (uncertain)`` on both. The null profile is
t11-nulln of ``bench_mdof_nulls.py`` (a linear chain, baseline 1.24x its floor, coupled worse on 2
of 4 folds, excess -0.18): it stays ``none (uncertain)``.
"""

from __future__ import annotations

import pytest

from station.mdof_commands import _uncertain_none
from station.mdof_verdict import SHORT_EXCESS, coupling_short


def _obj(base_ch, floors, fb, fc, excess, mode_ex=(), mode_better=(), cause="none", raw=0.28):
    return {"cause": cause, "gain": 0.0, "raw_gain": raw, "margin": 0.5, "notes": [], "symptoms": [],
            "noise_floor": floors,
            "baseline": {"channel_nrmse": base_ch, "folds": fb},
            "coupled": {"channel_nrmse": base_ch, "folds": fc},
            "allowance": {"earned": False, "excess_gain": excess, "base_over": 2.1, "coupled_over": 1.59,
                          "worse_folds": sum(c >= b for b, c in zip(fb, fc))},
            "modes": {"excess_gain": list(mode_ex), "better_folds": list(mode_better)} if mode_ex else None}


def r1():
    return _obj({"acc1": 0.0927, "acc2": 0.0939}, {"acc1": 0.0405, "acc2": 0.0447},
                [0.075, 0.076, 0.129], [0.0745, 0.0765, 0.049], 0.42, (0.385, 0.438), (1, 3))


def test_r1_profile_is_unexplained_with_the_symptoms_not_none():
    obj = r1()
    assert coupling_short(obj, "baseline", (True, True, False)) is True
    _uncertain_none(obj, "baseline")
    assert obj["cause"] == "unexplained" and obj["uncertain"] is False  # main: none, uncertain
    ev = obj["short_coupling"]
    assert (ev["better_folds"], ev["folds"], ev["channel"]) == (2, 3, "acc1")
    assert ev["excess_gain"] == pytest.approx(0.42) and ev["ratio"] == pytest.approx(0.0927 / 0.0405)
    assert ev["coupling_terms_folds"] == 2
    (note,) = obj["notes"]
    assert "2.3x the noise floor on channel acc1" in note and "removes 42 %" in note
    assert "better on 2 of 3 folds" in note and "q1 excess gain 38 %, better on 1 of 3 folds" in note
    assert obj["symptoms"][-1]["kind"] == "coupled_gain_short"


def test_r2_profile_is_unexplained():
    obj = _obj({"acc1": 0.0202, "acc2": 0.0157}, {"acc1": 0.0117, "acc2": 0.010},
               [0.018, 0.016, 0.0197], [0.0143, 0.0128, 0.0155], 0.36, (0.33, 0.21), (2, 3), raw=0.22)
    assert coupling_short(obj) is True and obj["cause"] == "unexplained"


def test_linear_null_profile_stays_none_uncertain():
    # t11-nulln (bench_mdof_nulls.py tuning, session 18 run): worse on 2 of 4 folds, excess -0.18
    obj = _obj({"acc1": 0.0124, "acc2": 0.0129}, {"acc1": 0.01, "acc2": 0.01},
               [0.0118, 0.0130, 0.0125, 0.0127], [0.0150, 0.0121, 0.0160, 0.0120], -0.18, (-0.22, 0.09), (2, 3),
               raw=-0.14)
    assert coupling_short(obj) is False and obj["short_coupling"] is None
    _uncertain_none(obj, "baseline")
    assert obj["cause"] == "none" and obj["uncertain"] is True


@pytest.mark.parametrize("change", ["within_floor", "two_worse", "half_worse", "small_excess", "mode_worse", "named"])
def test_each_cut_alone_keeps_the_verdict(change):
    obj = r1()
    if change == "within_floor":
        obj["baseline"]["channel_nrmse"] = {"acc1": 0.040, "acc2": 0.044}
    elif change == "two_worse":
        obj["coupled"]["folds"] = [0.076, 0.077, 0.049]
    elif change == "half_worse":  # 2 of 4 folds worse: a null's coin toss
        obj["baseline"]["folds"], obj["coupled"]["folds"] = [0.075, 0.076, 0.129, 0.08], [0.074, 0.077, 0.049, 0.09]
    elif change == "small_excess":
        obj["allowance"]["excess_gain"] = SHORT_EXCESS - 0.01
    elif change == "mode_worse":
        obj["modes"]["excess_gain"] = [0.8, -0.51]
    elif change == "named":
        obj["cause"] = "modal_coupling"
    cause = obj["cause"]
    assert coupling_short(obj) is False and obj["cause"] == cause and obj["notes"] == []


def test_a_baseline_that_did_not_run_is_not_counted():
    obj = r1()
    obj["baseline"]["folds"] = [0.075, 0.076, float("inf")]  # the fold the coupled model won: no evidence
    obj["coupled"]["folds"] = [0.0745, 0.0770, 0.049]
    assert coupling_short(obj) is False


def test_none_is_judged_against_the_prediction_floor_when_there_is_one():
    # t11-nulln-like figures: 1.24-1.29x the noise floor (0.01, the clamp), while the true equations leave
    # 1.27-1.32x it (the measured impulse's uncertainty, 0.011-0.012 per capture): within the prediction floor
    obj = _obj({"acc1": 0.0124, "acc2": 0.0129}, {"acc1": 0.01, "acc2": 0.01},
               [0.0118, 0.0130, 0.0125, 0.0127], [0.0150, 0.0121, 0.0160, 0.0120], -0.18, raw=-0.14)
    obj["prediction_floor"] = {"acc1": 0.0130, "acc2": 0.0131}
    assert coupling_short(obj) is False
    _uncertain_none(obj, "baseline")
    assert obj["cause"] == "none" and obj["uncertain"] is False and obj["notes"] == []
    obj["prediction_floor"] = {"acc1": 0.0120, "acc2": 0.0121}  # above it: still said
    _uncertain_none(obj, "baseline")
    assert obj["uncertain"] is True and "1.1x the prediction floor on channel acc2" in obj["notes"][-1]
