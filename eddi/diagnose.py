"""Former home of the discrepancy loop; kept so existing imports work.

The loop lives in :mod:`eddi.diagnosis` (one small module per step).
"""

from eddi.diagnosis import *  # noqa: F401,F403
from eddi.diagnosis import __all__  # noqa: F401
