"""The Daq API end to end over a real pty served by the emulated firmware (no hardware)."""

from __future__ import annotations


import numpy as np
import pytest

import drivers
from drivers.errors import (
    BadUrlError,
    DeviceError,
    DeviceGoneError,
    DeviceNotFoundError,
    DeviceTimeoutError,
    ProtocolVersionError,
)
from simulated_rig.device import EmulatedDaq, PatternSource
from simulated_rig.serve import PtyServer


class FakeClock:
    """A clock the test moves by hand (thread-safe enough for a float)."""

    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


@pytest.fixture
def rig():
    src = PatternSource(3, rate_hz=10_000.0, rates_hz=(10_000.0, 20_000.0, 51_200.0))
    server = PtyServer(EmulatedDaq(src), paced=False).start()
    yield server
    server.close()


def test_identify_configure_stream_exact_counts_and_si(rig):
    with drivers.open_device(f"serial://{rig.port}") as daq:
        assert (daq.info.model, daq.info.serial, daq.info.protocol_version) == ("EDDI-SIM-8", "SIM00001", 1)
        assert [c.name for c in daq.info.channels] == ["ch0", "ch1", "ch2"]
        info = daq.configure(rate_hz=20_000, channels=["ch0", "ch2"], block_size=100)
        assert info.rate_hz == 20_000.0 and info.block_size == 100
        assert [c.name for c in info.channels] == ["ch0", "ch2"]
        daq.start()
        first, counts, si, dropped = daq.read_samples(5000)
        daq.stop()
        assert first == 0 and dropped == 0
        want = PatternSource.expected(0, counts.shape[0], 3)[:, [0, 2]]
        np.testing.assert_array_equal(counts, want)
        # SI = counts * scale + offset, channel ch2: scale 3e-3, offset 0.2
        np.testing.assert_allclose(si[:, 1], want[:, 1] * 3e-3 + 0.2, rtol=0, atol=1e-12)
        st = daq.stats
        assert st.crc_errors == 0 and st.dropped_samples == 0 and st.resyncs == 0
        # after stop the tail is in the queue: nothing lost in total
        total = counts.shape[0]
        while (b := daq.read_block(timeout_s=0.5)) is not None:
            np.testing.assert_array_equal(b.counts, PatternSource.expected(b.first_sample, b.n_samples, 3)[:, [0, 2]])
            assert b.first_sample == total
            total += b.n_samples
        assert total == daq.status()["next_sample"] == daq.stats.samples


def test_device_refuses_unsupported_rate_in_one_line(rig):
    with drivers.open_device(f"serial://{rig.port}") as daq:
        with pytest.raises(DeviceError, match=r"rate must be one of \[10000.0, 20000.0, 51200.0\] Hz, got 12345.0"):
            daq.configure(rate_hz=12345)
        with pytest.raises(DeviceError, match="unknown channel 'nope'"):
            daq.configure(channels=["nope"])
        daq.start()
        with pytest.raises(DeviceError, match="configure while streaming"):
            daq.configure(block_size=10)


def test_impact_reaches_the_source(rig):
    with drivers.open_device(f"serial://{rig.port}") as daq:
        daq.impact(250.0, double_hit=True)
        with pytest.raises(DeviceError, match="impact peak force must be positive, got -1.0 N"):
            daq.impact(-1.0)
    assert rig.device.source.impacts == [(0, 250.0, True)]


def test_device_gone_mid_stream_keeps_what_was_read_then_raises(rig):
    daq = drivers.open_device(f"serial://{rig.port}", queue_blocks=64)
    daq.start()
    kept = [daq.read_block(timeout_s=2.0) for _ in range(5)]
    rig.close()  # the pty disappears under the host
    with pytest.raises(DeviceGoneError, match="device gone"):
        for _ in range(100_000):
            b = daq.read_block(timeout_s=2.0)
            assert b is not None
            kept.append(b)
    firsts = [b.first_sample for b in kept]
    ends = [b.first_sample + b.n_samples for b in kept]
    assert firsts[0] == 0 and firsts[1:] == ends[:-1]  # everything received is contiguous
    with pytest.raises(DeviceGoneError):
        daq.start()
    daq.close()


def test_reconnect_through_a_stable_link_after_the_device_went_away(tmp_path):
    link = str(tmp_path / "ttyRIG")
    first = PtyServer(EmulatedDaq(PatternSource(1), serial="A1"), link=link).start()
    daq = drivers.open_device(f"serial://{link}")
    assert daq.info.serial == "A1"
    first.close()
    with pytest.raises(DeviceGoneError):
        daq.start()
        while True:
            daq.read_block(timeout_s=2.0)
    daq.close()
    with PtyServer(EmulatedDaq(PatternSource(1), serial="A2"), link=link):
        with drivers.open_device(f"serial://{link}") as again:
            again.start()
            b = again.read_block(timeout_s=2.0)
            assert again.info.serial == "A2" and b is not None and b.first_sample == 0


