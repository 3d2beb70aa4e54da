"""A name must predict every held-out part at least as well as the baseline as judged.

Blind unseen7 (session 11): a heavy, noisy null whose judged baseline folds were 0.061 / 0.039 /
0.063 / 0.07 / 0.806 (one fold's refinement rejected) got `second_mode` named: 0.044 / 0.037 /
0.181 / 0.055 / 0.090, a 61 % cut of the mean and better than its own reference (the
equation-error fits) on every part, yet 2.9x worse than the baseline on the third part.
"""

from __future__ import annotations

from eddi.diagnosis.decide import decide
from eddi.diagnosis.results import Candidate, NoiseFloor
from eddi.model import EquationOfMotion

MODEL = EquationOfMotion.create(mass=482.0, damping={"v": 300.0}, stiffness={"x": 2.0e6})
BASE = (0.061, 0.039, 0.063, 0.07, 0.806)
FLOOR = NoiseFloor(nrmse=0.19, fold_nrmse=(0.19,) * 5, noise_rms=(0,) * 5, conditioning_nrmse=(0,) * 5,
                   method="test")


def _cand(folds: tuple[float, ...]) -> Candidate:
    mean = sum(folds) / len(folds)
    return Candidate("second_mode", mean, folds, 0.55, True, True, {"mass_kg": 10.0}, {"mass_kg": 0.1}, MODEL,
                     "s", reference="equation-error baseline", reference_nrmse=0.6)


def test_a_candidate_worse_on_one_part_is_not_named() -> None:
    dec = decide([_cand((0.044, 0.037, 0.181, 0.055, 0.090))], BASE, FLOOR, 0.5, 3.5, 10.0, strong_margin=0.6)
    assert dec.cause == "none"  # within the factor of the floor; named before the rule
    above = NoiseFloor(nrmse=0.05, fold_nrmse=(0.05,) * 5, noise_rms=(0,) * 5, conditioning_nrmse=(0,) * 5,
                       method="test")  # above the factor: unexplained, saying why
    dec = decide([_cand((0.044, 0.037, 0.181, 0.055, 0.090))], BASE, above, 0.5, 3.5, 10.0)
    assert dec.cause == "unexplained"
    assert "predicts held-out part 3 worse than the baseline as judged (0.181 against 0.063)" in dec.reason


def test_one_better_on_every_part_still_is() -> None:
    dec = decide([_cand((0.044, 0.037, 0.060, 0.055, 0.090))], BASE, FLOOR, 0.5, 3.5, 10.0, strong_margin=0.6)
    assert dec.cause == "second_mode"
