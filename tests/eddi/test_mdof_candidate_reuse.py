"""The candidate choice simulates each candidate's training records once (session 15, issue 14's cost).

``identify_mdof(coordinates="auto")`` chooses among its candidates twice when modal coordinates
are kept (again with the lower prunes added), and the lumped fit has already simulated its model
on the same records to pick its own variant. Before: the first choice's candidates were simulated
again in the second and the lumped model in both (a three-mass fold, session 13's 1 / 0.5 / 2 kg
chain: 4.6 of 9.9 s CPU in the two choices). The numbers must be the same ones: the lumped fit's
stored ``training_nrmse`` is the training error of the model it returns, to the last bit.
"""

from __future__ import annotations

import math

import pytest

from tests.eddi.test_mdof_chain import CHANNELS, _conditioned, _system


class _Cand:
    def __init__(self, n_terms: int, training_nrmse: float = math.nan):
        from eddi.mdof.model import MdofModel

        self.lumped = None
        self.training_nrmse = training_nrmse
        self.model = MdofModel.create(coordinates="physical", mass=(1.0, 1.0), input=(1.0, 0.0), damping=({}, {}),
                                      stiffness=({f"x1^{2 * k + 1}": 1.0 for k in range(n_terms)}, {}),
                                      channels=("a", "b"), shapes=((1.0, 0.0), (0.0, 1.0)), driving_point="a")


def test_known_training_errors_are_not_simulated_again(monkeypatch):
    from eddi.mdof import candidates

    cands = [_Cand(3), _Cand(2, training_nrmse=0.0067), _Cand(1), _Cand(4)]
    truth = [0.0064, 0.0067, 0.0114, 0.0050]
    simulated: list[int] = []

    def fake(model, records):
        k = [c.model for c in cands].index(model)
        simulated.append(k)
        return truth[k]

    monkeypatch.setattr(candidates, "training_error", fake)
    monkeypatch.setattr(candidates, "records_floor", lambda records: 0.0001)
    first = candidates.choose_candidate(cands[:3], ["a", "b", "c"], [])
    assert simulated == [0, 2]  # the second one's own figure is used, not simulated
    assert first.own == (0.0064, 0.0067, 0.0114)
    assert first.index == 0
    simulated.clear()
    again = candidates.choose_candidate(cands, ["a", "b", "c", "d"], [], known=first.own)
    assert simulated == [3]  # only the new candidate
    assert again.own == tuple(truth)
    assert again.index == 3 and again.errors == tuple(truth)


def test_the_lumped_fit_stores_its_models_training_error_exactly():
    from eddi.mdof.candidates import training_error
    from eddi.mdof.physical import identify_lumped

    system = _system((1, 2), 6e9)
    records = [_conditioned(system, p, seed=3 + k) for k, p in enumerate(system.impacts_n)]
    ident = identify_lumped(records, CHANNELS, "acc1")
    assert math.isfinite(ident.training_nrmse)
    assert ident.training_nrmse == training_error(ident.model, records)  # the same number, not a close one
    assert ident.form_error <= ident.training_nrmse
