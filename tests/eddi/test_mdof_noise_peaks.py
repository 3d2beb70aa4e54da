"""The conditioning of multi-channel records that ring for a small part of their length (session 12).

A noise bump of the doubly weighted spectrum at 1-2 Hz was taken as the lowest mode (drift cut-off
at the record's floor, the true model's own nrmse 0.4-0.8, the noise floor 0.6-0.96: a linear model
1.7 off was called ``none``), and with fewer than 8 samples of pre-trigger the noise was read from a
record end that still rang. Both fail without :data:`eddi.mdof.signals.PEAK_OVER_NOISE` /
:func:`eddi.mdof.signals.white_noise_rms`.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.mdof.validate import noise_floor, validate_mdof
from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test


def _records(system: MdofSystem, snr: float, peaks):
    from station.mdof_data import condition_all, reduce_rate
    from station.readers import Measurement

    meas = []
    for k, p in enumerate(peaks):
        r = mdof_impact_test(system, p, snr_db=snr, seed=100 + k)
        meas.append(Measurement(t=r.t, channels=r.columns(), rate_hz=r.rate_hz, pretrigger_samples=r.pretrigger_samples,
                                mass=None, source=f"rig {p:g} N", metadata={}))
    meas, _note = reduce_rate(meas)
    return condition_all(meas, f"acc{system.driving_point}")[0]


def test_a_short_ring_down_in_a_long_record_keeps_its_cut_off_at_a_quarter_of_the_first_mode():
    # 26 + 12 kg, modes 87 and 228 Hz at 2.1 %: the ring-down lasts ~0.3 s of a 4 s record
    system = MdofSystem(name="short-ring", masses_kg=(25.935, 12.036), driving_point=2, rate_hz=4096.0,
                        pretrigger_s=0.25, record_s=4.0, tip="plastic",
                        elements=(Element(between=(0, 1), k=1.24809e7, c=964.89),
                                  Element(between=(1, 2), k=1.53267e7, c=1184.9)))
    records = _records(system, 41.5, (3970.0, 3050.0))
    truth = system.model()
    for r in records:
        assert r.highpass_hz == pytest.approx(87.1 / 4, rel=0.05)  # was 1.25 Hz (the record's floor)
        floor = noise_floor(r)
        assert np.all(floor < 0.03)  # was 0.55-0.91
        err = np.array(list(validate_mdof(truth, r).channel_nrmse.values()))
        assert np.all(err < 2.0 * np.maximum(floor, 0.01))  # the true model at the floor (was 0.37-0.85)


def test_a_pre_trigger_of_five_samples_reads_the_noise_above_the_modes_not_from_a_ringing_end():
    # 61 + 500 kg, modes 10.8 and 62 Hz, 0.27 % on the first: the record's end still rings
    system = MdofSystem(name="ringing-end", masses_kg=(61.207, 500.0), driving_point=1, rate_hz=1000.0,
                        pretrigger_s=0.005, record_s=10.0, tip="rubber",
                        elements=(Element(between=(0, 1), k=6.13295e6, c=489.28),
                                  Element(between=(1, 2), k=3.12818e6, c=249.56),
                                  Element(between=(0, 2), k=2.81489e5, c=22.457)))
    records = _records(system, 47.7, (172.0, 112.0))
    for r in records:
        assert r.window[1] > 0.8 * r.t.size  # the free window spans the ring-down (was 7 % of it)
        assert noise_floor(r)[1] < 0.02  # the heavy mass's displacement (was 0.94-0.96)
