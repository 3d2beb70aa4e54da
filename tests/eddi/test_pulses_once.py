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
