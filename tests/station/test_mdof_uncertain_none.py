"""A multi-channel ``none`` above a channel's noise floor is said to be uncertain, as the
one-coordinate loop says it (session 16: blind unseen11 seed 4242, a three-channel capture set
whose baseline sat 2.8x its floors held out while the coupled model was better on every fold,
gain 29 % under the 50 % margin, read a plain ``Cause: none``)."""

from __future__ import annotations

from station.mdof_commands import _uncertain_none


def _obj(base_ch: dict[str, float], floors: dict[str, float], cause: str = "none") -> dict:
    return {"cause": cause, "gain": 0.29, "margin": 0.5, "notes": [], "noise_floor": floors,
            "baseline": {"channel_nrmse": base_ch, "folds": [0.019, 0.018, 0.049]},
            "coupled": {"channel_nrmse": base_ch, "folds": [0.015, 0.008, 0.047]}}


def test_none_above_the_floor_is_uncertain_with_the_worst_channel_and_the_folds() -> None:
    obj = _obj({"a": 0.0292, "b": 0.0285}, {"a": 0.01, "b": 0.01})
    _uncertain_none(obj, "baseline")
    assert obj["uncertain"] is True
    (note,) = obj["notes"]
    assert "2.9x the noise floor on channel a" in note
    assert "better on 3 of 3 folds" in note and "gain 29 % against a margin of 50 %" in note


def test_none_within_the_floor_and_named_causes_are_not_marked() -> None:
    obj = _obj({"a": 0.009, "b": 0.0099}, {"a": 0.01, "b": 0.01})
    _uncertain_none(obj, "baseline")
    assert obj["uncertain"] is False and obj["notes"] == []
    named = _obj({"a": 0.03}, {"a": 0.01}, cause="modal_coupling")
    _uncertain_none(named, "coupled")
    assert named["uncertain"] is False and named["notes"] == []
