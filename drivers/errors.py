"""Errors raised by the drivers. Every one subclasses :class:`DriverError`."""

from __future__ import annotations


class DriverError(Exception):
    """Root of every error the ``drivers`` package raises on purpose."""
