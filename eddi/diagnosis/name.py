"""Name: every mechanism refitted on the training parts and judged on the held-out ones.

The step of the loop that names a cause, in four modules with one job each (session 9; this
module re-exports them, the names callers import from it):

* :mod:`~eddi.diagnosis.fitter`: the fits of one fold (:class:`Fitter`, :class:`FoldFitter`,
  the pipeline's refinement policy :func:`refined_baseline`);
* :mod:`~eddi.diagnosis.folds`: the folds run (:func:`judge_baseline`,
  :func:`judge_candidates`, :func:`refine_candidates`, :class:`FoldResults`);
* :mod:`~eddi.diagnosis.candidates`: fold results as ranked
  :class:`~eddi.diagnosis.results.Candidate` rows (:func:`build_candidates`, :func:`rank`);
* :mod:`~eddi.diagnosis.decide`: the verdict against the noise floor (:func:`decide`,
  :class:`Decision`, :func:`lookalike_fails`).
"""

from eddi.diagnosis.candidates import UNREFINED, build_candidates, observed_candidate, rank, spread_of
from eddi.diagnosis.decide import Decision, decide, lookalike_fails, within_floor
from eddi.diagnosis.fitter import Fitter, FoldFitter, all_masks, refine_start, refined_baseline
from eddi.diagnosis.folds import (
    FoldResults, check_trainable, final_fits, judge_baseline, judge_candidates, refine_candidates,
)

__all__ = ["UNREFINED", "Decision", "Fitter", "FoldFitter", "FoldResults", "all_masks", "build_candidates",
           "check_trainable", "decide", "final_fits", "judge_baseline", "judge_candidates", "lookalike_fails",
           "observed_candidate", "rank", "refine_candidates", "refine_start", "refined_baseline", "spread_of",
           "within_floor"]
