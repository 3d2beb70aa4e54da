"""USB transport (pyusb): the protocol's byte stream over two bulk endpoints.

A device speaking the protocol over USB has a vendor-specific interface
(class 0xFF, subclass :data:`INTERFACE_SUBCLASS`, protocol = the protocol version) with a bulk
OUT endpoint for command frames and a bulk IN endpoint for replies and the sample stream;
the bytes are exactly those of the serial link (``docs/protocol.md``).

URLs: ``usb://VID:PID`` or ``usb://VID:PID/SERIAL`` (hexadecimal ids, e.g. ``usb://1209:edd1``).
The backend is libusb 1.0 (through ``libusb_package`` when installed) unless one is handed in,
which is how tests run this exact code path over the emulated device
(:class:`simulated_rig.usb.EmulatedUsbBackend`).
"""

from __future__ import annotations

import errno
import re
from dataclasses import dataclass
from typing import Any

import usb.core
import usb.util

from drivers.errors import BadUrlError, DeviceGoneError, DeviceNotFoundError
from drivers.protocol import PROTOCOL_VERSION
from drivers.transport import Transport

#: Default ids of the EDDI DAQ (pid.codes open-source vendor id).
DEFAULT_VID, DEFAULT_PID = 0x1209, 0xEDD1
#: Interface class/subclass that mark a device speaking the protocol.
INTERFACE_CLASS, INTERFACE_SUBCLASS = 0xFF, 0xED
EP_OUT, EP_IN = 0x01, 0x81

_URL = re.compile(r"^usb://([0-9a-fA-F]{1,4}):([0-9a-fA-F]{1,4})(?:/([^/?#]+))?/?$")
_GONE_ERRNOS = {errno.ENODEV, errno.EIO, errno.EPIPE, errno.ESHUTDOWN, errno.ENOENT}


def parse_usb_url(url: str) -> tuple[int, int, str | None]:
    """``usb://1209:edd1/SN42`` -> (0x1209, 0xEDD1, "SN42").

    Raises
    ------
    BadUrlError
    """
    m = _URL.match(url)
    if m is None:
        raise BadUrlError(f"expected usb://VID:PID[/SERIAL] with hexadecimal ids, got {url!r}")
    return int(m.group(1), 16), int(m.group(2), 16), m.group(3)


def default_backend() -> Any:
    """The libusb 1.0 backend (from ``libusb_package`` if installed), or None."""
    try:
        import libusb_package

        return libusb_package.get_libusb1_backend()
    except ImportError:  # pragma: no cover - depends on the installation
        import usb.backend.libusb1

        return usb.backend.libusb1.get_backend()


def speaks_protocol(dev: usb.core.Device) -> bool:
    """True when one interface of the active (or first) configuration is an EDDI DAQ interface."""
    try:
        cfg = dev[0]
    except (usb.core.USBError, IndexError, NotImplementedError):
        return False
    return any(
        intf.bInterfaceClass == INTERFACE_CLASS and intf.bInterfaceSubClass == INTERFACE_SUBCLASS for intf in cfg
    )


@dataclass(frozen=True)
class UsbDeviceEntry:
    """One USB device that speaks the protocol (for ``station devices``)."""

    url: str
    vid: int
    pid: int
    serial: str | None
    product: str | None
    protocol_version: int


def list_usb_devices(backend: Any = None) -> list[UsbDeviceEntry]:
    """USB devices with an EDDI DAQ interface (empty when there is no libusb)."""
    backend = backend if backend is not None else default_backend()
    if backend is None:
        return []
    found = []
    try:
        devices = list(usb.core.find(find_all=True, backend=backend, custom_match=speaks_protocol))
    except (usb.core.USBError, usb.core.NoBackendError):
        return []
    for dev in devices:
        serial = _string(dev, "serial_number")
        intf = next(i for i in dev[0] if i.bInterfaceSubClass == INTERFACE_SUBCLASS)
        url = f"usb://{dev.idVendor:04x}:{dev.idProduct:04x}" + (f"/{serial}" if serial else "")
        found.append(UsbDeviceEntry(url, dev.idVendor, dev.idProduct, serial, _string(dev, "product"),
                                    int(intf.bInterfaceProtocol)))
    return found


