"""A progress line on stderr for commands that run longer than about a second.

Shown only to a person: when stderr is a terminal and the command was not asked for ``--json``
(piped or machine output stays quiet). Drawn with tqdm: the command's name and the elapsed
time, refreshed from a daemon thread and cleared when the command ends. Commands with a
progress of their own (``acquire``, ``demo`` with their live trigger status) do not use it.

The thread draws only under :data:`DRAW_LOCK`, which a fork takes first (``os.register_at_fork``):
a forked worker (:class:`station.forkmap.ForkMap`) never inherits a lock held mid-draw, so the
thread is marked ``fork_safe`` and does not keep a diagnosis at a terminal in one process (it did
until session 17: the beam's 2-job 8.4 s ran 14.5 s at a terminal).
"""

from __future__ import annotations

import os
import sys
import threading
from types import TracebackType
from typing import TextIO

#: Seconds a command runs before the line appears.
DELAY_S = 1.0
#: Seconds between refreshes.
REFRESH_S = 0.25
#: Held while the line is drawn, and by the forking thread across a fork (module notes).
DRAW_LOCK = threading.Lock()


def _release_after_fork() -> None:
    DRAW_LOCK.release()


os.register_at_fork(before=DRAW_LOCK.acquire, after_in_parent=_release_after_fork,
                    after_in_child=_release_after_fork)


class Working:
    """Context manager: ``with Working("station identify", enabled): ...``.

    Parameters
    ----------
    label : str
        What runs (shown before the elapsed time).
    enabled : bool
        False: do nothing (``--json``, or a command with its own progress).
    stream : text stream
        Where to draw (default ``sys.stderr``); nothing is drawn unless it is a terminal.
    """

    def __init__(self, label: str, enabled: bool = True, stream: TextIO | None = None) -> None:
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = enabled and bool(getattr(self.stream, "isatty", lambda: False)())
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def __enter__(self) -> "Working":
        if self.enabled:
            self._thread = threading.Thread(target=self._run, name="progress", daemon=True)
            self._thread.fork_safe = True  # type: ignore[attr-defined]  # module notes
            self._thread.start()
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)

    def _run(self) -> None:
        if self._stop.wait(DELAY_S):
            return
        from tqdm import tqdm

        class Bar(tqdm):  # no monitor thread of tqdm's own (it would not be fork-safe)
            monitor_interval = 0

        with DRAW_LOCK:
            bar = Bar(total=None, desc=self.label, file=self.stream, leave=False, dynamic_ncols=True,
                      bar_format="{desc}: running {elapsed}")
        try:
            while not self._stop.wait(REFRESH_S):
                with DRAW_LOCK:
                    bar.refresh()
        finally:
            with DRAW_LOCK:
                bar.close()
