"""station.forkmap: the diagnosis' folds in forked workers, the same result as in turn."""

from __future__ import annotations

import json
import multiprocessing
import os
import io
import threading
from pathlib import Path

import numpy as np
import pytest

from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test
from station import forkmap
from station.cli import main
from station.forkmap import ForkMap, jobs_wanted


def test_results_in_order_from_workers_closure_not_pickled() -> None:
    data = np.random.default_rng(0).standard_normal((7, 1000))
    parent = os.getpid()

    def fn(i: int) -> tuple[int, float, bool]:  # a closure (not picklable): inherited by fork
        return i, float(data[i] @ data[i]), os.getpid() != parent

    m = ForkMap(3)
    out = m(fn, range(7))
    assert [o[:2] for o in out] == [(i, float(data[i] @ data[i])) for i in range(7)]
    # item k < 3 starts process k (0: here); the others go to whichever process is free
    assert [o[2] for o in out[:3]] == [False, True, True]
    assert m.forked == 2


def test_the_first_error_in_turn_is_raised() -> None:
    parent = os.getpid()

    def fn(i: int) -> int:
        if i in (1, 2):  # the two workers' first items both raise
            raise ValueError(f"bad item {i}: {'worker' if os.getpid() != parent else 'here'}")
        return i

    for _ in range(3):  # whichever worker reports first, item 1's error is the one raised
        with pytest.raises(ValueError, match="bad item 1: worker"):
            ForkMap(3)(fn, range(6))


def test_items_are_shared_out_as_processes_free_up() -> None:
    # item 0 (here) waits until both workers' items are done: the workers take every item
    # after their first, none is dealt to the busy process in advance
    parent = os.getpid()
    ctx = multiprocessing.get_context("fork")
    done = ctx.Semaphore(0)

    def fn(i: int) -> tuple[int, bool]:
        if i == 0:
            for _ in range(5):
                assert done.acquire(timeout=60)
        else:
            done.release()
        return i, os.getpid() != parent

    out = ForkMap(2)(fn, range(6))
    assert out == [(0, False)] + [(i, True) for i in range(1, 6)]


def test_one_job_or_one_item_runs_here() -> None:
    parent = os.getpid()
    for m, items in ((ForkMap(1), [1, 2, 3]), (ForkMap(4), [5])):
        assert m(lambda i: (i, os.getpid() == parent), items) == [(i, True) for i in items]
        assert m.forked == 0


def test_a_workers_error_is_raised_here() -> None:
    def fn(i: int) -> int:
        if i == 1:  # item 1 is the worker's (of two)
            raise ValueError(f"bad item {i}")
        return i

    with pytest.raises(ValueError, match="bad item 1"):
        ForkMap(2)(fn, [0, 1, 2, 3])


def test_a_worker_that_dies_is_replaced_here() -> None:
    parent = os.getpid()

    def fn(i: int) -> int:
        if os.getpid() != parent:
            os._exit(3)  # killed mid-way: nothing sent back
        return i * i

    m = ForkMap(2)
    assert m(fn, range(5)) == [i * i for i in range(5)]
    assert m.forked == 1


def test_queued_jobs_run_beside_an_item_still_running() -> None:
    # item 0 (here) runs until the worker has done every queued job: the worker, with no item
    # left while item 0 runs, takes them (ForkMap.beside); done() hands each out once
    parent = os.getpid()
    ctx = multiprocessing.get_context("fork")
    ran = ctx.Semaphore(0)

    def job(k: int):  # type: ignore[no-untyped-def]
        def run() -> tuple[int, bool]:
            ran.release()
            return k * k, os.getpid() != parent
        return run

    def bad() -> None:
        ran.release()
        raise ValueError("a queued job that fails is dropped")

    def fn(i: int) -> int:
        if i == 0:
            for _ in range(4):
                assert ran.acquire(timeout=60)
        return i

    m = ForkMap(2)
    m.beside([(("sq", k), job(k)) for k in range(3)] + [("bad", bad)])
    assert m(fn, [0, 1]) == [0, 1]
    assert [m.done(("sq", k)) for k in range(3)] == [(True, (k * k, True)) for k in range(3)]
    assert m.done(("sq", 0)) == (False, None)  # handed out once
    assert m.done("bad") == (False, None)  # raised in the worker: its caller runs it itself
    assert m.done("never queued") == (False, None)


