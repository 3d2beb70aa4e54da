"""Errors raised by the EDDI engine.

Every error subclasses :class:`EddiError` and the built-in exception it resembles, so a
caller's generic ``except ValueError`` still works.
"""

from __future__ import annotations


class EddiError(Exception):
    """Root of every error the ``eddi`` package raises on purpose."""


class TermError(EddiError, ValueError):
    """A candidate term could not be parsed (the message names the term)."""


class ModelError(EddiError, ValueError):
    """An equation of motion is invalid (bad mass, unknown effect, bad parameter)."""


class SignalError(EddiError, ValueError):
    """A measured signal cannot be used (NaN, non-uniform time, too short, clipped...)."""


class IdentificationError(EddiError, ValueError):
    """Identification failed (too few zero crossings, singular system...)."""


class TooShortToRefine(IdentificationError):
    """The window holds too few compared values for the output-error refinement (EDDI's
    estimate stands: :meth:`eddi.fit_record.Pipeline.fit` keeps it with refinement ``"off"``)."""
