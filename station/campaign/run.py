"""Run a campaign on a ``dask.distributed`` cluster and collect its rows as they arrive.

What runs where:

* the client (this process) expands the sources into capture references, skips those the
  journal already holds, submits one task per chunk of references, and writes each row to
  the journal as its task completes (models as JSON files beside it); at most a few tasks per
  worker thread are in flight, so a million-capture campaign holds a bounded number of
  futures, not a million;
* each worker reads its captures from the paths it is given, runs the pipeline
  (:func:`station.campaign.tasks.run_chunk`) and returns small rows (coefficients, scores and
  the model's JSON text, a few kB), never arrays.

The default cluster is a :class:`distributed.LocalCluster` of processes, one worker per core
and one thread per worker (the pipeline is numpy/numba code that holds the GIL in places, so
processes scale where threads would not; Dask's nanny sets ``OMP_NUM_THREADS=1`` etc. in each
worker so BLAS does not oversubscribe the cores).
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import os
import sys
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

from station.campaign import tasks
from station.campaign.sources import CaptureRef
from station.campaign.table import Journal
from station.errors import ConfigError


#: Tasks kept submitted per worker thread: enough that no worker waits for the client, few
#: enough that a million-capture campaign holds a bounded number of futures.
IN_FLIGHT_PER_THREAD = 4
#: Automatic chunking (``chunk=None``): at least this many tasks per worker thread (so the last
#: tasks leave a thread idle for at most ~1/8 of its share), and at most :data:`MAX_AUTO_CHUNK`
#: captures per task. Measured (``bench_campaign.py --n 60 --chunk 4`` vs ``--chunk 1``, same
#: code, load 9): 12-13 % less CPU per capture (100 vs 114 ms on 1 worker, 109 vs 125 ms on 2).
TASKS_PER_THREAD = 8
MAX_AUTO_CHUNK = 8


def auto_chunk(n_captures: int, threads: int) -> int:
    """Captures per task for ``n_captures`` on ``threads`` worker threads (see :data:`TASKS_PER_THREAD`)."""
    return max(1, min(MAX_AUTO_CHUNK, n_captures // max(1, TASKS_PER_THREAD * threads)))


#: Dask settings of the local cluster: no statistical profiler in the workers (it samples every
#: task's stack 100 times a second), event-loop and memory checks once a second instead of every
#: 20 / 100 ms. Measured on an idle 2-worker cluster: 0.12 -> 0.025 cores of background CPU
#: (issue 13; the workers' profile page of the dashboard is then empty).
QUIET_CLUSTER = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s",
                 "distributed.worker.memory.monitor-interval": "1s"}


@dataclass(frozen=True)
class CampaignResult:
    """What a campaign did.

    Attributes
    ----------
    total : int
        Captures the sources name.
    skipped : int
        Already in the journal (resume), not run again.
    processed : int
        Run now.
    failed : int
        Of ``processed``, rows with ``status="error"``.
    wall_s : float
        [s] from the first submission to the last row (cluster start and warm-up excluded).
    warm_up_s : float
        [s] the workers spent importing and compiling before the first task.
    csv, parquet : Path
        The tables.
    rows : int
        Rows in the tables (every capture processed so far, this run or before).
    workers : int
        Worker processes (threads in total: ``threads``).
    threads : int
    scheduler : str
        Address of the scheduler.
    peak_memory_mb : dict of str to float
        Peak resident memory of each worker process [MiB], by worker address.
    """

    total: int
    skipped: int
    processed: int
    failed: int
    wall_s: float
    warm_up_s: float
    csv: Path
    parquet: Path
    rows: int
    workers: int
    threads: int
    scheduler: str
    peak_memory_mb: dict[str, float] = field(default_factory=dict)

    @property
    def captures_per_s(self) -> float:
        """Throughput of this run [captures/s] (0 when nothing ran)."""
        return self.processed / self.wall_s if self.processed and self.wall_s > 0 else 0.0


@contextlib.contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None) -> Iterator[Any]:
    """A client of an existing scheduler, or of a new local cluster closed on exit.

    Parameters
    ----------
    scheduler : str, optional
        ``tcp://HOST:PORT`` of a running scheduler (``dask scheduler``, dask-jobqueue,
        dask-kubernetes...); default: start a :class:`~distributed.LocalCluster`.
    workers : int, optional
        Worker processes of the local cluster (default: the cores, ``os.cpu_count()``); one
        thread each. Ignored with ``scheduler``.

    Raises
    ------
    ConfigError
        Unreachable scheduler, or ``workers`` < 1.
    """
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise ConfigError(f"--scheduler {scheduler}: cannot connect ({str(exc).splitlines()[0]})") from None
        try:
            yield client
        finally:
            client.close()
        return
    n = workers if workers is not None else (os.cpu_count() or 1)
    if n < 1:
        raise ConfigError(f"--workers must be >= 1, got {n}")
    import dask

    with dask.config.set(QUIET_CLUSTER):
        with _children_ignore_sigint():  # the worker processes start with Ctrl-C ignored, and keep it
            # CRITICAL: a worker's heartbeat that meets the scheduler already closed at the end of a
            # run logs a CommClosedError traceback at ERROR (seen once in 7 two-worker runs at load
            # ~18, session 19, under a campaign that exited 0); a task lost on a worker is an error
            # row of its own (_lost_rows), so nothing the user needs is silenced
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                                   silence_logs=logging.CRITICAL)
        with cluster, Client(cluster) as client:
            yield client


@contextlib.contextmanager
def _children_ignore_sigint() -> Iterator[None]:
    """SIGINT ignored while the local cluster's processes are started (main thread only).

    A terminal's Ctrl-C reaches the whole process group: each worker took it and printed Dask's
    tracebacks (CancelledError in the nanny's ``run``) under the campaign's one line. A process
    started with SIGINT ignored keeps it ignored (Python installs no handler then), so only this
    process (the client) takes Ctrl-C and closes the cluster. A Ctrl-C during the few seconds
    the workers start is not taken.
    """
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _chunks(refs: Sequence[CaptureRef], size: int) -> Iterator[list[CaptureRef]]:
    for i in range(0, len(refs), size):
        yield list(refs[i:i + size])


def _lost_rows(refs: Sequence[CaptureRef], opts: tasks.TaskOptions, exc: BaseException) -> list[dict[str, Any]]:
    """Rows for a task that did not return (worker killed, lost...)."""
    msg = (str(exc).strip().splitlines() or [""])[0]
    return [{"file": r.file, "capture": r.capture, "task": opts.task, "status": "error",
             "error": f"task failed on the cluster: {type(exc).__name__}: {msg}"[:500], "worker": ""}
            for r in refs]


def _progress(total: int, quiet: bool) -> Any:
    from tqdm import tqdm

    return tqdm(total=total, unit="capture", disable=quiet or not sys.stderr.isatty(), file=sys.stderr,
                smoothing=0.05, dynamic_ncols=True)


def run_campaign(
    client: Any,
    refs: Sequence[CaptureRef],
    opts: tasks.TaskOptions,
    journal: Journal,
    *,
    chunk: int | None = None,
    retry_errors: bool = False,
    quiet: bool = False,
    warm_up: bool = True,
    on_row: Callable[[dict[str, Any]], None] | None = None,
) -> CampaignResult:
    """Run ``opts.task`` on every capture not yet in ``journal``; write rows and tables.

    Parameters
    ----------
    client : distributed.Client
    refs : sequence of CaptureRef
        From :func:`station.campaign.sources.expand_sources`.
    opts : TaskOptions
    journal : Journal
        Output folder; captures it holds are skipped (failed ones too unless ``retry_errors``).
    chunk : int, optional
        Captures per Dask task (1: finest load balance; more: less scheduling per capture);
        default :func:`auto_chunk` of the captures to run and the cluster's threads.
    retry_errors : bool
        Run again the captures whose row is an error.
    quiet : bool
        No progress bar (it is also off when stderr is not a terminal).
    warm_up : bool
        Import and compile on every worker first (:func:`station.campaign.tasks.warm_up`).
    on_row : callable, optional
        Called with each row as it is written (tests, live displays).

    Returns
    -------
    CampaignResult
        The tables are written even when interrupted (Ctrl-C): every row received is kept.
    """
    from distributed import as_completed

    if chunk is not None and chunk < 1:
        raise ConfigError(f"--chunk must be >= 1, got {chunk}")
    done = journal.done(retry_errors=retry_errors)
    todo = [r for r in refs if r.key not in done]
    threads = sum(client.nthreads().values())
    if chunk is None:
        chunk = auto_chunk(len(todo), threads)
    warm = 0.0
    if warm_up and todo:
        warm = max(client.run(tasks.warm_up).values(), default=0.0)
    token = uuid.uuid4().hex[:8]
    counter = itertools.count()
    pending = _chunks(todo, chunk)
    in_flight: dict[Any, list[CaptureRef]] = {}
    failed = processed = 0
    ac = as_completed()

    def submit(n: int) -> None:
        for part in pending:
            fut = client.submit(tasks.run_chunk, part, opts, pure=False, key=f"campaign-{token}-{next(counter)}")
            in_flight[fut] = part
            ac.add(fut)
            n -= 1
            if n <= 0:
                return

    t0 = time.perf_counter()
    bar = _progress(len(todo), quiet)
    try:
        submit(max(4, IN_FLIGHT_PER_THREAD * threads))
        checked = time.perf_counter()
        for fut in ac:
            part = in_flight.pop(fut)
            try:
                rows = fut.result()
            except Exception as exc:  # noqa: BLE001 - a lost worker costs rows, not the campaign
                rows = _lost_rows(part, opts, exc)
            fut.release()
            if time.perf_counter() - checked > 5.0:  # workers may join (adaptive clusters) or leave
                threads, checked = sum(client.nthreads().values()), time.perf_counter()
            submit(max(1, max(4, IN_FLIGHT_PER_THREAD * threads) - len(in_flight)))
            for row in rows:
                journal.append(row)
                processed += 1
                failed += row["status"] != "ok"
                if on_row is not None:
                    on_row(row)
            bar.update(len(rows))
        wall = time.perf_counter() - t0
    finally:
        bar.close()
        for fut in in_flight:
            fut.cancel()
        journal.close()
        csv_path, pq_path, n_rows = journal.write_tables()
    mem = client.run(tasks.peak_memory_mb)
    return CampaignResult(total=len(refs), skipped=len(refs) - len(todo), processed=processed, failed=failed,
                          wall_s=wall, warm_up_s=warm, csv=csv_path, parquet=pq_path, rows=n_rows,
                          workers=len(client.nthreads()), threads=threads,
                          scheduler=str(client.scheduler.address), peak_memory_mb=dict(mem))
