"""A ``map`` over forked copies of this process, for the diagnosis' independent folds.

:func:`eddi.diagnosis.diagnose` takes a ``mapper(fn, items)`` (:mod:`eddi.diagnosis.mapping`)
for its per-fold work (refinements of each fold's baseline, every candidate's refits, the
noise floor's perturbed refits). :class:`ForkMap` runs ``fn`` on the items in this process and
in ``jobs - 1`` forked workers (``fork``: nothing is re-imported and nothing is copied but
the results, which come back pickled through a pipe): item ``k < jobs`` starts process ``k``,
then each process takes the next item no process has taken yet (a shared counter). Each
worker computes exactly what this process would (the same code on the same inputs, one BLAS
thread each), so the diagnosis is the same bit for bit.

It forks only when it can pay: :func:`jobs_wanted` is 1 (run here, in turn) with one usable
core, without ``fork``, with another Python thread running (a fork copies the locks other
threads may hold), when the machine has no free core (1-minute load average), or with
``STATION_SERIAL=1``; ``STATION_JOBS=N`` forces ``N`` workers in all (no load check). A
worker that dies (killed, out of memory) is replaced by the same calls in this process; an
error raised in a worker is raised here, after this process's own share: of the items that
raised, the first in turn (the error a map in turn would raise). Which process computes an
item depends on timing; the results do not.

Work known to be needed later and independent of everything before it (the noise floor's
perturbed records of ``station diagnose``, which depend on the records alone) can be queued
with :meth:`ForkMap.beside`: during each later map, a process that has no item of the map left
to take while another process still works on one takes a queued job instead of waiting (the
core would idle; a job is short, so the map ends at most one job later). What was done comes
back with the map's results, :meth:`ForkMap.done` hands it to the caller that needs it (the
same call it would otherwise make, in this process or a forked copy: the same numbers), and
what was not done stays queued. Nothing is done beside in a map that runs in turn.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import pickle
import threading
from typing import Any, Callable, Hashable, Sequence


def usable_cores() -> int:
    """CPUs this process may run on (its affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def _unsafe_threads() -> bool:
    """Another thread runs that a fork could catch holding a lock (the progress line's thread is
    fork-safe: :mod:`station.progress`)."""
    me = threading.current_thread()
    return any(t is not me and not getattr(t, "fork_safe", False) for t in threading.enumerate())


def jobs_wanted(environ: dict[str, str] | None = None, load: float | None = None) -> int:
    """Processes to run the folds in (this one included; 1: no fork).

    Parameters
    ----------
    environ : dict, optional
        Environment (default ``os.environ``): ``STATION_SERIAL=1`` gives 1, ``STATION_JOBS=N``
        gives ``N`` (at least 1).
    load : float, optional
        1-minute load average (default :func:`os.getloadavg`); the cores not busy with it
        (rounded) are used, this process's own core included.
    """
    env = os.environ if environ is None else environ
    if env.get("STATION_SERIAL", "") not in ("", "0"):
        return 1
    if "fork" not in multiprocessing.get_all_start_methods() or _unsafe_threads():
        return 1
    forced = env.get("STATION_JOBS", "").strip()
    if forced:
        try:
            return max(1, int(forced))
        except ValueError:
            return 1
    cores = usable_cores()
    if cores < 2:
        return 1
    if load is None:
        try:
            load = os.getloadavg()[0]
        except OSError:  # pragma: no cover - no load average
            load = 0.0
    # this process is (about) one of the running ones: it keeps its own core
    free = cores - max(0.0, load - 1.0)
    return max(1, min(cores, int(math.floor(free + 0.5))))


class ForkMap:
    """``ForkMap(jobs)(fn, items)`` == ``[fn(item) for item in items]``, in ``jobs`` processes.

    ``fn`` may be any callable (a closure over large arrays included): workers are forked
    after it exists, so it is never pickled; only the results travel. With ``jobs`` 1 or
    fewer than two items everything runs here.
    """

    def __init__(self, jobs: int) -> None:
        self.jobs = max(1, int(jobs))
        self.forked = 0  # workers started (for tests and benchmarks)
        self._queued: dict[Hashable, Callable[[], Any]] = {}  # beside(): not done yet
        # beside(): done, not yet handed out; with its job, so that what the job holds (and the
        # ids a key may name) stays alive until then
        self._done: dict[Hashable, tuple[Callable[[], Any], Any]] = {}

    def beside(self, jobs: Sequence[tuple[Hashable, Callable[[], Any]]]) -> None:
        """Queue independent ``(key, job)`` pairs to run while a later map leaves a core idle.

        ``job()`` must depend on nothing a map computes (it may run in any process, at any
        later map, or never): its result is handed out by :meth:`done`. A job that raises is
        dropped (its caller then runs it itself, and meets the error there).
        """
        for key, job in jobs:
            if key not in self._done:
                self._queued[key] = job

    def done(self, key: Hashable) -> tuple[bool, Any]:
        """``(True, result)`` of a job queued by :meth:`beside` and done beside a map (handed
        out once, and no longer queued), else ``(False, None)``."""
        self._queued.pop(key, None)
        if key in self._done:
            return True, self._done.pop(key)[1]
        return False, None

    def __call__(self, fn: Callable[[Any], Any], items: Sequence[Any]) -> list:
        items = list(items)
        n = min(self.jobs, len(items))
        if n < 2:
            return [fn(x) for x in items]
        ctx = multiprocessing.get_context("fork")
        # item k < n is process k's first (0: this one); then each process takes the next item
        # not yet taken (a shared counter), so a process that drew cheap items takes more and
        # one long item does not leave the others idle (round robin waited for the slowest
        # share: 11.3 s where taking in turn needs 10.1 s of the beam's 17.7 s of maps, 2 jobs)
        counter = ctx.Value("q", n)
        # the queued jobs (beside()): taken from a second counter, only while an item is running
        queued = list(self._queued.items())
        side = _Side([job for _, job in queued], ctx.Value("q", 0), ctx.Value("q", 0), len(items)) if queued else None
        workers = []
        try:
            for w in range(1, n):
                recv, send = ctx.Pipe(duplex=False)
                # (multiprocessing flushes stdout / stderr before it forks: nothing is printed twice)
                proc = ctx.Process(target=_worker, args=(send, fn, items, w, counter, recv, side), daemon=True)
                proc.start()
                send.close()
                workers.append((proc, recv))
                self.forked += 1
            done = dict(_run(fn, items, 0, counter, catch=False, side=side))
            for proc, recv in workers:
                got = _collect(recv)
                proc.join()
                done.update(got)
            for b, (key, job) in enumerate(queued):
                kind, value = done.pop(len(items) + b, ("none", None))
                if kind == "ok":
                    self._done[key] = (job, value)
                if kind != "none":  # done (or raised: dropped, its caller runs it)
                    self._queued.pop(key, None)
            out: list[Any] = []
            for k, x in enumerate(items):  # in order: the error raised is the first in turn
                kind, value = done[k] if k in done else ("ok", fn(x))  # a dead worker's: here
                if kind != "ok":
                    raise value
                out.append(value)
            return out
        finally:
            for proc, recv in workers:
                if proc.is_alive():  # interrupted (Ctrl-C, an error here): stop the worker
                    proc.terminate()
                    proc.join()
                recv.close()


def _take(counter: Any) -> int:
    with counter.get_lock():
        k = int(counter.value)
        counter.value = k + 1
    return k


class _Side:
    """The queued jobs of a map (:meth:`ForkMap.beside`), the counter they are taken from and
    the count of the map's items finished (a job is taken only while one is still running)."""

    def __init__(self, jobs: list, taken: Any, finished: Any, n_items: int) -> None:
        self.jobs, self.taken, self.finished, self.n_items = jobs, taken, finished, n_items

    def run(self) -> list[tuple[int, tuple[str, Any]]]:
        """While another process still runs an item of the map: the next queued jobs, as
        ``(n_items + b, ("ok", result))`` (``("error", exc)`` for a job that raised)."""
        out: list[tuple[int, tuple[str, Any]]] = []
        while self.jobs and int(self.finished.value) < self.n_items:
            b = _take(self.taken)
            if b >= len(self.jobs):
                break
            try:
                out.append((self.n_items + b, ("ok", self.jobs[b]())))
            except Exception as exc:  # noqa: BLE001 - dropped by the parent (its caller runs it)
                out.append((self.n_items + b, ("error", exc)))
        return out


def _run(fn: Callable[[Any], Any], items: list, first: int, counter: Any,
         catch: bool = True, side: _Side | None = None) -> list[tuple[int, tuple[str, Any]]]:
    """``(k, ("ok", fn(items[k])))`` for item ``first``, then the items taken from ``counter``,
    until none is left or one raises (``catch``: its ``("error", exc)`` ends the list; else
    raised: this process's own errors propagate at once, Ctrl-C included); then ``side``'s
    queued jobs while another process still runs an item."""
    out: list[tuple[int, tuple[str, Any]]] = []
    k = first
    while k < len(items):
        try:
            out.append((k, ("ok", fn(items[k]))))
        except BaseException as exc:  # noqa: BLE001 - handed back to the parent
            if not catch:
                raise
            out.append((k, ("error", exc)))
            break
        finally:
            if side is not None:
                _take(side.finished)
        k = _take(counter)
    if side is not None:
        out.extend(side.run())
    return out


def _worker(conn: Any, fn: Callable[[Any], Any], items: list, first: int, counter: Any,
            own_recv: Any = None, side: _Side | None = None) -> None:  # pragma: no cover
    # the fork copied this pipe's read end: closed here, so that if the parent is killed the
    # result's send fails (broken pipe) instead of blocking this worker forever
    if own_recv is not None:
        own_recv.close()
    out = _run(fn, items, first, counter, side=side)
    try:
        data = pickle.dumps(out, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as exc:  # noqa: BLE001 - a result or error that does not pickle
        data = pickle.dumps([(out[0][0], ("error", RuntimeError(f"fold worker: {exc}")))])
    conn.send_bytes(data)
    conn.close()


def _collect(recv: Any) -> list[tuple[int, tuple[str, Any]]]:
    """A worker's ``(item, ("ok", result) or ("error", exc))`` pairs; none if it died (its
    items then run here, see :meth:`ForkMap.__call__`)."""
    try:
        return pickle.loads(recv.recv_bytes())
    except (EOFError, OSError):  # the worker died (killed, out of memory)
        return []
