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
  ordinary way (context managers close them, atexit handlers run); ``station diagnose``
  ends quickly unless given a file to write (its forked workers, :mod:`station.forkmap`,
  have all been joined when it prints: ~0.24 s of CPU at load 25 on the double beam).
* **scipy's docstrings.** scipy 1.15-1.17 parse ~650 docstrings at import to append a note
  (:func:`plain_scipy_docs`); :func:`load_quietly` keeps them as written.

Both apply only to a whole ``station`` process (:func:`station.cli.run`), never to
:func:`station.cli.main` called in a caller's interpreter (tests, notebooks).
"""

from __future__ import annotations

import gc
import importlib
import importlib.abc
import importlib.util
import os
import sys
from typing import Iterable, NoReturn


def load_quietly(modules: Iterable[str]) -> None:
    """Import ``modules`` with the cyclic garbage collector paused, then freeze what exists;
    scipy's docstring notes are not written first (:func:`plain_scipy_docs`).

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
        plain_scipy_docs()
        for name in modules:
            importlib.import_module(name)
    finally:
        gc.freeze()  # the imported modules' objects: alive until the process ends, never walked again
        if was_enabled:
            gc.enable()


class _Unparsed:
    """Stands for scipy's ``FunctionDoc`` in :func:`plain_scipy_docs`: the note is dropped and
    the docstring given back as it is (``str`` starts with the signature line the decorator cuts)."""

    __slots__ = ("_doc",)

    def __init__(self, func: object) -> None:
        self._doc = getattr(func, "__doc__", None) or ""

    def __getitem__(self, section: str) -> list:
        return []  # the decorator appends its note here: dropped

    def __str__(self) -> str:
        return "\n" + self._doc


def plain_scipy_docs() -> bool:
    """Keep scipy from parsing and rewriting docstrings while its subpackages import.

    scipy 1.15-1.17 decorate ~650 public functions with ``xp_capabilities``, which parses each
    one's docstring (``scipy._lib._docscrape.FunctionDoc``) to append a table of the array
    libraries it supports: ~0.16 s of CPU (load 24) of the ~1.0 s a ``station diagnose`` spends
    before its first computation (scipy.linalg, optimize, interpolate, signal, stats), ~0.05 s of
    ``station identify``'s. A whole ``station`` process never shows a scipy docstring, so the
    decorator's parser is replaced by :class:`_Unparsed` (the function, its registration and
    its docstring as written; only the note is not added; functions decorated before the call
    keep theirs). Only for the ``station`` executable (:func:`load_quietly`), never in a
    caller's interpreter.

    The decorator's module (``scipy._lib._array_api``) is not imported here: importing it loads
    scipy's array-API layer (numpy.f2py, numpy.testing, charset_normalizer: ~0.09 s on a quiet
    machine), which a command that uses no scipy (``station identify`` of a text record) would
    pay for nothing. When it is not imported yet, a finder on ``sys.meta_path`` replaces the
    parser as the module finishes importing, whenever that is (:class:`_PlainDocsFinder`).

    Returns
    -------
    bool
        True when the parser is replaced, or will be as scipy's module imports (scipy is
        installed); False when scipy is absent or has no such decorator.
    """
    api = sys.modules.get(_ARRAY_API)
    if api is not None:
        return _replace_parser(api)
    if any(isinstance(f, _PlainDocsFinder) for f in sys.meta_path):
        return True
    try:
        if importlib.util.find_spec("scipy") is None:
            return False
    except (ImportError, ValueError):
        return False
    sys.meta_path.insert(0, _PlainDocsFinder())
    return True


_ARRAY_API = "scipy._lib._array_api"


def _replace_parser(api: object) -> bool:
    """:func:`plain_scipy_docs` on the imported module ``api``."""
    if not (callable(getattr(api, "xp_capabilities", None)) and isinstance(getattr(api, "FunctionDoc", None), type)):
        return False
    api.FunctionDoc = _Unparsed
    return True


class _PlainDocsFinder(importlib.abc.MetaPathFinder):
    """Finds nothing itself: when ``scipy._lib._array_api`` is imported, it lets the other finders
    find it and has its loader replace the docstring parser (:func:`_replace_parser`) once the
    module has run, before any subpackage decorates a function; then it leaves ``sys.meta_path``."""

    def find_spec(self, name, path=None, target=None):  # noqa: D102 - the finder protocol
        if name != _ARRAY_API:
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.loader is not None and hasattr(spec.loader, "exec_module"):
            run = spec.loader.exec_module

            def exec_module(module, run=run):
                run(module)
                _replace_parser(module)

            spec.loader.exec_module = exec_module
        return spec


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
