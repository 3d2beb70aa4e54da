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
"""

from __future__ import annotations

import math
import multiprocessing
import os
import pickle
import threading
from typing import Any, Callable, Sequence


def usable_cores() -> int:
    """CPUs this process may run on (its affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


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
    if "fork" not in multiprocessing.get_all_start_methods() or threading.active_count() > 1:
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
        workers = []
        try:
            for w in range(1, n):
                recv, send = ctx.Pipe(duplex=False)
                # (multiprocessing flushes stdout / stderr before it forks: nothing is printed twice)
                proc = ctx.Process(target=_worker, args=(send, fn, items, w, counter, recv), daemon=True)
                proc.start()
                send.close()
                workers.append((proc, recv))
                self.forked += 1
            done = dict(_run(fn, items, 0, counter, catch=False))
            for proc, recv in workers:
                got = _collect(recv)
                proc.join()
                done.update(got)
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


def _run(fn: Callable[[Any], Any], items: list, first: int, counter: Any,
         catch: bool = True) -> list[tuple[int, tuple[str, Any]]]:
    """``(k, ("ok", fn(items[k])))`` for item ``first``, then the items taken from ``counter``,
    until none is left or one raises (``catch``: its ``("error", exc)`` ends the list; else
    raised: this process's own errors propagate at once, Ctrl-C included)."""
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
        k = _take(counter)
    return out


def _worker(conn: Any, fn: Callable[[Any], Any], items: list, first: int, counter: Any,
            own_recv: Any = None) -> None:  # pragma: no cover
    # the fork copied this pipe's read end: closed here, so that if the parent is killed the
    # result's send fails (broken pipe) instead of blocking this worker forever
    if own_recv is not None:
        own_recv.close()
    out = _run(fn, items, first, counter)
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
