"""One computation run in a second process while this one does another (``station diagnose``).

``station diagnose`` needs two independent results: the pipeline's baseline (the model
``station identify`` gives, its refinement tried: seconds of output-error fits) and the
diagnosis proper (held-out fits of every candidate mechanism: seconds too), and only the
diagnosis' last step reads the baseline. On a machine with two or more cores they run side
by side: :class:`Background` forks a worker (``multiprocessing``, the ``fork`` start method:
no re-import, the arguments are not copied but inherited; the result comes back pickled
through a pipe) and hands the result back when asked. The result is the one the same call gives
in this process (same code, same inputs, one BLAS thread each).

With one core, without ``fork`` (Windows, macOS' default), with other threads running, or with
``STATION_SERIAL=1`` in the environment, the call runs here at once, as before (its errors raised at once). A worker
that dies (killed, out of memory) is replaced by the same call in this process.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
from typing import Any, Callable, Generic, TypeVar

T = TypeVar("T")


def usable_cores() -> int:
    """CPUs this process may run on (its affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def background_allowed() -> bool:
    """True when a second process can run alongside: >= 2 cores, ``fork``, not ``STATION_SERIAL``,
    and no other Python thread (a fork copies the locks other threads may hold: the worker
    could wait on one forever; the CLI has none, a library caller may)."""
    return (usable_cores() >= 2 and "fork" in multiprocessing.get_all_start_methods()
            and os.environ.get("STATION_SERIAL", "") in ("", "0") and threading.active_count() == 1)


def _worker(conn: Any, fn: Callable[..., Any], args: tuple[Any, ...]) -> None:  # pragma: no cover - in the child
    try:
        out: tuple[str, Any] = ("ok", fn(*args))
    except BaseException as exc:  # noqa: BLE001 - handed back to the parent
        out = ("error", exc)
    try:
        conn.send(out)
    except Exception as exc:  # noqa: BLE001 - a result or error that does not pickle
        conn.send(("error", RuntimeError(f"background {getattr(fn, '__name__', 'call')}: {exc}")))
    conn.close()


class Background(Generic[T]):
    """``fn(*args)``, computed in a forked worker when :func:`background_allowed`.

    Calling the object returns the result (waiting for it), or raises the call's error.
    The arguments reach the worker by ``fork`` (not pickled); the result comes back pickled.
    """

    def __init__(self, fn: Callable[..., T], *args: Any) -> None:
        self._fn, self._args = fn, args
        self._proc: Any = None
        self._conn: Any = None
        self._done = False
        self._value: T | None = None
        self._error: BaseException | None = None
        self._forked = False
        if background_allowed():
            self._forked = True
            # (multiprocessing flushes stdout / stderr before it forks: nothing is printed twice)
            ctx = multiprocessing.get_context("fork")
            self._conn, child = ctx.Pipe(duplex=False)
            self._proc = ctx.Process(target=_worker, args=(child, fn, args), daemon=True)
            self._proc.start()
            child.close()
        else:
            self._value, self._done = fn(*args), True

    @property
    def in_background(self) -> bool:
        """True when the call runs (or ran) in a worker process."""
        return self._forked

    def _collect(self) -> None:
        try:
            kind, value = self._conn.recv()
        except (EOFError, OSError):  # the worker died (killed, out of memory): compute it here
            kind, value = "ok", None
            try:
                value = self._fn(*self._args)
            except Exception as exc:  # noqa: BLE001 - kept like the worker's
                kind, value = "error", exc
        self._release()
        if kind == "ok":
            self._value = value
        else:
            self._error = value
        self._done = True

    def __call__(self) -> T:
        if not self._done:
            self._collect()
        if self._error is not None:
            raise self._error
        return self._value  # type: ignore[return-value]

    def failed(self) -> BaseException | None:
        """The call's error once it has finished with one (waiting for it), else None."""
        if not self._done:
            self._collect()
        return self._error

    def close(self) -> None:
        """Stop the worker if its result was not collected (an interrupted command); release it."""
        if self._proc is not None and not self._done and self._proc.is_alive():
            self._proc.terminate()
        self._release()

    def _release(self) -> None:
        if self._proc is not None:
            self._proc.join()
            self._conn.close()
            self._proc = self._conn = None
