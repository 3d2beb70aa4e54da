"""EDDI: energy-based dual-phase dynamics identification (pure numerics, no I/O)."""

from eddi.errors import EddiError, IdentificationError, ModelError, SignalError, TermError
from eddi.identify import IdentifiedModel, identify
from eddi.model import EFFECTS, Effect, EquationOfMotion
from eddi.simulate import SimulationResult, simulate
from eddi.phase_one import PhaseOneResult
from eddi.phase_two import PhaseTwoResult
from eddi.terms import DEFAULT_DAMPING, DEFAULT_STIFFNESS, Term, parse_term, parse_terms
from eddi.validate import Validation, cwt_map, spectra, validate

__all__ = [
    "DEFAULT_DAMPING", "DEFAULT_STIFFNESS", "EFFECTS", "EddiError", "Effect", "EquationOfMotion",
    "IdentificationError", "IdentifiedModel", "ModelError", "PhaseOneResult", "PhaseTwoResult",
    "SignalError", "SimulationResult", "Term", "TermError", "Validation", "cwt_map", "identify",
    "parse_term", "parse_terms", "simulate", "spectra", "validate",
]
