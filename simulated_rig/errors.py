"""Errors raised by the simulated rig. Every one subclasses :class:`RigError`."""

from __future__ import annotations


class RigError(Exception):
    """Root of every error the ``simulated_rig`` package raises on purpose."""


class ScenarioError(RigError, ValueError):
    """A scenario file or system description is invalid (the message names the field)."""


class EmulatorError(RigError, OSError):
    """The firmware emulator (QEMU, the ARM toolchain) is missing or failed to start."""
