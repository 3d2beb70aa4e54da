"""The emulated DAQ as a USB device, behind a pyusb backend.

:class:`EmulatedUsbBackend` implements ``usb.backend.IBackend``, so
``usb.core.find(idVendor=..., backend=EmulatedUsbBackend(device))`` returns a real
``usb.core.Device`` and the production driver (:mod:`drivers.usb`) runs unchanged on it:
descriptors, string descriptors through control transfers, claiming, bulk OUT commands and
the bulk IN stream.

Sample time is unpaced: a bulk IN read acquires as many samples as it needs, so the host's
reading speed sets the pace and nothing is dropped. :meth:`EmulatedUsbBackend.unplug` makes
the device vanish (``ENODEV``) to test what the host does when a cable is pulled.
"""

from __future__ import annotations

import array
import errno
import threading
from types import SimpleNamespace

import usb.backend
import usb.core

from drivers.protocol import PROTOCOL_VERSION
from drivers.usb import DEFAULT_PID, DEFAULT_VID, EP_IN, EP_OUT, INTERFACE_CLASS, INTERFACE_SUBCLASS
from simulated_rig.device import EmulatedDaq

_LANGID_EN_US = 0x0409
_GET_DESCRIPTOR = 6
_DESC_STRING = 3


class _Handle:
    def __init__(self, dev: "_UsbDevice") -> None:
        self.dev = dev


class _UsbDevice:
    """One emulated device on the bus: firmware, descriptors, IN buffer."""

    def __init__(self, firmware: EmulatedDaq, vid: int, pid: int, address: int) -> None:
        self.firmware = firmware
        self.address = address
        self.strings = {1: "EDDI Station", 2: firmware.model, 3: firmware.serial}
        self.descriptor = SimpleNamespace(
            bLength=18, bDescriptorType=1, bcdUSB=0x0200, bDeviceClass=0, bDeviceSubClass=0,
            bDeviceProtocol=0, bMaxPacketSize0=64, idVendor=vid, idProduct=pid, bcdDevice=0x0100,
            iManufacturer=1, iProduct=2, iSerialNumber=3, bNumConfigurations=1,
            address=address, bus=1, port_number=address, port_numbers=(address,), speed=3,
        )
        self.config = SimpleNamespace(
            bLength=9, bDescriptorType=2, wTotalLength=32, bNumInterfaces=1, bConfigurationValue=1,
            iConfiguration=0, bmAttributes=0x80, bMaxPower=50, extra_descriptors=[],
        )
        self.interface = SimpleNamespace(
            bLength=9, bDescriptorType=4, bInterfaceNumber=0, bAlternateSetting=0, bNumEndpoints=2,
            bInterfaceClass=INTERFACE_CLASS, bInterfaceSubClass=INTERFACE_SUBCLASS,
            bInterfaceProtocol=PROTOCOL_VERSION, iInterface=0, extra_descriptors=[],
        )
        self.endpoints = [
            SimpleNamespace(bLength=7, bDescriptorType=5, bEndpointAddress=addr, bmAttributes=2,
                            wMaxPacketSize=512, bInterval=0, bRefresh=0, bSynchAddress=0, extra_descriptors=[])
            for addr in (EP_OUT, EP_IN)
        ]
        self.out = bytearray()  # device -> host bytes not yet read
        self.configured = 0
        self.claimed: set[int] = set()
        self.unplugged = False


