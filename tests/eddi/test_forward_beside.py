"""The forward term selection's start fitted beside the fit of every term (eddi.selection).

With a mapper that forks (``jobs`` > 1), :func:`eddi.refine.refine_output_error` fits the
forward path's start (the core ``x, v`` from equation error) in a second item beside the fit of
every term: the two are independent, and which path runs is known only after the latter. The
result must be the same as in turn, bit for bit (model, reasons, intervals, simulations
counted), whichever process runs which item and in whatever order; the start's error is raised
only where the forward path runs.
"""

from __future__ import annotations

import os
import pickle
from dataclasses import replace

import pytest

import eddi.selection as selection
from eddi.conditioning import condition
from eddi.fit_record import Pipeline
from tests.eddi.impact_cases import impact_record
from tests.eddi.test_term_selection import NULLS, _linear, _record


class InTurn:
    """A mapper that says it forks (``jobs`` 2) and runs the items here, in turn or reversed,
    recording each call's items."""

    def __init__(self, reverse: bool = False) -> None:
        self.jobs, self.reverse, self.calls = 2, reverse, []

    def __call__(self, fn, items):  # type: ignore[no-untyped-def]
        items = list(items)
        self.calls.append(items)
        order = range(len(items) - 1, -1, -1) if self.reverse else range(len(items))
        out = {k: fn(items[k]) for k in order}
        return [out[k] for k in range(len(items))]


class Elsewhere(InTurn):
    """Every item in a forked child of its own (item 0 too): nothing comes back but the results."""

    def __call__(self, fn, items):  # type: ignore[no-untyped-def]
        items = list(items)
        self.calls.append(items)
        out = []
        for x in items:
            r, w = os.pipe()
            pid = os.fork()
            if pid == 0:  # pragma: no cover - the child
                os.close(r)
                with os.fdopen(w, "wb") as f:
                    pickle.dump(fn(x), f)
                os._exit(0)
            os.close(w)
            with os.fdopen(r, "rb") as f:
                out.append(pickle.load(f))
            os.waitpid(pid, 0)
        return out


def _forward_case():
    # a short, heavily damped record (tests/eddi/test_term_selection.py, seed 3): the backward
    # path leaves a weak term and the forward path runs
    m = 0.5
    r = impact_record(_linear(m, 25.0, 0.15), rate_hz=10_000.0, duration_s=0.54, pretrigger_s=0.2, pulse_s=2e-3,
                      snr_db=50.0, seed=3)
    return condition(r.t, acc=r.acc, force=r.force), m


def _backward_case():
    # the Duffing null (seed 7): the backward path's model stands, no forward path
    spec = NULLS["duffing"]
    r = _record(spec, 7)
    return condition(r.t, acc=r.acc, force=r.force), spec["mass"]


def _same(a, b) -> None:  # type: ignore[no-untyped-def]
    assert a.model.eom == b.model.eom
    assert a.choices.dropped == b.choices.dropped
    assert a.ci95 == b.ci95
    assert a.model.refinement.evaluations == b.model.refinement.evaluations
    assert a.model.refinement == b.model.refinement


@pytest.mark.parametrize("mapper", [InTurn(), InTurn(reverse=True), Elsewhere()], ids=["in-turn", "reversed", "elsewhere"])
def test_forward_start_beside_the_full_fit_gives_the_result_in_turn(mapper: InTurn) -> None:
    cond, m = _forward_case()
    serial = Pipeline().fit(cond, m)
    assert "forward selection" in " ".join(serial.choices.dropped.values())
    beside = replace(Pipeline(), mapper=mapper).fit(cond, m)
    # the refinement's first map: the fit of every term (0) and the forward path's start (1)
    assert mapper.calls[0] == [0, 1]
    _same(beside, serial)


def test_forward_start_not_needed_changes_nothing() -> None:
    cond, m = _backward_case()
    serial = Pipeline().fit(cond, m)
    assert "forward selection" not in " ".join(serial.choices.dropped.values())
    mapper = InTurn()
    beside = replace(Pipeline(), mapper=mapper).fit(cond, m)
    assert mapper.calls[0] == [0, 1]  # computed beside, then not used: its simulations not counted
    _same(beside, serial)


def test_a_mapper_in_turn_fits_no_start_beside() -> None:
    # jobs 1 (or a plain function): the start is fitted only where the forward path runs
    cond, m = _backward_case()
    mapper = InTurn()
    mapper.jobs = 1
    replace(Pipeline(), mapper=mapper).fit(cond, m)
    assert [0, 1] not in mapper.calls


def test_the_start_s_error_is_raised_only_where_the_forward_path_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise ArithmeticError("core fit")

    monkeypatch.setattr(selection, "_core_fit", broken)
    cond, m = _backward_case()
    replace(Pipeline(), mapper=InTurn()).fit(cond, m)  # not needed: not raised
    cond, m = _forward_case()
    with pytest.raises(ArithmeticError, match="core fit"):
        Pipeline().fit(cond, m)
    with pytest.raises(ArithmeticError, match="core fit"):
        replace(Pipeline(), mapper=InTurn()).fit(cond, m)


def test_a_start_from_other_inputs_is_not_used(monkeypatch: pytest.MonkeyPatch) -> None:
    # the start is used only when it was computed from the inputs the forward path has where it
    # runs (selection._start_key); another key: the core is fitted again there, the same result
    keys = iter(range(10**6))
    monkeypatch.setattr(selection, "_start_key", lambda *args: str(next(keys)).encode())
    fits = []
    real = selection._core_fit
    monkeypatch.setattr(selection, "_core_fit", lambda *a, **k: fits.append(1) or real(*a, **k))
    cond, m = _forward_case()
    serial = Pipeline().fit(cond, m)
    in_turn = len(fits)  # one per refinement with a forward path (the pipeline may refine twice)
    assert in_turn >= 1
    fits.clear()
    beside = replace(Pipeline(), mapper=InTurn()).fit(cond, m)
    assert len(fits) == 2 * in_turn  # beside, then again where the forward path runs
    _same(beside, serial)
