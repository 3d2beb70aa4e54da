"""The default candidate terms of the paper's experiments, without the term machinery.

Kept apart from :mod:`eddi.terms` (which imports numpy) so that a command's ``--help`` can show
them without loading numpy; :mod:`eddi.terms` re-exports both names.
"""

from __future__ import annotations

#: Default damping library of the paper's experiments (Eqs. 21, 24).
DEFAULT_DAMPING: tuple[str, ...] = ("v", "x^2*v", "v^3")
#: Default stiffness library of the paper (Eqs. 22, 25).
DEFAULT_STIFFNESS: tuple[str, ...] = ("x", "x^2", "x^3", "x^4", "x^5")
