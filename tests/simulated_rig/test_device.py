"""The emulated firmware, driven frame by frame in sample time (no transport, no clock)."""

from __future__ import annotations

import numpy as np
import pytest

from drivers.protocol import (
    CONFIGURE_BODY,
    DataFrame,
    FrameType,
    ReplyStatus,
    StreamDecoder,
    encode_command,
    encode_frame,
)
from simulated_rig.device import EmulatedDaq, PatternSource


class Host:
    """A minimal host: sends commands, decodes what comes back."""

    def __init__(self, device: EmulatedDaq) -> None:
        self.device = device
        self.decoder = StreamDecoder()
        self.seq = 0

    def send(self, command: FrameType, **kw):
        self.seq += 1
        out = self.decoder.feed(self.device.receive(encode_command(self.seq, command, **kw)))
        *data, reply = out
        cseq, ctype, status, content = reply.reply()
        assert (cseq, ctype) == (self.seq, command)
        return data, ReplyStatus(status), content

    def acquire(self, n: int) -> list[DataFrame]:
        return self.decoder.feed(self.device.acquire(n))


def test_identify_reports_channels_rate_and_version():
    host = Host(EmulatedDaq(PatternSource(3, rate_hz=19_200.0, adc_bits=16), serial="X9"))
    _, status, info = host.send(FrameType.IDENTIFY)
    assert status is ReplyStatus.OK
    assert info["serial"] == "X9" and info["protocol_version"] == 1
    assert info["rate_hz"] == 19_200.0  # paper: 19200 Hz sampling (HBM MX1601B)
    assert [c["name"] for c in info["channels"]] == ["ch0", "ch1", "ch2"]
    assert info["channels"][2]["scale"] == pytest.approx(3e-3) and info["channels"][0]["adc_bits"] == 16


def test_blocks_carry_the_sample_counter_and_stop_flushes_the_partial_block():
    dev = EmulatedDaq(PatternSource(2), block_size=100)
    host = Host(dev)
    assert host.acquire(500) == []  # not streaming: sample time does not produce frames
    _, _, started = host.send(FrameType.START)
    assert started["first_sample"] == 0
    frames = host.acquire(250) + host.acquire(30)  # 280 samples: two full blocks, 80 pending
    assert [(f.first_sample, f.counts.shape[0]) for f in frames] == [(0, 100), (100, 100)]
    data, _, stopped = host.send(FrameType.STOP)
    assert [(f.first_sample, f.counts.shape[0]) for f in data] == [(200, 80)]
    assert stopped["next_sample"] == 280
    allc = np.concatenate([f.counts for f in frames + data])
    np.testing.assert_array_equal(allc, PatternSource.expected(0, 280, 2))
    # restart continues the counter: nothing was acquired while stopped
    _, _, again = host.send(FrameType.START)
    assert again["first_sample"] == 280
    assert host.acquire(100)[0].first_sample == 280


def test_configure_selects_channels_and_refuses_bad_values():
    src = PatternSource(4, rates_hz=(1000.0, 2000.0))
    host = Host(EmulatedDaq(src))
    _, status, info = host.send(FrameType.CONFIGURE, rate_hz=2000.0, channel_mask=0b1010, block_size=10)
    assert status is ReplyStatus.OK and info["rate_hz"] == 2000.0 and info["channel_mask"] == 0b1010
    host.send(FrameType.START)
    (f,) = host.acquire(10)
    np.testing.assert_array_equal(f.counts, PatternSource.expected(0, 10, 4)[:, [1, 3]])
    assert f.channel_mask == 0b1010
    _, status, reply = host.send(FrameType.CONFIGURE, block_size=5)
    assert status is ReplyStatus.BAD_STATE and "stop first" in reply["error"]
    host.send(FrameType.STOP)
    for kw, text in [
        ({"rate_hz": 1500.0}, "rate must be one of [1000.0, 2000.0] Hz, got 1500.0 Hz"),
        ({"channel_mask": 0b10000}, "channel mask 0x10 names channels beyond the 4"),
        ({"block_size": 5000}, "block size must be 1..4096 samples, got 5000"),
        ({"rate_hz": -5.0}, "rate must be positive"),
    ]:
        _, status, reply = host.send(FrameType.CONFIGURE, **kw)
        assert status is ReplyStatus.BAD_VALUE and text in reply["error"]
    assert host.device.source.rate_hz == 2000.0  # refused values changed nothing


def test_impact_and_unknown_or_malformed_commands():
    src = PatternSource(1)
    host = Host(EmulatedDaq(src))
    host.send(FrameType.START)
    host.acquire(37)
    _, status, reply = host.send(FrameType.IMPACT, peak_force_n=500.0, double_hit=False)
    assert status is ReplyStatus.OK and reply["at_sample"] == 37 and src.impacts == [(37, 500.0, False)]
    out = host.decoder.feed(host.device.receive(encode_frame(0x7E, 99)))
    assert out[0].reply()[2] == ReplyStatus.BAD_COMMAND
    out = host.decoder.feed(host.device.receive(encode_frame(FrameType.CONFIGURE, 98, b"\x01")))
    cseq, _, status, content = out[0].reply()
    assert cseq == 98 and status == ReplyStatus.BAD_COMMAND
    assert content["error"] == f"configure body must be {CONFIGURE_BODY.size} bytes, got 1"


def test_device_without_hammer_says_unsupported():
    class NoHammer(PatternSource):
        deliver_impact = None  # type: ignore[assignment]

    host = Host(EmulatedDaq(NoHammer(1)))
    _, status, reply = host.send(FrameType.IMPACT, peak_force_n=1.0)
    assert status is ReplyStatus.UNSUPPORTED and reply["error"] == "this device has no hammer"


def test_garbage_from_host_is_ignored_then_commands_work():
    host = Host(EmulatedDaq(PatternSource(1)))
    assert host.device.receive(b"\x11\x22\x00\x05abc\x00") == b""
    _, status, _ = host.send(FrameType.STATUS)
    assert status is ReplyStatus.OK
