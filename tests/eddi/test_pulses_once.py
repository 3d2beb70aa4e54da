"""The hammer pulses of a record are found once (session 14): the impulse check and the chain
asked for them four times a record, each pass a median over the whole force channel."""

from __future__ import annotations

import dataclasses

import numpy as np

import eddi.diagnosis.chain as chain
from eddi.conditioning import condition
from eddi.diagnosis.records import Record
from station.impulse_check import check_signal
from tests.eddi.impact_cases import impact_record

SYSTEM = {"mass": 0.8, "damping": {"v": 2 * 0.01 * 0.8 * 2 * np.pi * 40.0},
          "stiffness": {"x": 0.8 * (2 * np.pi * 40.0) ** 2}, "peak_n": 200.0}


def _sig():
    r = impact_record(SYSTEM, rate_hz=10_000.0, duration_s=1.5, pretrigger_s=0.2, pulse_s=2e-3, snr_db=45.0, seed=5)
    return condition(r.t, acc=r.acc, force=r.force, pretrigger_samples=2000)


def test_the_impulse_check_finds_the_pulses_once(monkeypatch):
    calls = []
    real = chain._pulses

    def counted(f, rate):
        calls.append(f.size)
        return real(f, rate)

    monkeypatch.setattr(chain, "_pulses", counted)
    sig = _sig()
    chk = check_signal(sig, SYSTEM["mass"])
    assert chk is not None and chk.fault == ""
    assert len(calls) == 1  # double hit, impulse, pulse width and lag share them (4 before)
    # the same verdicts as without the memo: the record's symptoms, each pulse list equal
    rec = Record.from_conditioned(sig)
    assert chain._record_pulses(rec) == tuple(real(rec.force, rec.rate_hz))


def test_a_record_with_another_force_gets_its_own_pulses():
    rec = Record.from_conditioned(_sig())
    first = chain._record_pulses(rec)
    twice = rec.force.copy()
    twice[len(twice) // 2: len(twice) // 2 + 20] = 3 * np.max(np.abs(rec.force))  # a second blow
    other = dataclasses.replace(rec, force=twice)
    assert len(chain._record_pulses(other)) == len(first) + 1
    assert chain._record_pulses(rec) == first
    assert other == dataclasses.replace(rec, force=twice)  # the memo is not a field


def test_the_impulse_check_measures_the_damping_and_the_lag_once(monkeypatch):
    # session 16: the window's widening and the lag warning each measured the record's damping
    # ratio (a backbone over the free response) and its lag: ~15 ms of a 45 s record's identify
    import eddi.diagnosis.lag as lag
    import eddi.diagnosis.show as show

    backbones, lags = [], []
    real_backbone, real_lag = show.backbone, lag.response_lag
    monkeypatch.setattr(show, "backbone", lambda *a, **k: backbones.append(1) or real_backbone(*a, **k))
    monkeypatch.setattr(lag, "response_lag", lambda *a, **k: lags.append(a[1:]) or real_lag(*a, **k))
    sig = _sig()
    chk = check_signal(sig, SYSTEM["mass"])
    assert chk is not None and chk.fault == ""
    assert len(backbones) == 1 and len(lags) == 1  # 2 and 2 before
    # the same numbers as measured afresh on a new record
    rec = Record.from_conditioned(sig)
    f1 = lags[0][0]
    assert chain._damping_ratio(rec) == chain._damping_ratio_of(rec)
    assert chain.response_lag(rec, f1) == real_lag(rec, f1, chain._damping_ratio_of(rec))
    monkeypatch.undo()
    fresh = check_signal(sig, SYSTEM["mass"])
    assert fresh == chk


def test_a_record_with_another_response_gets_its_own_damping_and_lag():
    rec = Record.from_conditioned(_sig())
    z = chain._damping_ratio(rec)
    other = dataclasses.replace(rec, x=rec.x * 1.0, v=rec.v * (1.0 + 1e-3 * np.arange(rec.v.size) / rec.v.size))
    assert chain._damping_ratio(other) == chain._damping_ratio_of(other) != z
    assert chain._damping_ratio(rec) == z
