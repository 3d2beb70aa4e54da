"""Errors raised by the station. Every one subclasses :class:`StationError`.

The lower layers have their own roots (``eddi.errors.EddiError``,
``drivers.errors.DriverError``, ``simulated_rig.errors.RigError``) because they import
nothing from the project; the CLI turns any of them into a one-line message and exit code 2
(see :data:`station.cli.USER_ERROR_ROOTS`).
"""

from __future__ import annotations


class StationError(Exception):
    """Root of every error the ``station`` package raises on purpose."""


class InputFileError(StationError, ValueError):
    """A data file cannot be read or does not hold what is needed."""


class CaptureFormatError(InputFileError):
    """An HDF5 capture file is foreign, damaged, or of an unsupported schema version."""


class ConfigError(StationError, ValueError):
    """A configuration file or option is invalid (the message names the field)."""
