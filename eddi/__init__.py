"""EDDI: energy-based dual-phase dynamics identification (pure numerics, no I/O).

The names below are loaded on first use (PEP 562), so ``import eddi.terms`` (numpy only) does
not pay for scipy, numba and pydantic: a command's ``--help`` and ``station identify`` import
only the modules they use (issue 13). ``from eddi import simulate`` works as before.
"""

from __future__ import annotations

import importlib
import types
from typing import Any

#: Public name -> module that defines it.
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("EddiError", "IdentificationError", "ModelError", "SignalError", "TermError"), "eddi.errors"),
    **dict.fromkeys(("IdentifiedModel", "identify"), "eddi.identify"),
    **dict.fromkeys(("EFFECTS", "Effect", "EquationOfMotion"), "eddi.model"),
    **dict.fromkeys(("SimulationResult", "simulate"), "eddi.simulate"),
    "PhaseOneResult": "eddi.phase_one",
    "PhaseTwoResult": "eddi.phase_two",
    **dict.fromkeys(("DEFAULT_DAMPING", "DEFAULT_STIFFNESS", "Term", "parse_term", "parse_terms"), "eddi.terms"),
    **dict.fromkeys(("Validation", "cwt_map", "spectra", "validate"), "eddi.validate"),
}

__all__ = sorted(_EXPORTS)

def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'eddi' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))


class _Function:
    """``eddi.identify`` / ``eddi.simulate`` / ``eddi.validate`` are the functions, not the
    submodules of the same name (as when this package imported them eagerly): the import
    system's binding of the submodule onto the package is ignored."""

    def __init__(self, name: str) -> None:
        self.name = name

    def __get__(self, obj: Any, owner: Any = None) -> Any:
        if obj is None:
            return self
        return getattr(importlib.import_module(f"eddi.{self.name}"), self.name)

    def __set__(self, obj: Any, value: Any) -> None:
        if not isinstance(value, types.ModuleType):  # a submodule bound by the import system: keep the function
            raise AttributeError(f"eddi.{self.name} is read-only")


class _Package(types.ModuleType):
    identify = _Function("identify")
    simulate = _Function("simulate")
    validate = _Function("validate")


import sys as _sys  # noqa: E402

_sys.modules[__name__].__class__ = _Package
