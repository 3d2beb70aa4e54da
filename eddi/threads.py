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


def _controller():
    from threadpoolctl import ThreadpoolController

    if _CONTROLLER[0] is None or _CONTROLLER[1] != len(sys.modules):
        _CONTROLLER[:] = [ThreadpoolController(), len(sys.modules)]
    return _CONTROLLER[0]


@contextlib.contextmanager
def one_blas_thread() -> Iterator[None]:
    """Limit the BLAS thread pools to one thread inside the ``with`` block (or a decorated call)."""
    try:
        controller = _controller()
    except ImportError:  # optional: without it the BLAS pools keep their size
        yield
        return
    with controller.limit(limits=1, user_api="blas"):
        yield
