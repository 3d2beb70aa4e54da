"""The production pyusb path over the emulated USB backend (no hardware, no libusb)."""

from __future__ import annotations

import numpy as np
import pytest
import usb.core

import drivers
from drivers.errors import BadUrlError, DeviceGoneError, DeviceNotFoundError
from drivers.usb import list_usb_devices, parse_usb_url
from simulated_rig.device import EmulatedDaq, PatternSource
from simulated_rig.usb import EmulatedUsbBackend


@pytest.fixture
def backend():
    return EmulatedUsbBackend(
        EmulatedDaq(PatternSource(4, adc_bits=16), serial="U1"),
        EmulatedDaq(PatternSource(2), serial="U2", model="EDDI-SIM-2"),
    )


def test_pyusb_find_returns_real_devices_with_descriptors(backend):
    devs = list(usb.core.find(find_all=True, idVendor=0x1209, backend=backend))
    assert [type(d) for d in devs] == [usb.core.Device, usb.core.Device]
    assert [d.serial_number for d in devs] == ["U1", "U2"]
    assert devs[1].product == "EDDI-SIM-2"
    assert [e.url for e in list_usb_devices(backend)] == ["usb://1209:edd1/U1", "usb://1209:edd1/U2"]


def test_stream_over_bulk_endpoints_is_exact(backend):
    with drivers.open_device("usb://1209:EDD1/U1", usb_backend=backend) as daq:
        assert daq.info.serial == "U1" and [c.adc_bits for c in daq.info.channels] == [16] * 4
        daq.configure(channels=[1, 3], block_size=64)
        daq.start()
        first, counts, _, dropped = daq.read_samples(20_000)
        assert first == 0 and dropped == 0
        want = PatternSource.expected(0, counts.shape[0], 4, adc_bits=16)[:, [1, 3]]
        np.testing.assert_array_equal(counts, want)
        daq.stop()
        assert daq.stats.crc_errors == 0 and daq.stats.dropped_samples == 0


def test_unplugged_device_raises_gone_and_keeps_blocks(backend):
    daq = drivers.open_device("usb://1209:edd1/U2", usb_backend=backend, queue_blocks=8)
    daq.start()
    blocks = [daq.read_block(timeout_s=2.0)]
    backend.unplug(1)
    with pytest.raises(DeviceGoneError, match="device gone while reading"):
        while True:
            b = daq.read_block(timeout_s=2.0)
            assert b is not None
            blocks.append(b)
    assert [b.first_sample for b in blocks] == [k * blocks[0].n_samples for k in range(len(blocks))]
    daq.close()
    with pytest.raises(DeviceNotFoundError, match="no USB device 1209:edd1 with serial U2 is connected"):
        drivers.open_device("usb://1209:edd1/U2", usb_backend=backend)


def test_usb_url_forms():
    assert parse_usb_url("usb://1209:edd1") == (0x1209, 0xEDD1, None)
    assert parse_usb_url("usb://16c0:0486/SN-7") == (0x16C0, 0x0486, "SN-7")
    for bad in ("usb://", "usb://1209", "usb://xyz:1", "usb://12345:1"):
        with pytest.raises(BadUrlError, match="expected usb://VID:PID"):
            parse_usb_url(bad)


@pytest.mark.hardware
def test_real_usb_daq_identifies():
    entries = list_usb_devices()
    assert entries, "no EDDI DAQ on USB"
    with drivers.open_device(entries[0].url) as daq:
        assert daq.info.protocol_version == 1