def test_queued_jobs_wait_for_a_map_that_forks() -> None:
    # nothing runs beside a map in turn (no core idles): the job stays queued for a later map
    m = ForkMap(2)
    m.beside([("k", lambda: 7)])
    assert m(lambda i: i, [5]) == [5]  # one item: in turn
    assert m.done("k") == (False, None)
    release = multiprocessing.get_context("fork").Semaphore(0)

    def fn(i: int) -> int:
        if i == 0:  # here, until the worker has taken the job (it signals from inside it)
            assert release.acquire(timeout=60)
        return i

    # (done() above took it off the queue, as its caller then runs it): queued again
    m.beside([("k", lambda: (release.release(), 7)[1])])
    assert m(fn, [0, 1]) == [0, 1]
    assert m.done("k") == (True, 7)


def _ignore_leftover_threads(monkeypatch: pytest.MonkeyPatch) -> None:
    """Threads other tests of the session left running (idle pools) are not this process's
    work: count only the threads started after this point, as a fresh ``station`` has none."""
    real, me = threading.enumerate, threading.current_thread()
    before = {t for t in real() if t is not me}
    monkeypatch.setattr(forkmap.threading, "enumerate", lambda: [t for t in real() if t not in before])


def test_jobs_wanted_environment_load_and_threads(monkeypatch: pytest.MonkeyPatch) -> None:
    _ignore_leftover_threads(monkeypatch)
    monkeypatch.setattr(forkmap, "usable_cores", lambda: 2)
    assert jobs_wanted({}, load=0.3) == 2  # a free core besides this process's
    assert jobs_wanted({}, load=1.2) == 2
    assert jobs_wanted({}, load=2.0) == 1  # the other core is busy
    assert jobs_wanted({}, load=6.0) == 1
    assert jobs_wanted({"STATION_SERIAL": "1"}, load=0.0) == 1
    assert jobs_wanted({"STATION_JOBS": "3"}, load=9.0) == 3
    assert jobs_wanted({"STATION_JOBS": "x"}, load=0.0) == 1
    monkeypatch.setattr(forkmap, "usable_cores", lambda: 1)
    assert jobs_wanted({}, load=0.0) == 1
    monkeypatch.setattr(forkmap, "usable_cores", lambda: 2)
    stop = threading.Event()
    t = threading.Thread(target=stop.wait)
    t.start()
    try:  # another thread running: a fork could copy a lock it holds
        assert jobs_wanted({"STATION_JOBS": "2"}, load=0.0) == 1
    finally:
        stop.set()
        t.join()


def test_the_progress_line_does_not_keep_a_terminal_run_in_one_process(monkeypatch: pytest.MonkeyPatch) -> None:
    # s17beam found `station diagnose` at a terminal in one process whatever STATION_JOBS said:
    # the progress line's thread counted as a thread a fork could catch holding a lock
    from station import progress

    _ignore_leftover_threads(monkeypatch)
    monkeypatch.setattr(progress, "DELAY_S", 0.0)
    monkeypatch.setattr(forkmap, "usable_cores", lambda: 2)

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    term = Terminal()
    with progress.Working("station diagnose", stream=term):
        assert jobs_wanted({"STATION_JOBS": "2"}, load=0.0) == 2
        # forked while the line is drawn: the workers run and answer (no lock copied mid-draw)
        assert ForkMap(2)(lambda i: i * i, list(range(40))) == [i * i for i in range(40)]
    assert "station diagnose: running" in term.getvalue()


SYSTEM = EquationOfMotion.create(mass=0.1, damping={"v": 0.06}, stiffness={"x": 600.0, "x^3": 2e7})


