"""The live sample-time source: equals impact_test sample for sample, noise, clipping, rate."""

from __future__ import annotations

import json

import numpy as np
import pytest

from simulated_rig.bench import impact_test
from simulated_rig.errors import ScenarioError
from simulated_rig.scenario import Scenario, SensorConfig, SensorsConfig
from simulated_rig.source import IMPACT_DELAY_S, RigSource


def _stream(src: RigSource, pre: int, total: int, peak: float, chunk: int = 777) -> np.ndarray:
    """Read so that the pulse starts at sample ``pre``; return ``total`` samples."""
    delay = int(round(IMPACT_DELAY_S * src.rate_hz))
    parts = [src.read(pre - delay)]
    src.deliver_impact(peak)
    left = total - (pre - delay)
    while left > 0:
        k = min(chunk, left)
        parts.append(src.read(k))
        left -= k
    return np.vstack(parts)


@pytest.mark.parametrize("iepe", [None, 0.5])
def test_streamed_counts_equal_impact_test_for_same_scenario_and_seed(iepe: float | None) -> None:
    sensors = SensorsConfig(acc={"snr_db": 40.0, "iepe_highpass_hz": iepe})
    s = Scenario(system="duffing-smooth", record_s=3.0, pretrigger_s=0.1, impacts=(246.0, 600.0),
                 seed=7, sensors=sensors)
    src = RigSource.from_scenario(s)
    rec = s.impact(peak_force_n=600.0, seed=7)  # the reference (largest) impact
    got = _stream(src, rec.pretrigger_samples, rec.n_samples, 600.0)
    assert np.array_equal(got, rec.counts)
    assert src.channels == rec.channels
    assert src.impacts == [(rec.pretrigger_samples, 600.0)]


def test_ring_down_continues_past_the_simulated_window_exactly() -> None:
    # the source simulates 0.2 s per blow and then continues chunk by chunk from the state
    s = Scenario(system="duffing-struts", record_s=0.2, pretrigger_s=0.05, impacts=(37.0,), seed=2)
    src = RigSource.from_scenario(s)
    rec = impact_test(s.eom(), 37.0, pretrigger_s=0.05, record_s=1.5, sensors=src.sensors,
                      hammer=s.hammer_spec(), seed=2)
    got = _stream(src, rec.pretrigger_samples, rec.n_samples, 37.0)
    assert np.array_equal(got, rec.counts)


def test_at_rest_noise_matches_spec_and_structure_settles_to_rest() -> None:
    s = Scenario(system="duffing-struts", record_s=0.5, pretrigger_s=0.05, impacts=(11.0,), seed=3)
    src = RigSource.from_scenario(s)
    quiet = src.read(200_000)
    for j, ch in enumerate(src.channels):
        values = ch.to_si(quiet[:, j])
        sigma = src.noise_rms[ch.name]
        assert abs(np.mean(values)) < 5 * sigma / np.sqrt(len(values))
        assert np.std(values) == pytest.approx(sigma, rel=0.01)
    src.deliver_impact(11.0)
    ring = src.read(int(0.5 * src.rate_hz))
    acc = src.channels[1].to_si(ring[:, 1])
    assert np.max(np.abs(acc)) > 50 * src.noise_rms["acc"]
    # struts' ring-down dies within ~10 s (paper Sec. 3.3.2: "dies out in about 1 s" at the
    # measured level); afterwards only noise is left
    src.read(int(12 * src.rate_hz))
    tail = src.channels[1].to_si(src.read(100_000)[:, 1])
    assert np.std(tail) == pytest.approx(src.noise_rms["acc"], rel=0.02)
    assert src._seg.shape[0] <= 1  # nothing left to simulate


def test_a_larger_blow_than_the_reference_clips_and_is_counted() -> None:
    sensors = SensorsConfig(acc=SensorConfig(sensitivity=1.0, snr_db=45.0, adc_bits=16))
    s = Scenario(system="duffing-smooth", record_s=1.0, pretrigger_s=0.1, impacts=(246.0,),
                 sensors=sensors)
    src = RigSource.from_scenario(s)
    src.deliver_impact(246.0)
    src.read(int(1.0 * src.rate_hz))
    assert src.clipped == ()
    src.deliver_impact(1110.0)
    counts = src.read(int(1.0 * src.rate_hz))
    assert src.clipped == ("force", "acc")  # both ranges were set for 246 N
    acc = src.channels[1]
    assert src.clip_counts["acc"] == int(np.count_nonzero((counts[:, 1] == acc.max_count)
                                                          | (counts[:, 1] == acc.min_count)))
    assert counts[:, 1].max() == 32767


def test_deterministic_for_a_seed_and_configure_changes_rate() -> None:
    a = RigSource.from_system("duffing-struts", seed=11)
    b = RigSource.from_system("duffing-struts", seed=11)
    for src in (a, b):
        src.read(500)
        src.deliver_impact(20.0, double_hit=True)
    assert np.array_equal(a.read(5000), b.read(5000))
    # a rate change mid ring-down keeps ringing at the new rate (no jump to rest)
    a.configure(rate_hz=4800.0)
    assert a.rate_hz == 4800.0
    after = a.channels[1].to_si(a.read(480)[:, 1])
    assert np.max(np.abs(after)) > 20 * a.noise_rms["acc"]
    with pytest.raises(ScenarioError, match=r"rate_hz: must be in \[100, 1e6\] Hz"):
        a.configure(rate_hz=10.0)


def test_scenario_metadata_holds_model_noise_and_ranges() -> None:
    src = RigSource.from_system("duffing-struts", seed=1)
    meta = json.loads(src.scenario_json)
    assert meta["system"] == "duffing-struts"
    assert meta["equation_of_motion"]["mass"] == 0.088  # paper Sec. 3.3.2
    assert meta["source"]["reference_force_n"] == 60.0
    assert meta["source"]["range_si"]["acc"] == src.channels[1].range_si
    assert meta["source"]["seed"] == 1