def test_paced_device_follows_the_injected_clock_exactly():
    clock = FakeClock()
    src = PatternSource(2, rate_hz=10_000.0)
    with PtyServer(EmulatedDaq(src, block_size=100), paced=True, clock=clock) as server:
        with drivers.open_device(f"serial://{server.port}") as daq:
            daq.start()
            assert daq.read_block(timeout_s=0.2) is None  # no sample time has passed
            clock.t = 0.1  # 1000 samples are due, i.e. 10 blocks
            got = [daq.read_block(timeout_s=2.0) for _ in range(10)]
            assert [b.first_sample for b in got] == list(range(0, 1000, 100))
            assert daq.read_block(timeout_s=0.2) is None
            assert daq.stats.samples == 1000


def test_paced_overrun_is_counted_exactly_as_dropped_samples():
    clock = FakeClock()
    src = PatternSource(8, rate_hz=10_000.0)
    server = PtyServer(EmulatedDaq(src, block_size=50), paced=True, clock=clock, fifo_bytes=2000).start()
    try:
        with drivers.open_device(f"serial://{server.port}", queue_blocks=4) as daq:
            daq.start()
            clock.t = 5.0  # 50 000 samples at once: far more than the FIFO, the pty and the queue hold
            blocks = []
            while (b := daq.read_block(timeout_s=0.5)) is not None:
                blocks.append(b)
            daq.stop()
            while (b := daq.read_block(timeout_s=0.5)) is not None:
                blocks.append(b)
            received = sum(b.n_samples for b in blocks)
            assert server.overrun_frames > 0
            assert daq.stats.dropped_samples == sum(b.dropped_before for b in blocks) + (
                50_000 - blocks[-1].first_sample - blocks[-1].n_samples)
            assert received + daq.stats.dropped_samples == 50_000
            for b in blocks:
                np.testing.assert_array_equal(b.counts, PatternSource.expected(b.first_sample, b.n_samples, 8))
    finally:
        server.close()


def test_bad_urls_and_missing_devices_are_one_line_errors(tmp_path):
    for url, err, text in [
        ("nothing", BadUrlError, "expected a device URL"),
        ("ftp://x", BadUrlError, "unknown device URL scheme 'ftp'"),
        ("serial://", BadUrlError, "expected serial:///path"),
        ("serial:///dev/ttyS0?speed=9", BadUrlError, "unknown serial option 'speed'"),
        ("serial:///dev/ttyS0?baudrate=fast", BadUrlError, "baudrate must be int"),
        (f"serial://{tmp_path}/none", DeviceNotFoundError, "no serial port at"),
        ("usb://zz:1", BadUrlError, "usb://VID:PID"),
        ("sim://duffing", BadUrlError, "station.devices.open_device"),
    ]:
        with pytest.raises(err, match=text) as info:
            drivers.open_device(url)
        assert "\n" not in str(info.value)


def test_silent_port_times_out_and_echo_is_not_a_device():
    # loop:// echoes our own commands back: they are not replies, so identify times out
    with pytest.raises(DeviceTimeoutError, match="no reply to STOP within 0.2 s"):
        drivers.open_device("loop://", timeout_s=0.2)


def test_other_protocol_version_is_refused():
    from drivers.daq import DeviceInfo

    with pytest.raises(ProtocolVersionError, match="protocol version 2, this driver speaks version 1"):
        DeviceInfo.from_reply({"protocol_version": 2})


def test_reader_never_blocks_a_command_when_the_queue_is_full(rig):
    with drivers.open_device(f"serial://{rig.port}", queue_blocks=2) as daq:
        daq.start()
        first = daq.read_block(timeout_s=2.0)
        status = daq.status()  # the reader is waiting on a full queue; the reply still comes
        assert status["streaming"] is True
        daq.stop()
        blocks = [first]
        while (b := daq.read_block(timeout_s=0.5)) is not None:
            blocks.append(b)
        assert sum(b.n_samples for b in blocks) + daq.stats.dropped_samples == daq.status()["next_sample"]
        assert daq.stats.dropped_samples == 0


class _FutureFirmware:
    """A device that answers every command with a well-formed frame of protocol version 2."""

    streaming = False
    block_size = 1

    def receive(self, data: bytes) -> bytes:
        from drivers.protocol import FrameType, encode_frame

        return encode_frame(FrameType.REPLY, 0, b"\x00" * 6 + b"{}", version=2)

    def acquire(self, n: int) -> bytes:
        return b""


def test_device_of_another_protocol_version_is_a_one_line_error():
    with PtyServer(_FutureFirmware(), paced=False) as server:  # type: ignore[arg-type]
        with pytest.raises(ProtocolVersionError, match="device speaks protocol version 2, this driver speaks version 1"):
            drivers.open_device(f"serial://{server.port}")


@pytest.mark.hardware
def test_real_serial_daq_streams_without_loss():
    import os

    url = os.environ.get("EDDI_DAQ_URL", "serial:///dev/ttyACM0")
    with drivers.open_device(url) as daq:
        daq.start()
        _, counts, _, dropped = daq.read_samples(int(daq.info.rate_hz))
        daq.stop()
        assert dropped == 0 and daq.stats.crc_errors == 0 and counts.shape[1] == len(daq.info.channels)
