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
"""

from eddi.diagnosis.catalogue import ALL_NAMES, CHAIN_NAMES, MECHANISM_NAMES
from eddi.diagnosis.loop import diagnose
from eddi.diagnosis.records import Part, Record
from eddi.diagnosis.results import (
    Candidate, Diagnosis, HeldOut, NoiseFloor, PipelineBaseline, Score, Symptom,
)
from eddi.diagnosis.settings import (
    DEFAULT_CONSISTENCY, DEFAULT_MARGIN, FITS, MODAL_DIAGNOSE_STIFFNESS, NAMED_FACTOR, NONE_FACTOR,
    NRMSE_CAP, REFERENCE_MARGIN,
)
from eddi.diagnosis.show import backbone, energy_per_cycle, nmte, nrmse, residual_force, spectrum

__all__ = ["ALL_NAMES", "CHAIN_NAMES", "MECHANISM_NAMES", "diagnose", "Part", "Record", "Candidate",
           "Diagnosis", "HeldOut", "NoiseFloor", "PipelineBaseline", "Score", "Symptom", "DEFAULT_CONSISTENCY",
           "DEFAULT_MARGIN", "FITS", "MODAL_DIAGNOSE_STIFFNESS", "NAMED_FACTOR", "NONE_FACTOR",
           "NRMSE_CAP", "REFERENCE_MARGIN", "backbone", "energy_per_cycle", "nmte", "nrmse", "residual_force", "spectrum"]
