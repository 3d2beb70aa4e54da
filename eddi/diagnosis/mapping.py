"""How the diagnosis runs its independent per-fold work: a ``map``-like callable.

The folds of :func:`eddi.diagnosis.diagnose` (the baseline refitted and refined without one
part, every candidate refitted, the noise floor's perturbed refits) do not depend on one
another. The engine stays pure numerics and starts no process: it calls ``mapper(fn, items)``
(:data:`Mapper`) and uses the list it returns, in the order of ``items``. The default,
:func:`serial_map`, runs them here one after the other; a caller with free cores may pass a
mapper that runs them in other processes (``station diagnose`` does:
:mod:`station.forkmap`). ``fn`` may be a closure over large arrays: a mapper must either run it
in this process or in a forked copy of it (nothing is pickled but the items' results).
The results are the same either way (the same code on the same inputs).

A mapper may also offer ``done(key) -> (bool, result)``: work its caller queued beforehand
because it depends on nothing computed since (:meth:`station.forkmap.ForkMap.beside`; the
noise floor's perturbed records, :func:`eddi.diagnosis.measure.draw_jobs`), done where a map
left a core idle. The engine takes such a result only under the key it would have queued
itself, and computes what is missing.
"""

from __future__ import annotations

from typing import Any, Callable, Sequence

#: ``mapper(fn, items) -> [fn(item) for item in items]``, possibly in other processes.
Mapper = Callable[[Callable[[Any], Any], Sequence[Any]], list]


def serial_map(fn: Callable[[Any], Any], items: Sequence[Any]) -> list:
    """``[fn(item) for item in items]`` in this process (the default :data:`Mapper`)."""
    return [fn(item) for item in items]
