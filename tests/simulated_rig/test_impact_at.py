"""IMPACT_AT: the firmware delivers a scheduled blow at its exact sample, however sample time is chunked."""

from __future__ import annotations

import pytest

from drivers.protocol import FrameType, ReplyStatus, StreamDecoder, encode_command
from simulated_rig.device import EmulatedDaq, PatternSource


class Host:
    """Sends commands to the firmware and decodes what comes back (no transport, no clock)."""

    def __init__(self, device: EmulatedDaq) -> None:
        self.device, self.decoder, self.seq = device, StreamDecoder(), 0

    def send(self, command: FrameType, **kw):
        self.seq += 1
        reply = self.decoder.feed(self.device.receive(encode_command(self.seq, command, **kw)))[-1]
        cseq, ctype, status, content = reply.reply()
        assert (cseq, ctype) == (self.seq, command)
        return None, ReplyStatus(status), content

    def acquire(self, n: int) -> None:
        self.decoder.feed(self.device.acquire(n))


@pytest.mark.parametrize("chunk", [1, 97, 256, 5000])
def test_a_scheduled_blow_lands_at_its_sample_whatever_the_chunking(chunk: int) -> None:
    source = PatternSource(n_channels=2)
    host = Host(EmulatedDaq(source, block_size=64))
    assert host.send(FrameType.IMPACT_AT, peak_force_n=300.0, at_sample=1000)[1:] == (ReplyStatus.OK, {"at_sample": 1000})
    assert host.send(FrameType.IMPACT_AT, peak_force_n=50.0, double_hit=True, at_sample=1700)[1] == ReplyStatus.OK
    host.send(FrameType.START)
    total = 0
    while total < 3000:
        host.acquire(chunk)
        total += chunk
    assert source.impacts == [(1000, 300.0, False), (1700, 50.0, True)]


def test_a_blow_in_the_past_or_without_force_is_refused_and_configure_clears_the_schedule() -> None:
    source = PatternSource(n_channels=1)
    host = Host(EmulatedDaq(source, block_size=64))
    host.send(FrameType.START)
    host.acquire(640)
    _, status, content = host.send(FrameType.IMPACT_AT, peak_force_n=10.0, at_sample=100)
    assert status == ReplyStatus.BAD_VALUE and "in the past (the device is at 640)" in content["error"]
    _, status, content = host.send(FrameType.IMPACT_AT, peak_force_n=-1.0, at_sample=5000)
    assert status == ReplyStatus.BAD_VALUE and "> 0 N" in content["error"]
    assert host.send(FrameType.IMPACT_AT, peak_force_n=10.0, at_sample=800)[1] == ReplyStatus.OK
    host.send(FrameType.STOP)
    host.send(FrameType.CONFIGURE)  # the counter restarts at 0: the schedule goes with it
    host.send(FrameType.START)
    host.acquire(2000)
    assert source.impacts == []
