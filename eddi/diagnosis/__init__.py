"""The discrepancy loop: where a model's simulation departs from measurements, and why.

Modules, in the order the loop reads (``docs/diagnosis.md``):

* :mod:`~eddi.diagnosis.records`: inputs and held-out parts;
* :mod:`~eddi.diagnosis.show`, :mod:`~eddi.diagnosis.symptoms`: what a held-out simulation
  gets wrong (views, numbers, words);
* :mod:`~eddi.diagnosis.name`, :mod:`~eddi.diagnosis.catalogue` (one mechanism per module),
  :mod:`~eddi.diagnosis.chain` (measurement-chain causes), :mod:`~eddi.diagnosis.observed`
  (a second mode seen in the signal): candidates judged held out;
* :mod:`~eddi.diagnosis.extend`: fitting the baseline plus a mechanism;
* :mod:`~eddi.diagnosis.measure`: the noise floor;
* :mod:`~eddi.diagnosis.soundness`: whether the diagnosed model can be trusted as a simulation;
* :mod:`~eddi.diagnosis.loop`: :func:`diagnose`, the whole loop (one BLAS thread while it
  runs: :mod:`eddi.threads`).

Everything here is pure numerics: arrays in, a frozen :class:`Diagnosis` out.

The names below are loaded on first use (PEP 562), as :mod:`eddi`'s: ``station identify``'s
impulse check imports :mod:`eddi.diagnosis.chain` alone, which no longer runs the whole loop's
imports (``eddi.diagnosis.loop`` and its candidates, fitter, high-pass search...; ~40-50 ms of
CPU of every ``station identify`` process, session 12). ``from eddi.diagnosis import diagnose``
works as before.
"""

from __future__ import annotations

import importlib
from typing import Any

#: Public name -> submodule that defines it.
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("ALL_NAMES", "CHAIN_NAMES", "MECHANISM_NAMES"), "catalogue"),
    "diagnose": "loop",
    **dict.fromkeys(("Part", "Record"), "records"),
    **dict.fromkeys(("Candidate", "Diagnosis", "HeldOut", "NoiseFloor", "PipelineBaseline", "Score", "Symptom"),
                    "results"),
    **dict.fromkeys(("DEFAULT_CONSISTENCY", "DEFAULT_MARGIN", "FITS", "MODAL_DIAGNOSE_STIFFNESS", "NAMED_FACTOR",
                     "NONE_FACTOR", "NONE_LIMIT", "NRMSE_CAP", "REFERENCE_MARGIN"), "settings"),
    **dict.fromkeys(("backbone", "energy_per_cycle", "nmte", "nrmse", "residual_force", "spectrum"), "show"),
}

__all__ = ["ALL_NAMES", "CHAIN_NAMES", "MECHANISM_NAMES", "diagnose", "Part", "Record", "Candidate",
           "Diagnosis", "HeldOut", "NoiseFloor", "PipelineBaseline", "Score", "Symptom", "DEFAULT_CONSISTENCY",
           "DEFAULT_MARGIN", "FITS", "MODAL_DIAGNOSE_STIFFNESS", "NAMED_FACTOR", "NONE_FACTOR",
           "NONE_LIMIT", "NRMSE_CAP", "REFERENCE_MARGIN", "backbone", "energy_per_cycle", "nmte", "nrmse", "residual_force", "spectrum"]


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        try:  # a submodule not imported yet (``eddi.diagnosis.loop`` after ``import eddi.diagnosis``)
            return importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
