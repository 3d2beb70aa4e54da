"""Byte transports under the DAQ driver, chosen by URL.

A transport moves bytes and nothing else: :meth:`Transport.read` returns what arrived within a
timeout (``b""`` if nothing), :meth:`Transport.write` sends, and both raise
:class:`~drivers.errors.DeviceGoneError` once the device has disappeared.

URLs
----
``serial:///dev/ttyACM0?baudrate=921600``
    A serial port (the path after ``serial://``), pyserial options as query parameters.
``loop://``, ``socket://host:port``, ``rfc2217://host:port``, ``spy://...``
    pyserial's own URL handlers, passed through unchanged.
``usb://VID:PID[/SERIAL]``
    A USB device speaking the protocol over bulk endpoints (pyusb, see :mod:`drivers.usb`).
"""

from __future__ import annotations

import abc
import urllib.parse

import serial

from drivers.errors import BadUrlError, DeviceGoneError, DeviceNotFoundError

#: Schemes pyserial handles itself (``serial.serial_for_url``).
PYSERIAL_SCHEMES = ("loop", "socket", "rfc2217", "spy", "hwgrep", "alt", "cp2110")

#: Serial options accepted in a ``serial://`` query, with their types.
SERIAL_OPTIONS = {"baudrate": int, "bytesize": int, "parity": str, "stopbits": float, "rtscts": bool, "xonxoff": bool}


class Transport(abc.ABC):
    """A bidirectional byte pipe to one device."""

    #: The URL it was opened from.
    url: str

    @abc.abstractmethod
    def read(self, max_bytes: int, timeout_s: float) -> bytes:
        """Bytes that arrived, at most ``max_bytes``, waiting at most about ``timeout_s`` [s]."""

    @abc.abstractmethod
    def write(self, data: bytes) -> None:
        """Send all of ``data``."""

    @abc.abstractmethod
    def close(self) -> None:
        """Release the device (idempotent)."""

    def flush_input(self) -> None:
        """Drop bytes already received and not read (default: nothing to do)."""


class SerialTransport(Transport):
    """A pyserial port: a real serial port, a pty, or one of pyserial's URL handlers.

    Parameters
    ----------
    port : serial.SerialBase
        An open port; its read timeout is set here.
    url : str
    """

    POLL_S = 0.02

    def __init__(self, port: serial.SerialBase, url: str) -> None:
        self.port = port
        self.url = url
        self.port.timeout = self.POLL_S
        self.port.write_timeout = 2.0

    def read(self, max_bytes: int, timeout_s: float) -> bytes:
        try:
            waiting = self.port.in_waiting
            if waiting:
                return self.port.read(min(waiting, max_bytes))
            data = self.port.read(1)
            if data:
                more = self.port.in_waiting
                if more:
                    data += self.port.read(min(more, max_bytes - 1))
            return data
        except (serial.SerialException, OSError, TypeError, AttributeError) as exc:
            # pyserial raises TypeError/AttributeError when the port was closed under it
            raise DeviceGoneError(f"{self.url}: device gone while reading ({exc})") from None

    def write(self, data: bytes) -> None:
        try:
            self.port.write(data)
        except (serial.SerialException, OSError) as exc:
            raise DeviceGoneError(f"{self.url}: device gone while writing ({exc})") from None

    def flush_input(self) -> None:
        try:
            self.port.reset_input_buffer()
        except (serial.SerialException, OSError) as exc:
            raise DeviceGoneError(f"{self.url}: device gone ({exc})") from None

    def close(self) -> None:
        try:
            self.port.close()
        except (serial.SerialException, OSError):
            pass


def parse_serial_url(url: str) -> tuple[str, dict[str, object]]:
    """``serial:///dev/ttyACM0?baudrate=9600`` -> (``/dev/ttyACM0``, {``baudrate``: 9600}).

    Raises
    ------
    BadUrlError
        On a missing path or an unknown or badly typed option.
    """
    parts = urllib.parse.urlsplit(url)
    path = (parts.netloc + parts.path) if parts.netloc else parts.path
    if not path:
        raise BadUrlError(f"expected serial:///path/to/port[?baudrate=N], got {url!r}")
    options: dict[str, object] = {}
    for key, value in urllib.parse.parse_qsl(parts.query, keep_blank_values=True):
        kind = SERIAL_OPTIONS.get(key)
        if kind is None:
            raise BadUrlError(f"unknown serial option {key!r} in {url!r}; expected one of {sorted(SERIAL_OPTIONS)}")
        try:
            options[key] = value.lower() in ("1", "true", "yes") if kind is bool else kind(value)
        except ValueError:
            raise BadUrlError(f"serial option {key} must be {kind.__name__}, got {value!r} in {url!r}") from None
    return path, options


def open_transport(url: str, *, usb_backend: object = None) -> Transport:
    """Open the transport a URL names.

    ``usb_backend`` is a pyusb backend for ``usb://`` URLs (default libusb 1.0).

    Raises
    ------
    BadUrlError
        When the URL's scheme or form is not understood.
    DeviceNotFoundError
        When nothing is at that address.
    """
    if not isinstance(url, str) or "://" not in url:
        raise BadUrlError(f"expected a device URL such as serial:///dev/ttyACM0 or usb://16c0:0486, got {url!r}")
    scheme = url.split("://", 1)[0].lower()
    if scheme == "usb":
        from drivers.usb import open_usb_transport

        return open_usb_transport(url, backend=usb_backend)
    if scheme == "serial":
        path, options = parse_serial_url(url)
        try:
            port = serial.Serial(path, **options)  # type: ignore[arg-type]
        except ValueError as exc:
            raise BadUrlError(f"{url}: {exc}") from None
        except (serial.SerialException, OSError) as exc:
            raise DeviceNotFoundError(f"no serial port at {path} ({_reason(exc)})") from None
        return SerialTransport(port, url)
    if scheme in PYSERIAL_SCHEMES:
        try:
            port = serial.serial_for_url(url)
        except ValueError as exc:
            raise BadUrlError(f"{url}: {exc}") from None
        except (serial.SerialException, OSError) as exc:
            raise DeviceNotFoundError(f"nothing answers at {url} ({_reason(exc)})") from None
        return SerialTransport(port, url)
    raise BadUrlError(
        f"unknown device URL scheme {scheme!r} in {url!r}; expected serial://, usb://, sim:// "
        f"or one of pyserial's {', '.join(s + '://' for s in PYSERIAL_SCHEMES)}"
    )


def _reason(exc: BaseException) -> str:
    text = str(exc).strip() or type(exc).__name__
    return text.splitlines()[0]
