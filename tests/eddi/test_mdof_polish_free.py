"""The MDOF polish moves only what the energy balance leaves open (eddi.mdof.refine.frequency_terms).

Session 13: a three-mass diagnose spent > 1000 s CPU polishing 37-43 coefficients per fold with
forward sensitivities in every one of them. The polish now frees the terms that set the
frequencies (linear stiffness, each coordinate's own nonlinear stiffness) and keeps the damping and
the nonlinear coupling at EDDI's values; the intervals still cover every coefficient.
"""

from __future__ import annotations

import numpy as np

import eddi.mdof.sensitivity as sensitivity
from eddi.mdof.refine import JACOBIAN_COARSEN, frequency_terms, refine_mdof
from tests.eddi.test_mdof_sensitivity import SYSTEM, _records  # the same records (seeds 3.., 45 dB)


def test_frequency_terms_of_a_cubic_coupling_chain():
    model = SYSTEM.model()  # two masses, a cubic spring between them: per equation 2 dashpots, 6 springs
    order = [(i, t) for i in range(2) for t in list(model.damping[i]) + list(model.stiffness[i])]
    free = {order[k] for k in frequency_terms(model)}
    assert free == {(0, "x1"), (0, "x2"), (0, "x1^3"), (1, "x1"), (1, "x2"), (1, "x2^3")}


def test_polish_recovers_a_frequency_error_in_the_free_terms_only(monkeypatch):
    records = _records(SYSTEM)
    truth = SYSTEM.model()
    stiffness = [dict(s) for s in truth.stiffness]
    stiffness[0]["x1"] *= 1.005  # a 0.25 % frequency error of the first mass, as EDDI leaves it
    stiffness[0]["x1^2*x2"] *= 1.01  # and a 1 % coupling error, which the polish keeps
    start = truth.model_copy(update={"stiffness": tuple(stiffness)})
    directions: list[int] = []
    plain = sensitivity.predict_sensitivities

    coarse: list[int] = []

    def counted(model, record, dirs=None, coarsen=1):
        directions.append(dirs.shape[1])
        coarse.append(coarsen)
        return plain(model, record, dirs, coarsen=coarsen)

    monkeypatch.setattr(sensitivity, "predict_sensitivities", counted)
    out, before, after = refine_mdof(start, records, max_nfev=40)
    assert after < 0.2 * before
    assert out.stiffness[0]["x1^2*x2"] == stiffness[0]["x1^2*x2"]  # kept, bit for bit
    assert out.damping == start.damping
    assert abs(out.stiffness[0]["x1"] / truth.stiffness[0]["x1"] - 1) < 1e-3
    # Jacobians along the 6 free terms; one along all 16 coefficients (per record) for the intervals
    n_all = sum(len(d) + len(s) for d, s in zip(start.damping, start.stiffness))
    per_record = len(records)
    assert set(directions) == {6, n_all} and directions.count(n_all) == per_record
    # it stops once a step gains < 0.1 % of the cost (POLISH_FTOL): 5 Jacobians, where scipy's default
    # tolerance went on to 6 for the same result (and on the three-mass chain to its 60-evaluation cap)
    assert directions.count(6) == 5 * per_record
    assert all(np.isfinite(list(ci.values())).all() and set(ci) == set(s)
               for ci, s in zip(out.stiffness_ci95, out.stiffness))
    # session 15: every Jacobian integrates its sensitivities at half the simulation's sub-steps
    assert set(coarse) == {JACOBIAN_COARSEN} == {2}
    # a fold model (intervals=False): the same polish, no Jacobian in every coefficient, EDDI's intervals kept
    directions.clear()
    fold, b2, a2 = refine_mdof(start, records, max_nfev=40, intervals=False)
    assert (b2, a2) == (before, after) and fold.stiffness == out.stiffness
    assert set(directions) == {6} and fold.stiffness_ci95 == start.stiffness_ci95
