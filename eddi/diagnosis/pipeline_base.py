"""The pipeline's baseline for records already conditioned (what ``station diagnose`` gets).

``station diagnose`` runs :func:`station.session.run_session` on the measurements and gives
the result to :func:`~eddi.diagnosis.diagnose` as a :class:`PipelineBaseline`. Library
callers and the calibration benchmark have conditioned :class:`Record` objects instead:
:func:`pipeline_baseline` runs the same :class:`eddi.fit_record.Pipeline` on them (the record
of the median peak force fitted, the others held out), so the loop judges the same baseline
with or without the CLI.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from eddi.conditioning import ConditionedSignal
from eddi.diagnosis.records import Record
from eddi.diagnosis.results import PipelineBaseline
from eddi.terms import DEFAULT_DAMPING, DEFAULT_STIFFNESS


def conditioned_of(rec: Record) -> ConditionedSignal:
    """The conditioned signal a record was built from (its fields, no copy)."""
    return ConditionedSignal(t=rec.t, x=rec.x, v=rec.v, a=rec.a, force=rec.force, rate_hz=rec.rate_hz,
                             free_start=rec.free_start, free_stop=rec.free_stop, method="",
                             impact_start=rec.impact_start, impact_end=rec.impact_end,
                             noise_rms=rec.noise_rms, force_noise_rms=rec.force_noise_rms,
                             acc_measured=rec.acc_measured, response=rec.response or "acc")


def fit_index(records: Sequence[Record]) -> int:
    """The record of the median peak force (lower middle), as
    :func:`station.session.choose_fit_index`; the first without force channels."""
    if any(r.force is None for r in records):
        return 0
    peaks = [float(np.max(np.abs(r.force))) for r in records]
    order = sorted(range(len(peaks)), key=lambda i: peaks[i])
    return order[(len(order) - 1) // 2]


def pipeline_baseline(records: Sequence[Record], mass: float, *,
                      damping: str | Sequence[str] = DEFAULT_DAMPING,
                      stiffness: str | Sequence[str] = DEFAULT_STIFFNESS,
                      refine: bool = True) -> PipelineBaseline:
    """The pipeline's model and held-out error on conditioned records.

    Raises
    ------
    EddiError
        As :meth:`eddi.fit_record.Pipeline.fit`.
    """
    from eddi.fit_record import Pipeline

    conds = [conditioned_of(r) for r in records]
    k = fit_index(records)
    others = [i for i in range(len(records)) if i != k]
    fit = Pipeline.create(damping, stiffness, refine=refine).fit(conds[k], mass,
                                                                 held_out=[conds[i] for i in others])
    held = {i: float(v.nrmse) for i, v in zip(others, fit.held_out)}
    nrmse = float(np.mean(list(held.values()))) if held else float(fit.validation.nrmse)
    choices = fit.choices.as_dict() if fit.choices is not None else {}
    return PipelineBaseline(model=fit.model.eom, nrmse=nrmse, fit_record=k, held_out=held, choices=choices)
