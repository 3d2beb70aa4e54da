"""The process around one ``station`` command: how it loads the engine and how it ends.

Two costs of a short command that are not the command's work (issue 13, item 1; measured on
``station identify`` of the 45 s x 19.2 kHz record, CPU, ``benchmarks/bench_startup.py``):

* **Loading the engine.** ``station identify`` imports ~600 modules (scipy.interpolate and
  scipy.optimize, pydantic, the engine); every 700 allocations of that import start a pass of
  CPython's cyclic garbage collector, and the oldest generation's passes walk every object
  imported so far. None of it is garbage. :func:`load_quietly` imports the modules a command
  always uses with the collector paused, then moves what they created into the permanent
  generation (:func:`gc.freeze`) and resumes collecting: the command's own objects are
  collected as before. ~0.03-0.05 s.
* **Ending.** The interpreter's teardown (clearing ~600 modules and every object left, the
  exit handlers of the libraries loaded) costs ~0.1 s with the kernels built ahead of time and
  ~0.25 s with numba's JIT loaded. A command that only reads its inputs and prints
  (:data:`QUICK_EXIT` in :mod:`station.cli`) has nothing to tear down once its output is
  flushed: :func:`end_now` flushes stdout and stderr and ends the process with its exit code
  (:func:`os._exit`). A command that writes files, runs workers or holds devices ends the
  ordinary way (context managers close them, atexit handlers run).

Both apply only to a whole ``station`` process (:func:`station.cli.run`), never to
:func:`station.cli.main` called in a caller's interpreter (tests, notebooks).
"""

from __future__ import annotations

import gc
import importlib
import os
import sys
from typing import Iterable, NoReturn


def load_quietly(modules: Iterable[str]) -> None:
    """Import ``modules`` with the cyclic garbage collector paused, then freeze what exists.

    Parameters
    ----------
    modules : iterable of str
        Dotted module names, imported in order.

    Raises
    ------
    ModuleNotFoundError, ImportError
        As :func:`importlib.import_module` (the collector is resumed first).
    """
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        for name in modules:
            importlib.import_module(name)
    finally:
        gc.freeze()  # the imported modules' objects: alive until the process ends, never walked again
        if was_enabled:
            gc.enable()


def end_now(code: int) -> NoReturn:
    """Flush stdout and stderr and end the process with exit code ``code``, skipping the
    interpreter's teardown; when a flush fails (a closed pipe) the ordinary exit runs instead,
    so the failure is reported as it was before."""
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):
        sys.exit(code)
    os._exit(code)