class EmulatedUsbBackend(usb.backend.IBackend):
    """A pyusb backend whose bus holds emulated EDDI DAQs.

    Parameters
    ----------
    *devices : EmulatedDaq
        Firmware instances, one per emulated device.
    vid, pid : int
        USB ids every device reports.
    """

    def __init__(self, *devices: EmulatedDaq, vid: int = DEFAULT_VID, pid: int = DEFAULT_PID) -> None:
        super().__init__()
        self._lock = threading.Condition()
        self._devices = [_UsbDevice(fw, vid, pid, address=i + 1) for i, fw in enumerate(devices)]

    # ------------------------------------------------------------------ test controls
    def unplug(self, index: int = 0) -> None:
        """Pull the cable of device ``index``: every later transfer fails with ENODEV."""
        with self._lock:
            self._devices[index].unplugged = True
            self._lock.notify_all()

    def _alive(self, dev: _UsbDevice) -> None:
        if dev.unplugged:
            raise usb.core.USBError("No such device (it may have been disconnected)", -4, errno.ENODEV)

    # ------------------------------------------------------------------ enumeration
    def enumerate_devices(self):
        return [d for d in self._devices if not d.unplugged]

    def get_parent(self, dev):
        return None

    def get_device_descriptor(self, dev):
        return dev.descriptor

    def get_configuration_descriptor(self, dev, config):
        if config != 0:
            raise IndexError(f"configuration index must be 0, got {config}")
        return dev.config

    def get_interface_descriptor(self, dev, intf, alt, config):
        if (intf, alt, config) != (0, 0, 0):
            raise IndexError(f"interface (0, 0, 0) only, got {(intf, alt, config)}")
        return dev.interface

    def get_endpoint_descriptor(self, dev, ep, intf, alt, config):
        if (intf, alt, config) != (0, 0, 0) or not 0 <= ep < 2:
            raise IndexError(f"endpoint 0..1 of interface 0 only, got {ep}")
        return dev.endpoints[ep]

    # ------------------------------------------------------------------ handles
    def open_device(self, dev):
        self._alive(dev)
        return _Handle(dev)

    def close_device(self, dev_handle):
        pass

    def set_configuration(self, dev_handle, config_value):
        self._alive(dev_handle.dev)
        dev_handle.dev.configured = config_value

    def get_configuration(self, dev_handle):
        self._alive(dev_handle.dev)
        if not dev_handle.dev.configured:
            raise usb.core.USBError("Entity not found", -5, errno.ENOENT)
        return dev_handle.dev.configured

    def set_interface_altsetting(self, dev_handle, intf, altsetting):
        self._alive(dev_handle.dev)

    def claim_interface(self, dev_handle, intf):
        self._alive(dev_handle.dev)
        dev_handle.dev.claimed.add(intf)

    def release_interface(self, dev_handle, intf):
        dev_handle.dev.claimed.discard(intf)

    def is_kernel_driver_active(self, dev_handle, intf):
        return False

    def detach_kernel_driver(self, dev_handle, intf):
        pass

    def attach_kernel_driver(self, dev_handle, intf):
        pass

    def clear_halt(self, dev_handle, ep):
        pass

    def reset_device(self, dev_handle):
        pass

    # ------------------------------------------------------------------ transfers
    def ctrl_transfer(self, dev_handle, bmRequestType, bRequest, wValue, wIndex, data, timeout):
        dev = dev_handle.dev
        self._alive(dev)
        if bmRequestType & 0x80 and bRequest == _GET_DESCRIPTOR and wValue >> 8 == _DESC_STRING:
            index = wValue & 0xFF
            if index == 0:
                payload = _LANGID_EN_US.to_bytes(2, "little")
            elif index in dev.strings:
                payload = dev.strings[index].encode("utf-16-le")
            else:
                raise usb.core.USBError("Pipe error", -9, errno.EPIPE)
            desc = bytes([2 + len(payload), _DESC_STRING]) + payload
            n = min(len(desc), len(data) * data.itemsize)
            data[:n] = array.array("B", desc[:n])
            return n
        raise usb.core.USBError("Pipe error (request not supported)", -9, errno.EPIPE)

    def bulk_write(self, dev_handle, ep, intf, data, timeout):
        dev = dev_handle.dev
        with self._lock:
            self._alive(dev)
            if ep != EP_OUT:
                raise usb.core.USBError("Pipe error (not an OUT endpoint)", -9, errno.EPIPE)
            dev.out += dev.firmware.receive(bytes(data))
            self._lock.notify_all()
            return len(data)

    def bulk_read(self, dev_handle, ep, intf, buff, timeout):
        dev = dev_handle.dev
        size = len(buff) * buff.itemsize
        with self._lock:
            self._alive(dev)
            if ep != EP_IN:
                raise usb.core.USBError("Pipe error (not an IN endpoint)", -9, errno.EPIPE)
            fw = dev.firmware
            if not dev.out and fw.streaming:
                per_block = max(1, fw.block_size)
                want = max(per_block, size // max(1, 3 * len(fw.active_channels)))
                dev.out += fw.acquire(-(-want // per_block) * per_block)
            if not dev.out:
                # nothing to send: wait for a command (another thread's bulk_write) or time out
                self._lock.wait(timeout / 1000.0 if timeout else None)
                self._alive(dev)
                if not dev.out:
                    raise usb.core.USBTimeoutError("Operation timed out", -7, errno.ETIMEDOUT)
            n = min(size, len(dev.out))
            buff[:n] = array.array("B", dev.out[:n])
            del dev.out[:n]
            return n

    def intr_write(self, dev_handle, ep, intf, data, timeout):
        raise usb.core.USBError("Pipe error (no interrupt endpoint)", -9, errno.EPIPE)

    def intr_read(self, dev_handle, ep, intf, size, timeout):
        raise usb.core.USBError("Pipe error (no interrupt endpoint)", -9, errno.EPIPE)
