"""Trigger tests: expected indices come from the contract in station/trigger.py, not the code.

Signals are built so the answer is known by construction: a force channel that is zero
except for pulses at chosen samples, and a second channel whose count *is* the absolute
sample index, so every row of a capture tells which sample it holds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.channels import ChannelInfo
from station.trigger import Capture, Trigger, TriggerError, TriggerSettings

FORCE = ChannelInfo(name="force", quantity="force", unit="N", scale=1.0, adc_bits=16)
INDEX = ChannelInfo(name="acc", quantity="acceleration", unit="m/s^2", scale=1.0, adc_bits=24)
RATE = 1000.0


@dataclass
class Blk:
    first_sample: int
    counts: np.ndarray
    si: np.ndarray


def signal(n: int, pulses: dict[int, list[int]]) -> np.ndarray:
    """Counts (n, 2): force = pulse values starting at each key, channel 1 = sample index."""
    c = np.zeros((n, 2), dtype=np.int32)
    c[:, 1] = np.arange(n)
    for start, values in pulses.items():
        c[start : start + len(values), 0] = values
    return c


def feed(trig: Trigger, counts: np.ndarray, sizes: list[int] | int, first: int = 0) -> list[Capture]:
    out: list[Capture] = []
    i = 0
    k = 0
    while i < counts.shape[0]:
        m = sizes if isinstance(sizes, int) else sizes[k % len(sizes)]
        k += 1
        chunk = counts[i : i + m]
        out += trig.feed(Blk(first + i, chunk, chunk * np.array([FORCE.scale, INDEX.scale])))
        i += m
    return out


def make(level: float = 5.5, pre: int = 50, post: int = 100, holdoff: int = 0, slope: str = "rising") -> Trigger:
    s = TriggerSettings(channel=0, level=level, slope=slope, pretrigger_samples=pre,  # type: ignore[arg-type]
                        posttrigger_samples=post, holdoff_samples=holdoff)
    return Trigger(s, (FORCE, INDEX), RATE)


def test_ramp_crossing_is_first_sample_at_or_above_level() -> None:
    # force count k/100 rounded down -> use scale 0.01 N/count on a ramp of counts = k
    force = ChannelInfo(name="force", quantity="force", unit="N", scale=0.01, adc_bits=24)
    s = TriggerSettings(channel=0, level=12.345, pretrigger_samples=10, posttrigger_samples=5)
    trig = Trigger(s, (force, INDEX), RATE)
    n = 3000
    counts = np.stack([np.arange(n), np.arange(n)], axis=1).astype(np.int32)
    caps = []
    for i in range(0, n, 7):
        c = counts[i : i + 7]
        caps += trig.feed(Blk(i, c, c * np.array([0.01, 1.0])))
    expected = math.ceil(12.345 / 0.01)  # first k with 0.01*k >= level: 1235
    assert [c.trigger_sample for c in caps] == [expected]
    cap = caps[0]
    assert cap.first_sample == expected - 10
    np.testing.assert_array_equal(cap.counts[:, 1], np.arange(expected - 10, expected + 5))
    assert cap.si[10, 0] >= 12.345 > cap.si[9, 0]


@pytest.mark.parametrize("size", [1, 3, 64, 1000, 5000])
def test_window_rows_and_time_base_independent_of_block_size(size: int) -> None:
    counts = signal(2000, {700: [10, 20, 10, 2, 0]})
    caps = feed(make(pre=50, post=100), counts, size)
    assert len(caps) == 1
    cap = caps[0]
    assert (cap.trigger_sample, cap.first_sample, cap.pretrigger_samples, cap.n_samples) == (700, 650, 50, 150)
    np.testing.assert_array_equal(cap.counts[:, 1], np.arange(650, 800))
    assert cap.t[50] == 0.0 and cap.t[0] == pytest.approx(-50 / RATE)
    assert cap.trigger_time_s == pytest.approx(0.7)
    assert not (cap.double_hit or cap.overload or cap.partial) and cap.dropped_samples == 0


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(min_value=1, max_value=400), min_size=1, max_size=30))
def test_any_block_split_gives_the_same_captures(sizes: list[int]) -> None:
    pulses = {120: [9, 9], 400: [30], 470: [8], 900: [7, 3]}
    counts = signal(1500, pulses)
    caps = feed(make(pre=100, post=200, holdoff=20), counts, sizes)
    # contract: 120 triggers (armed at 100); re-arm at 120+200+20=340; 400 triggers;
    # re-arm at 620 so 470 is ignored; 900 triggers and its window ends at 1100 <= 1500.
    assert [c.trigger_sample for c in caps] == [120, 400, 900]
    for c in caps:
        np.testing.assert_array_equal(c.counts[:, 1], np.arange(c.trigger_sample - 100, c.trigger_sample + 200))


def test_not_armed_until_pretrigger_is_full() -> None:
    counts = signal(600, {49: [10], 50 + 100: [10]})
    caps = feed(make(pre=50, post=20), counts, 13, first=0)
    # a pulse at 49 has only 49 samples before it: ignored; the one at 150 triggers.
    assert [c.trigger_sample for c in caps] == [150]


def test_arming_counts_from_first_sample_seen() -> None:
    counts = signal(600, {40: [10], 60: [10]})
    caps = feed(make(pre=50, post=20), counts, 600, first=1000)
    # first sample is absolute 1000: armed from 1050, so the pulse at 1040 is ignored
    assert [c.trigger_sample for c in caps] == [1060]
    np.testing.assert_array_equal(caps[0].counts[:, 1], np.arange(10, 80))


def test_holdoff_counts_from_end_of_record() -> None:
    # record ends at 200+100=300; hold-off 30 -> re-arm at 330
    counts = signal(1000, {200: [10], 329: [10], 400: [10]})
    caps = feed(make(pre=50, post=100, holdoff=30), counts, 17)
    assert [c.trigger_sample for c in caps] == [200, 400]
    counts = signal(1000, {200: [10], 330: [10]})
    caps = feed(make(pre=50, post=100, holdoff=30), counts, 17)
    assert [c.trigger_sample for c in caps] == [200, 330]


def test_level_already_above_does_not_trigger_without_crossing() -> None:
    counts = signal(500, {0: [10] * 300})  # starts above level; falls at 300 then stays 0
    assert feed(make(pre=10, post=10), counts, 50) == []


def test_falling_and_either_slopes() -> None:
    counts = signal(800, {100: [-10, -10], 300: [10, 10]})
    falling = feed(make(level=-5.5, pre=20, post=20, slope="falling"), counts, 9)
    assert [c.trigger_sample for c in falling] == [100]
    either = feed(make(level=5.5, pre=20, post=20, slope="either"), counts, 9)
    # 'either' at level 5.5: rising at 300, falling back at 302
    assert [c.trigger_sample for c in either] == [300]


def test_gap_inside_window_is_counted_and_filled() -> None:
    counts = signal(1000, {300: [10, 20, 5]})
    trig = make(pre=50, post=100)
    out: list[Capture] = []
    # drop samples 320..329 (10) and 330..339 arrive normally
    for lo, hi in [(0, 310), (310, 320), (330, 1000)]:
        c = counts[lo:hi]
        out += trig.feed(Blk(lo, c, c.astype(float)))
    assert len(out) == 1
    cap = out[0]
    assert cap.trigger_sample == 300 and cap.n_samples == 150
    assert cap.gaps == ((70, 10),) and cap.dropped_samples == 10
    assert np.isnan(cap.si[70:80]).all() and (cap.counts[70:80] == 0).all()
    assert not np.isnan(np.delete(cap.si, range(70, 80), axis=0)).any()
    np.testing.assert_array_equal(cap.counts[80:, 1], np.arange(330, 400))
    assert trig.dropped_total == 10


def test_gap_in_pretrigger_and_no_trigger_right_after_gap() -> None:
    counts = signal(1000, {400: [10] * 50, 600: [10]})
    trig = make(pre=100, post=50)
    out: list[Capture] = []
    # samples 380..399 lost; 400 is the first after the gap: its predecessor is unknown -> no trigger
    for lo, hi in [(0, 380), (400, 1000)]:
        c = counts[lo:hi]
        out += trig.feed(Blk(lo, c, c.astype(float)))
    assert [c.trigger_sample for c in out] == [600]
    counts2 = signal(1000, {600: [10]})
    trig2 = make(pre=100, post=50)
    out2: list[Capture] = []
    for lo, hi in [(0, 520), (530, 1000)]:  # 520..529 lost: inside 600's pre-trigger (500..599)
        c = counts2[lo:hi]
        out2 += trig2.feed(Blk(lo, c, c.astype(float)))
    assert out2[0].gaps == ((20, 10),) and out2[0].dropped_samples == 10


def test_capture_completed_by_a_gap() -> None:
    counts = signal(400, {200: [10]})
    trig = make(pre=10, post=50)
    out = trig.feed(Blk(0, counts[:220], counts[:220].astype(float)))
    assert out == []
    # 1000 samples lost: the record (200..249) ends inside the gap
    out = trig.feed(Blk(1220, counts[220:230], counts[220:230].astype(float)))
    assert len(out) == 1 and out[0].gaps == ((30, 30),) and out[0].n_samples == 60


def test_double_hit_needs_release_then_new_crossing() -> None:
    single = signal(1000, {200: [10, 20, 30, 20, 10, 6, 4, 1]})
    bounce_no_release = signal(1000, {200: [10, 20, 4, 10]})  # 4 >= 0.5*5.5: not released
    double = signal(1000, {200: [10, 20, 10], 260: [8, 12, 3]})
    assert feed(make(pre=50, post=100), single, 31)[0].double_hit is False
    assert feed(make(pre=50, post=100), bounce_no_release, 31)[0].double_hit is False
    assert feed(make(pre=50, post=100), double, 31)[0].double_hit is True
    late = signal(1000, {200: [10], 300: [10]})  # second hit outside the record (200..299)
    assert feed(make(pre=50, post=100), late, 31)[0].double_hit is False


def test_overload_flags_clipped_channel() -> None:
    counts = signal(1000, {200: [10, FORCE.max_count, 10]})
    cap = feed(make(pre=50, post=100), counts, 64)[0]
    assert cap.overload and cap.overload_channels == ("force",)
    assert cap.rejection(on_overload="reject") == "overload on force"
    assert cap.rejection(on_overload="flag") is None
    counts = signal(1000, {200: [10, FORCE.max_count - 1, 10]})
    assert feed(make(pre=50, post=100), counts, 64)[0].overload is False
    # a sensor range below the ADC's: |value| > range_si is overload, == range_si is not
    ranged = ChannelInfo(name="force", quantity="force", unit="N", scale=1.0, range_si=15.0, adc_bits=16)
    s = TriggerSettings(channel=0, level=5.5, pretrigger_samples=50, posttrigger_samples=100)
    for peak, expected in [(15, False), (16, True), (-16, True)]:
        cap = feed(Trigger(s, (ranged, INDEX), RATE), signal(1000, {200: [10, peak, 10]}), 64)[0]
        assert cap.overload is expected and cap.overload_channels == (("force",) if expected else ())


def test_flush_returns_partial_capture() -> None:
    counts = signal(250, {200: [10]})
    trig = make(pre=50, post=100)
    assert feed(trig, counts, 32) == []
    assert trig.state == "triggered" and trig.progress == pytest.approx(100 / 150)
    cap = trig.flush()
    assert cap is not None and cap.partial and cap.n_samples == 100  # rows 150..249 of 150..299
    np.testing.assert_array_equal(cap.counts[:, 1], np.arange(150, 250))
    assert trig.flush() is None


def test_states_and_errors() -> None:
    trig = make(pre=50, post=10, holdoff=5)
    assert trig.state == "waiting"
    counts = signal(300, {100: [10]})
    feed(trig, counts[:60], 60)
    assert trig.state == "armed"
    feed(trig, counts[60:112], 52, first=60)
    assert trig.state == "holdoff"  # captured 100..109, re-arm at 115
    with pytest.raises(TriggerError, match="expected first sample >= 112"):
        trig.feed(Blk(5, counts[:3], counts[:3].astype(float)))
    with pytest.raises(TriggerError, match="slope"):
        TriggerSettings(channel=0, level=1.0, slope="up")  # type: ignore[arg-type]
    with pytest.raises(TriggerError, match="post-trigger"):
        TriggerSettings(channel=0, level=1.0, posttrigger_samples=0)


def test_capture_is_immutable() -> None:
    cap = feed(make(pre=5, post=5), signal(100, {50: [10]}), 100)[0]
    with pytest.raises(ValueError):
        cap.counts[0, 0] = 1
    with pytest.raises(AttributeError):
        cap.rate_hz = 2.0  # type: ignore[misc]
