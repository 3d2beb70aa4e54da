"""A ``step()`` loop in a daemon thread, stopped by :meth:`StepLoop.close`; a context manager.

The pty server (:class:`simulated_rig.serve.PtyServer`) and the relay in front of QEMU
(:class:`simulated_rig.relay.PtyRelay`) both run one: they define :meth:`StepLoop.step` (one
round of their work) and :meth:`StepLoop.release` (close their file descriptors). A failure
of the loop ends it and is kept in :attr:`StepLoop.error` for whoever started it.
"""

from __future__ import annotations

import os
import threading
from typing import Any


class StepLoop:
    """Base of a loop thread.

    Attributes
    ----------
    error : BaseException or None
        What ended the loop, if it did not end by :meth:`close`.
    """

    #: Name of the thread (for debuggers and ``threading.enumerate``).
    thread_name = "loop"

    def __init__(self) -> None:
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.error: BaseException | None = None

    def step(self) -> None:  # pragma: no cover - defined by each loop
        """One round of the loop's work (bounded wait)."""
        raise NotImplementedError

    def release(self) -> None:
        """Close what the loop holds (after its thread has stopped)."""

    def stop(self) -> None:
        """Ask the loop to end after its current step (safe from signal handlers and threads)."""
        self._stop.set()

    def run(self) -> None:
        """Step until :meth:`stop` / :meth:`close`, or until a step fails (kept in :attr:`error`)."""
        try:
            while not self._stop.is_set():
                self.step()
        except BaseException as exc:  # recorded for whoever started the thread
            self.error = exc

    def start(self) -> Any:
        """Run the loop in a daemon thread; returns self."""
        self._thread = threading.Thread(target=self.run, name=self.thread_name, daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop the loop, wait for its thread (at most 2 s), then :meth:`release`."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self.release()

    def __enter__(self) -> Any:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()


def close_fds(*fds: int) -> None:
    """Close each descriptor, ignoring those already closed."""
    for fd in fds:
        try:
            os.close(fd)
        except OSError:
            pass