def test_diagnose_forked_equals_in_turn(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    _ignore_leftover_threads(monkeypatch)
    caps = []
    for i, f in enumerate((20.0, 25.0, 30.0)):
        r = impact_test(SYSTEM, f, rate_hz=4000.0, pretrigger_s=0.2, record_s=1.5, snr_db=40.0,
                        effects=[{"name": "coulomb_friction", "params": {"force_n": 0.006}}], seed=i)
        path = tmp_path / f"c{i}.csv"
        np.savetxt(path, np.column_stack((r.t, r.force_n, r.acc_m_s2)), delimiter=",",
                   header="t,force,acc", comments="", fmt="%.10g")
        caps.append(str(path))
    forks = []
    real = ForkMap.__call__

    def counting(self: ForkMap, fn, items):  # type: ignore[no-untyped-def]
        out = real(self, fn, items)
        forks.append(self.forked)
        return out

    monkeypatch.setattr(ForkMap, "__call__", counting)
    taken = []  # the noise floor's perturbed records done beside the maps (ForkMap.beside)
    real_done = ForkMap.done
    monkeypatch.setattr(ForkMap, "done", lambda self, key: (lambda got: (taken.append(got[0]), got)[1])(
        real_done(self, key)))
    outs = []
    for env in ({"STATION_SERIAL": "1"}, {"STATION_JOBS": "2"}):
        monkeypatch.delenv("STATION_SERIAL", raising=False)
        monkeypatch.delenv("STATION_JOBS", raising=False)
        for k, v in env.items():
            monkeypatch.setenv(k, v)
        forks.clear()
        taken.clear()
        assert main(["diagnose", *caps, "--mass", "0.1", "--json"]) == 0
        outs.append(json.loads(capsys.readouterr().out))
        assert (max(forks) > 0) == ("STATION_JOBS" in env)
        # 3 draws of 3 records asked for; in one process none was queued
        assert len(taken) == 9 and (any(taken) if "STATION_JOBS" in env else not any(taken))
    assert outs[0] == outs[1]  # every number the same bit for bit


def test_forward_term_selection_forked_equals_in_turn() -> None:
    # a short, heavily damped record (as tests/eddi/test_term_selection.py; seed 3, where the
    # backward path leaves a weak term, so the refinement's forward selection runs); its
    # trials go through the pipeline's mapper (forked workers) and give the same model,
    # reasons and simulation count as in turn
    from dataclasses import replace

    from eddi.conditioning import condition
    from eddi.fit_record import Pipeline
    from tests.eddi.impact_cases import impact_record

    from tests.eddi.test_term_selection import _linear

    m = 0.5
    spec = _linear(m, 25.0, 0.15)
    r = impact_record(spec, rate_hz=10_000.0, duration_s=0.54, pretrigger_s=0.2, pulse_s=2e-3, snr_db=50.0, seed=3)
    cond = condition(r.t, acc=r.acc, force=r.force)
    serial = Pipeline().fit(cond, m)
    fm = ForkMap(2)
    forked = replace(Pipeline(), mapper=fm).fit(cond, m)
    assert fm.forked > 0
    assert "forward selection" in " ".join(serial.choices.dropped.values())
    assert forked.model.eom == serial.model.eom
    assert forked.choices.dropped == serial.choices.dropped
    assert forked.model.refinement.evaluations == serial.model.refinement.evaluations
    assert forked.ci95 == serial.ci95


def test_forward_selection_start_fitted_in_a_worker(monkeypatch: pytest.MonkeyPatch) -> None:
    # with a second process the forward path's start (the core x, v fitted alone) runs beside
    # the fit of every term, in the worker: this process never fits the core alone, the result
    # is the same bit for bit (eddi.selection.fit_beside_forward_start)
    from dataclasses import replace

    from eddi.fit_record import Pipeline
    from eddi.output_error import OutputErrorProblem

    from tests.eddi.test_forward_beside import _forward_case

    cond, m = _forward_case()
    fitted: list[list[str]] = []
    real = OutputErrorProblem.fit

    def recording(self, p, stop, max_nfev, free=None):  # type: ignore[no-untyped-def]
        fitted.append([self.names[i][1] for i in self.active])
        return real(self, p, stop, max_nfev, free)

    monkeypatch.setattr(OutputErrorProblem, "fit", recording)
    serial = Pipeline().fit(cond, m)
    core = ["v", "x"]  # the damping terms come first
    assert core in fitted  # in turn: the core fitted here
    fitted.clear()
    fm = ForkMap(2)
    forked = replace(Pipeline(), mapper=fm).fit(cond, m)
    assert fm.forked > 0 and fitted and core not in fitted
    assert forked.model.eom == serial.model.eom
    assert forked.model.refinement == serial.model.refinement
    assert forked.ci95 == serial.ci95
