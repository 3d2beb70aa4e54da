"""A weak nonlinear coupling named within the baseline's allowance: excess gain with a strong cut.

:func:`eddi.mdof.verdict.coupling_earned` names ``modal_coupling`` when the coupled model's
held-out gain exceeds the margin, or (s12two) when the baseline cannot be called complete and
the coupled model removes more than the margin of the error above the floor. Between the two
sits a weak coupling: the baseline within its allowance (every channel <= ``NONE_FACTOR`` x its
floor) but clearly above the floor, the coupled model at the floor. Blind unseen7 M1 (session 12):
a two-mass chain with a weak cubic coupling spring, baseline 1.7-2.2x the per-channel floors,
coupled near the floors, raw gain 45 % (< 50 %): ``none``, the coupling not found.

The rule (every part must hold; thresholds calibrated in session 13 on the tuning half of
``benchmarks/bench_mdof_nulls.py``, see docs/multi-dof.md):

- the baseline is above :data:`BASE_OVER` x the floor on every channel (a null's baseline sits
  near the floor on at least one channel: a ratio of two numbers at the floor is noise);
- the coupled model is within :data:`COUPLED_WITHIN` x the floor on every channel: the allowance a
  ``none`` needs of the baseline (``NONE_FACTOR``), so the coupled model would be called complete;
- the coupled model is better on all held-out folds but at most :data:`WORSE_FOLDS` (and on more
  than half): the fold holding out the largest blow extrapolates in amplitude, where a weak cubic
  trained on smaller blows can lose (session 11's 28 N fold);
- the excess gain (:func:`eddi.mdof.verdict.excess_gain`) exceeds the margin;
- and, once the coupled model is identified on every capture, one nonlinear coupling coefficient
  is determined at :data:`COEFFICIENT_Z` x its 95 % half-width (:func:`strongest_coupling`);
  without intervals the rule does not name.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from eddi.diagnosis.settings import NONE_FACTOR

#: The baseline's held-out nrmse over the channel's floor, least over the channels (module notes).
BASE_OVER = 1.5
#: The coupled model's held-out nrmse over the channel's floor, most over the channels.
COUPLED_WITHIN = NONE_FACTOR
#: A nonlinear coupling coefficient's value over its 95 % half-width, the strongest one: twice the
#: determined-coefficient rule's 1 (:func:`eddi.mdof.verdict.undetermined_coupling`), a strong cut.
COEFFICIENT_Z = 2.0
#: Held-out folds on which the coupled model may be worse than the baseline.
WORSE_FOLDS = 1


@dataclass(frozen=True)
class Allowance:
    """The evidence of the within-allowance rule (module notes) on one diagnosis.

    Attributes
    ----------
    earned : bool
        Every held-out part of the rule holds (the coefficient is judged later).
    excess_gain : float
        :func:`eddi.mdof.verdict.excess_gain` of the folds (NaN when a fold is not finite).
    base_over : float
        Least over the channels of the baseline's held-out nrmse / floor.
    coupled_over : float
        Most over the channels of the coupled model's held-out nrmse / floor.
    worse_folds : int
        Folds on which the coupled model is not better than the baseline.
    """

    earned: bool
    excess_gain: float
    base_over: float
    coupled_over: float
    worse_folds: int

    def as_dict(self) -> dict:
        return {"earned": self.earned, "excess_gain": self.excess_gain, "base_over": self.base_over,
                "coupled_over": self.coupled_over, "worse_folds": self.worse_folds}

    def note(self, raw_gain: float, margin: float) -> str:
        return (f"within the baseline's allowance, the coupled model removes {100 * self.excess_gain:.0f} % of the "
                f"error above the floor held out (raw gain {100 * raw_gain:.0f} %, margin {100 * margin:.0f} %): the "
                f"baseline is {self.base_over:.2g}x or more above every channel's floor, the coupled model within "
                f"{self.coupled_over:.2g}x, worse on {self.worse_folds} of the folds")


def within_allowance(baseline: Sequence[float], coupled: Sequence[float], fold_floors: Sequence[float],
                     baseline_channels: Mapping[str, float], coupled_channels: Mapping[str, float],
                     channel_floors: Mapping[str, float], margin: float) -> Allowance:
    """The held-out parts of the rule (module notes): folds' nrmse of each kind with each held-out
    capture's floor, per-channel means of each kind with the channels' floors."""
    from eddi.mdof.verdict import excess_gain

    names = list(channel_floors)
    fl = np.array([float(channel_floors[c]) for c in names])
    b = np.array([float(baseline_channels[c]) for c in names]) / fl
    c = np.array([float(coupled_channels[c]) for c in names]) / fl
    base_over = float(np.min(b)) if np.all(np.isfinite(b)) else float("nan")
    coupled_over = float(np.max(c)) if np.all(np.isfinite(c)) else float("inf")
    worse = sum(not float(cc) < float(bb) for bb, cc in zip(baseline, coupled)) if len(baseline) == len(coupled) \
        else len(baseline)
    ex = excess_gain(baseline, coupled, fold_floors)
    earned = bool(len(baseline) > 0 and worse <= WORSE_FOLDS and 2 * worse < len(baseline) and np.isfinite(ex)
                  and ex > margin and base_over >= BASE_OVER and coupled_over <= COUPLED_WITHIN)
    return Allowance(earned, float(ex), base_over, coupled_over, int(worse))


def strongest_coupling(coefficients: Sequence[Mapping[str, Sequence]]) -> float:
    """The largest |value| / 95 % half-width over the nonlinear coupling coefficients (per
    equation, term -> (value, half-width); degree >= 2 terms, as
    :func:`eddi.mdof.verdict.undetermined_coupling`); 0 when none has an interval."""
    best = 0.0
    for eq in coefficients:
        for t, (v, h) in eq.items():
            if ("^" in t or "*" in t) and h is not None and float(h) > 0:
                best = max(best, abs(float(v)) / float(h))
    return best


def undetermined_weak(coefficients: Sequence[Mapping[str, Sequence]], excess: float) -> str | None:
    """Why a coupling earned within the allowance is not named (None: named): no nonlinear coupling
    coefficient at :data:`COEFFICIENT_Z` x its interval."""
    z = strongest_coupling(coefficients)
    if z > COEFFICIENT_Z:
        return None
    return (f"no coupling named: within the baseline's allowance the coupled model removes {100 * excess:.0f} % of "
            f"the error above the floor, but its strongest nonlinear coupling coefficient is {z:.2g}x its 95 % "
            f"half-width (needed above {COEFFICIENT_Z:g}x)")
