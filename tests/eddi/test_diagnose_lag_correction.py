"""A response that lags the hammer force is corrected, not only named: the force aligned with
the response by the measured lag, the baseline refitted per fold, the gain measured held out
(session 14, eddi/diagnosis/align.py); nothing is aligned on a null."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import butter, lfilter

from eddi.calculus import delay
from eddi.conditioning import condition
from eddi.diagnosis import Record, diagnose
from eddi.diagnosis.align import aligned, record_lags
from eddi.diagnosis.chain import measured_frequency
from tests.eddi.impact_cases import impact_record


def _set(mass: float, f: float, rate: float, chain=None, pulse_s: float = 2e-3, zeta: float = 0.015):
    k = mass * (2 * math.pi * f) ** 2
    peak = k * 2e-3 * math.pi / (2 * math.pi * f * pulse_s * 2)
    recs = []
    for j in range(3):
        s = {"mass": mass, "damping": {"v": 2 * zeta * mass * 2 * math.pi * f}, "stiffness": {"x": k},
             "peak_n": peak * (0.6 + 0.2 * j)}
        r = impact_record(s, rate_hz=rate, duration_s=min(max(30 / f, 1.0), 4.0) + 0.2, pretrigger_s=0.2,
                          pulse_s=pulse_s, snr_db=45.0, seed=140 + j)
        acc = chain(r.acc) if chain is not None else r.acc
        sig = condition(r.t, acc=acc, force=r.force, pretrigger_samples=int(0.2 * rate))
        recs.append(Record.from_conditioned(sig, label=f"c{j + 1}", pretrigger_samples=int(0.2 * rate)))
    return recs


def _lag(d):
    return next((c for c in d.candidates if c.name == "response_lag"), None)


def test_delay_moves_a_signal_by_a_fraction_of_a_sample_and_keeps_a_pulse_s_area():
    n = np.arange(400)
    y = np.sin(2 * np.pi * n / 25.0)
    assert np.max(np.abs(delay(y, 2.5)[10:390] - np.sin(2 * np.pi * (n[10:390] - 2.5) / 25.0))) < 1e-5
    assert np.array_equal(delay(np.arange(8.0), 2), [0, 0, 0, 1, 2, 3, 4, 5])
    pulse = np.zeros(64)
    pulse[30:33] = [0.5, 1.0, 0.5]
    assert delay(pulse, 7.3).sum() == pytest.approx(2.0, rel=1e-9)


def test_channels_sampled_apart_are_aligned_and_the_lag_is_named_with_its_gain():
    # 5 kg, 12 Hz at 5 kHz, the acceleration 6 samples after the force (a pure delay): the old
    # code named the lag and stopped there (`unexplained`, held-out nrmse 0.30 against a floor of 0.02)
    recs = _set(5.0, 12.0, 5000.0, chain=lambda a: delay(a, 6.0))
    d = diagnose(recs, 5.0, damping="v", stiffness="x")
    lag = _lag(d)
    assert d.cause == "response_lag"
    assert lag.params["lag_samples"] == pytest.approx(6.0, abs=0.2)
    assert d.judging.nrmse > 0.2 and lag.nrmse < 0.1 and lag.gain > 0.7 and lag.wins_every_part
    # over the force pulse alone (as if there were no lag) the impulse reads a mass 2x off; over the
    # window widened by the measured lag, within 0.5 %
    assert lag.params["impulse_ratio_before"] == pytest.approx(2.0, abs=0.05)
    assert abs(lag.params["impulse_ratio_after"] - 1.0) < 0.01
    assert "aligned" in d.verdict and any(n.startswith("response_lag: the force aligned") for n in d.notes)


def test_an_anti_alias_low_pass_is_corrected_by_its_group_delay():
    # 0.8 kg, 40 Hz at 10 kHz behind a 4th-order Butterworth at 1 kHz (group delay ~4 samples):
    # held-out 0.027 -> 0.006 once the force is aligned
    recs = _set(0.8, 40.0, 10000.0, chain=lambda a: lfilter(*butter(4, 1000.0 / 5000.0), a))
    d = diagnose(recs, 0.8, damping="v", stiffness="x")
    lag = _lag(d)
    assert d.cause == "response_lag" and 3.5 < lag.params["lag_samples"] < 4.8
    assert lag.gain > 0.5 and lag.nrmse < 1.5 * d.noise_floor.data_nrmse


def test_a_null_is_not_aligned():
    recs = _set(0.8, 40.0, 10000.0)
    assert record_lags(recs, measured_frequency(recs)) is None
    d = diagnose(recs, 0.8, damping="v", stiffness="x")
    assert d.cause == "none" and _lag(d) is None
    assert aligned(recs[0], 0.0) is recs[0]
