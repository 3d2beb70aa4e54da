"""Whether the model a diagnosis stands behind can be trusted as a simulation.

The model is the extended one when a mechanism is named, else the baseline. It is flagged when
its simulation diverged on a held-out part or when it has a negative stiffness or damping along
the held-out records (:func:`eddi.stability.model_warnings`, the check ``station identify``
applies to its model).
"""

from __future__ import annotations

from eddi.diagnosis.results import Diagnosis
from eddi.diagnosis.settings import NRMSE_CAP
from eddi.model import EquationOfMotion
from eddi.stability import model_warnings


def model_flags(diag: Diagnosis) -> tuple[str, ...]:
    """Why the diagnosed model is unsound, one sentence each (empty when it is sound).

    Parameters
    ----------
    diag : Diagnosis

    Returns
    -------
    tuple of str
    """
    named = diag.cause not in ("none", "unexplained")
    which = "extended" if named else "baseline"
    score = diag.extended if named else diag.baseline
    out: list[str] = []
    # a diverged simulation's held-out nrmse is capped at NRMSE_CAP (eddi.diagnosis.show.nrmse):
    # `== inf` never held, and `station diagnose --model` with a model whose simulation diverges
    # exited 0 where `station validate` of the same model on the same capture exits 1 (session 19)
    if not score.nrmse < NRMSE_CAP or any(not v < NRMSE_CAP for v in score.fold_nrmse):
        out.append(f"the {which} model's simulation diverged on a held-out part (held-out nrmse at the "
                   f"cap {NRMSE_CAP:g})")
    if isinstance(score.model, EquationOfMotion):
        seen: set[str] = set()
        for h in diag.held_out:
            if h.v_measured is None:
                continue
            for w in model_warnings(score.model, h.x_measured, h.v_measured):
                if w not in seen:
                    seen.add(w)
                    out.append(f"{which} model, part {h.part.label}: {w}")
    return tuple(out)
