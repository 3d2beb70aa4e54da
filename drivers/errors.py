"""Errors raised by the drivers. Every one subclasses :class:`DriverError`."""

from __future__ import annotations


class DriverError(Exception):
    """Root of every error the ``drivers`` package raises on purpose."""


class ProtocolError(DriverError, IOError):
    """The bytes from the device do not follow the wire protocol (see ``docs/protocol.md``)."""


class ProtocolVersionError(ProtocolError):
    """The device speaks a protocol version this driver does not understand."""


class DeviceError(DriverError, RuntimeError):
    """The device understood a command and refused it (its message says why)."""


class DeviceTimeoutError(DriverError, TimeoutError):
    """The device did not answer within the allotted time."""


class DeviceGoneError(DriverError, ConnectionError):
    """The device disappeared (port closed, cable pulled, USB error) while in use."""


class DeviceNotFoundError(DriverError, FileNotFoundError):
    """No device answers at the given address."""


class BadUrlError(DriverError, ValueError):
    """A device URL cannot be understood (the message shows the expected form)."""
