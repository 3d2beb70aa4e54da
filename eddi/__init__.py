"""EDDI: energy-based dual-phase dynamics identification (pure numerics, no I/O)."""

from eddi.errors import EddiError, IdentificationError, ModelError, SignalError, TermError
from eddi.model import EFFECTS, Effect, EquationOfMotion
from eddi.simulate import SimulationResult, simulate
from eddi.terms import DEFAULT_DAMPING, DEFAULT_STIFFNESS, Term, parse_term, parse_terms

__all__ = [
    "DEFAULT_DAMPING", "DEFAULT_STIFFNESS", "EFFECTS", "EddiError", "Effect", "EquationOfMotion",
    "IdentificationError", "ModelError", "SignalError", "SimulationResult", "Term", "TermError",
    "parse_term", "parse_terms", "simulate",
]
