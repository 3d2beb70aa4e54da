"""One BLAS thread while the engine makes many small linear-algebra calls.

Diagnosis and the multi-DOF fits make thousands of small least-squares solves and matrix
products (a few dozen columns, up to tens of thousands of rows). With OpenBLAS's default of
one thread per core each hands work to a second thread and spin-waits for it; on a shared
two-core machine that thread is mostly not scheduled. Measured:

* diagnosis (``benchmarks/bench_diagnose_speed.py --case three``, load average 3.5-3.8):
  52 s with two BLAS threads, 16.6 s with one;
* ``identify_mdof`` on three 45 dB ``two-mass-cubic`` records (session 7, one process, load
  10-11, the same model to every printed digit): 26.4 / 25.4 s CPU (71 / 61 s wall) with the
  default pool, 4.4 / 4.2 s CPU (11 / 9 s wall) with one thread.

The station CLI already asks for one thread through the environment, but only before numpy
is imported; in-process callers (tests, benchmarks, notebooks) had the full pool.
:func:`one_blas_thread` limits the BLAS pools for the duration of a call (``threadpoolctl``,
the library scikit-learn uses for this) and does nothing when it is not installed. This is
the one place that owns it (the diagnosis loop and ``eddi.mdof`` both use it).
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator

#: threadpoolctl's view of the loaded BLAS libraries and ``len(sys.modules)`` when it was taken:
#: finding the libraries walks every loaded shared object (``dl_iterate_phdr``, ~2.4 ms a call,
#: two calls per in-process identify); a new BLAS can only arrive with a newly imported module,
#: so the view is taken again when the module count changed.
_CONTROLLER: list = [None, -1]
#: True once a program has declared (:func:`declare_one_thread_environment`) that every BLAS pool
#: of this process starts with one thread: then there is nothing to limit, and the look-up is skipped.
_ENVIRONMENT_ONE_THREAD: list = [False]

#: The variables that size the BLAS pools at their load: OpenBLAS, OpenMP (BLAS built on it), MKL.
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def declare_one_thread_environment() -> bool:
    """Note that the BLAS pools of this process start with one thread, when that is sure: every
    one of :data:`THREAD_VARIABLES` is "1" and numpy (which loads the BLAS) is not imported yet.
    Returns whether it was noted. station's command line calls this after setting them (it does,
    unless the user set other counts): :func:`one_blas_thread` then skips threadpoolctl, whose
    import and look-up of the loaded libraries (every shared object walked) cost ~7 ms of CPU per
    ``station identify`` (session 14), to set a limit the pools already have."""
    import os

    sure = "numpy" not in sys.modules and all(os.environ.get(v, "").strip() == "1" for v in THREAD_VARIABLES)
    _ENVIRONMENT_ONE_THREAD[0] = sure
    return sure


def _controller():
    from threadpoolctl import ThreadpoolController

    if _CONTROLLER[0] is None or _CONTROLLER[1] != len(sys.modules):
        _CONTROLLER[:] = [ThreadpoolController(), len(sys.modules)]
    return _CONTROLLER[0]


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Limit the BLAS thread pools to one thread inside the ``with`` block (or a decorated call)."""
    if _ENVIRONMENT_ONE_THREAD[0]:  # they have one already (declare_one_thread_environment)
        yield
        return
    try:
        controller = _controller()
    except ImportError:  # optional: without it the BLAS pools keep their size
        yield
        return
    with controller.limit(limits=1, user_api="blas"):
        yield
