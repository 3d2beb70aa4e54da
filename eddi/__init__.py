"""EDDI: energy-based dual-phase dynamics identification (pure numerics, no I/O).

The public names below are imported lazily (PEP 562), so that ``import eddi.errors`` (which
the CLI does at start-up) does not pay for scipy and numba.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS: dict[str, str] = {
    "EddiError": "eddi.errors", "IdentificationError": "eddi.errors", "ModelError": "eddi.errors",
    "SignalError": "eddi.errors", "TermError": "eddi.errors",
    "IdentifiedModel": "eddi.identify", "identify": "eddi.identify",
    "EFFECTS": "eddi.model", "Effect": "eddi.model", "EquationOfMotion": "eddi.model",
    "SimulationResult": "eddi.simulate", "simulate": "eddi.simulate",
    "PhaseOneResult": "eddi.phase_one", "PhaseTwoResult": "eddi.phase_two",
    "DEFAULT_DAMPING": "eddi.terms", "DEFAULT_STIFFNESS": "eddi.terms", "Term": "eddi.terms",
    "parse_term": "eddi.terms", "parse_terms": "eddi.terms",
    "Validation": "eddi.validate", "cwt_map": "eddi.validate", "spectra": "eddi.validate",
    "validate": "eddi.validate",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'eddi' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


def __dir__() -> list[str]:
    return __all__
