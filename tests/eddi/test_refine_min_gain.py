"""``refine_output_error(min_gain=)``: a refinement that stops when a step no longer matters.

The diagnosis' per-fold refinements stop when a Levenberg-Marquardt step lowers the sum of
squares by less than ``min_gain`` mean squares per compared value (docs/performance.md,
"Session 6"). On a noisy record the stopped fit must sit within a small part of its own 95 %
intervals of the fit run to rounding, at no more simulations.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.conditioning import condition
from eddi.identify import identify
from eddi.refine import refine_output_error
from tests.eddi.impact_cases import impact_record
from tests.eddi.test_term_selection import NULLS


@pytest.mark.parametrize("name", ["duffing", "nl_damping"])
def test_stopped_refinement_is_within_its_intervals_of_the_full_one(name: str) -> None:
    spec = NULLS[name]
    r = impact_record(spec, rate_hz=4000.0, duration_s=2.0, pretrigger_s=0.2, snr_db=40.0, seed=5)
    cond = condition(r.t, acc=r.acc, force=r.force)
    w0, w1 = cond.window
    args = (cond.t[w0:w1], cond.x[w0:w1], cond.v[w0:w1], cond.a[w0:w1])
    start = identify(*args[:3], spec["mass"], damping=list(spec["damping"]), stiffness=list(spec["stiffness"]),
                     a=args[3]).eom
    full, info_full = refine_output_error(start, *args)
    fast, info_fast = refine_output_error(start, *args, min_gain=1.0)
    assert info_fast.evaluations <= info_full.evaluations
    assert info_fast.nrmse_after <= info_fast.nrmse_before
    for group in ("damping", "stiffness"):
        for term, c in getattr(full, group).items():
            half = info_full.ci95[group][term]
            assert 0 < half < np.inf
            assert abs(getattr(fast, group)[term] - c) <= 0.25 * half, (group, term)
    # relative to the truth, the stopped fit is as good as the full one (within its interval)
    for group in ("damping", "stiffness"):
        for term, c in spec[group].items():
            assert abs(getattr(fast, group)[term] - c) <= info_full.ci95[group][term] + abs(getattr(full, group)[term] - c)
