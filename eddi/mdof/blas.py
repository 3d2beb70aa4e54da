"""One BLAS thread while identifying or polishing a multi-DOF model.

The MDOF fits make thousands of small products and solves (tall matrices of a few dozen
columns). With OpenBLAS's default of one thread per core each hands work to a second thread
and spin-waits for it; on a shared two-core machine that thread is mostly not scheduled.
Measured (session 7, one process, load average 10-11, ``identify_mdof`` on three 45 dB
``two-mass-cubic`` records, the same model to every printed digit): 26.4 / 25.4 s CPU (71 /
61 s wall) with the default pool, 4.4 / 4.2 s CPU (11 / 9 s wall) with one thread. The station
CLI already asks for one thread through the environment, but only before numpy is imported:
in-process callers (tests, benchmarks, notebooks) had the full pool. Same mechanism as
:func:`eddi.diagnosis.threads.one_blas_thread`, kept here so that identifying a multi-DOF
model does not import the diagnosis package.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Limit the BLAS thread pools to one thread inside the ``with`` block (or a decorated call)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # optional: without it the BLAS pools keep their size
        yield
        return
    with threadpool_limits(limits=1, user_api="blas"):
        yield
