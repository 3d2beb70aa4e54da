"""Former home of the mechanism catalogue; kept so existing imports work.

The catalogue lives in :mod:`eddi.diagnosis.catalogue` (one mechanism per module).
"""

from eddi.diagnosis.catalogue import (  # noqa: F401
    ALL_NAMES, CHAIN_NAMES, MECHANISM_NAMES, Context, Mechanism, MechanismFit, Signal, catalogue, extend,
)
