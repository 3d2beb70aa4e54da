"""The within-allowance rule for weak couplings (:mod:`eddi.mdof.allowance`): exact cuts."""

from eddi.mdof.allowance import (BASE_OVER, COEFFICIENT_Z, COUPLED_WITHIN, strongest_coupling, undetermined_weak,
                                 within_allowance)
from eddi.mdof.verdict import coupling_earned

FLOORS = {"acc1": 0.01, "acc2": 0.012}


def _m1_like(base=(0.019, 0.025), cpl=(0.0105, 0.0125), folds_b=(0.021, 0.022, 0.023), folds_c=(0.012, 0.0115, 0.0125)):
    """The blind M1 profile: baseline ~2x the floors, coupled at them, raw gain ~45 %."""
    return dict(baseline=list(folds_b), coupled=list(folds_c), fold_floors=[0.011] * 3,
                baseline_channels=dict(zip(FLOORS, base)), coupled_channels=dict(zip(FLOORS, cpl)),
                channel_floors=FLOORS, margin=0.5)


def test_m1_profile_is_earned_within_the_allowance_where_the_old_rules_are_not():
    a = _m1_like()
    won, gain = coupling_earned(a["baseline"], a["coupled"], a["fold_floors"], a["baseline_channels"], FLOORS, 0.5)
    assert not won and 0.40 < gain < 0.50  # the premise: raw gain under the margin, baseline within 3.5x
    ev = within_allowance(**a)
    assert ev.earned and ev.worse_folds == 0
    assert round(ev.base_over, 3) == 1.9 and round(ev.coupled_over, 3) == 1.05
    assert ev.excess_gain > 0.5


def test_each_cut_alone_refuses():
    # a channel of the baseline near its floor (a null's profile)
    assert not within_allowance(**_m1_like(base=(0.019, 0.99 * BASE_OVER * 0.012))).earned
    # the coupled model above the allowance on a channel (and its fold means still under the baseline's)
    assert not within_allowance(**_m1_like(base=(0.019, 0.05), cpl=(0.0105, 1.01 * COUPLED_WITHIN * 0.012))).earned
    # two folds worse (one is allowed: the largest blow's extrapolation)
    assert within_allowance(**_m1_like(folds_c=(0.012, 0.0115, 0.0235))).worse_folds == 1
    assert not within_allowance(**_m1_like(folds_c=(0.012, 0.0225, 0.0235))).earned
    # excess gain under the margin (both folds near the floor)
    assert not within_allowance(**_m1_like(folds_b=(0.0125, 0.013, 0.0128))).earned


def test_the_coefficient_cut():
    weak = [{"x1^3": (4.0e9, 1.0e9)}, {"x2*x1^2": (1.0, None)}]
    assert strongest_coupling(weak) == 4.0 and COEFFICIENT_Z == 2.0
    assert undetermined_weak(weak, 0.7) is None
    assert "1.5x its 95 % half-width" in undetermined_weak([{"x1*x2^2": (-3.0, 2.0)}], 0.7)
    loose = [{"x1^3": (1.0e9, 2.0e9), "x1": (5.0, 0.1)}]  # a linear term is no coupling
    assert strongest_coupling(loose) == 0.5
    assert "no coupling named" in undetermined_weak(loose, 0.7)
    assert strongest_coupling([{"x1^3": (1.0, None)}]) == 0.0