def _string(dev: usb.core.Device, attr: str) -> str | None:
    try:
        return getattr(dev, attr)
    except (usb.core.USBError, ValueError, NotImplementedError):
        return None


class UsbTransport(Transport):
    """Bulk IN/OUT endpoints of a claimed pyusb device.

    Parameters
    ----------
    dev : usb.core.Device
    url : str
    """

    def __init__(self, dev: usb.core.Device, url: str) -> None:
        self.dev = dev
        self.url = url
        self._closed = False
        try:
            try:
                dev.get_active_configuration()
            except usb.core.USBError:
                dev.set_configuration()
            cfg = dev.get_active_configuration()
            intf = usb.util.find_descriptor(
                cfg, bInterfaceClass=INTERFACE_CLASS, bInterfaceSubClass=INTERFACE_SUBCLASS
            )
            if intf is None:
                raise DeviceNotFoundError(f"{url}: the device has no EDDI DAQ interface (class ff, subclass ed)")
            self.interface = intf.bInterfaceNumber
            if intf.bInterfaceProtocol != PROTOCOL_VERSION:
                from drivers.errors import ProtocolVersionError

                raise ProtocolVersionError(
                    f"{url}: device speaks protocol version {intf.bInterfaceProtocol}, "
                    f"this driver speaks version {PROTOCOL_VERSION}"
                )
            usb.util.claim_interface(dev, self.interface)
        except usb.core.USBError as exc:
            raise DeviceNotFoundError(f"{url}: cannot claim the device ({exc.strerror or exc})") from None

    def read(self, max_bytes: int, timeout_s: float) -> bytes:
        try:
            return bytes(self.dev.read(EP_IN, max_bytes, timeout=max(1, int(timeout_s * 1000))))
        except usb.core.USBTimeoutError:
            return b""
        except usb.core.USBError as exc:
            if exc.errno == errno.ETIMEDOUT:
                return b""
            raise DeviceGoneError(f"{self.url}: device gone while reading ({exc.strerror or exc})") from None

    def write(self, data: bytes) -> None:
        try:
            self.dev.write(EP_OUT, data, timeout=2000)
        except usb.core.USBError as exc:
            raise DeviceGoneError(f"{self.url}: device gone while writing ({exc.strerror or exc})") from None

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            usb.util.release_interface(self.dev, self.interface)
        except (usb.core.USBError, AttributeError):
            pass
        try:
            usb.util.dispose_resources(self.dev)
        except usb.core.USBError:
            pass


def open_usb_transport(url: str, backend: Any = None) -> UsbTransport:
    """Find and claim the device a ``usb://`` URL names.

    Raises
    ------
    BadUrlError, DeviceNotFoundError
    """
    vid, pid, serial = parse_usb_url(url)
    backend = backend if backend is not None else default_backend()
    if backend is None:
        raise DeviceNotFoundError(f"{url}: no libusb backend found (pip install libusb-package)")

    def match(dev: usb.core.Device) -> bool:
        return serial is None or _string(dev, "serial_number") == serial

    try:
        dev = usb.core.find(idVendor=vid, idProduct=pid, backend=backend, custom_match=match)
    except usb.core.USBError as exc:
        raise DeviceNotFoundError(f"{url}: cannot enumerate USB devices ({exc.strerror or exc})") from None
    if dev is None:
        what = f"{vid:04x}:{pid:04x}" + (f" with serial {serial}" if serial else "")
        raise DeviceNotFoundError(f"no USB device {what} is connected")
    return UsbTransport(dev, url)
