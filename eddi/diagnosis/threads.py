"""One BLAS thread while diagnosing.

Diagnosis makes thousands of small least-squares and matrix products (a few columns, up to
tens of thousands of rows). OpenBLAS's default of one thread per core makes each of them
hand work to a second thread and spin-wait for it; on a shared 2-core machine that thread
is mostly not scheduled, and the same diagnosis (``benchmarks/bench_diagnose_speed.py
--case three``, load average 3.5-3.8) took 52 s with two BLAS threads and 16.6 s with one.
:func:`one_blas_thread` limits the BLAS pools to one thread for the duration of a call
(``threadpoolctl``, the library scikit-learn uses for this), and does nothing when it is
not installed.
"""

from __future__ import annotations

import contextlib
from typing import Iterator


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Limit the BLAS thread pools to one thread inside the ``with`` block."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # optional: without it the BLAS pools keep their size
        yield
        return
    with threadpool_limits(limits=1, user_api="blas"):
        yield
