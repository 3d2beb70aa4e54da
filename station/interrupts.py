"""Ctrl-C held back while a capture is written, then delivered.

A SIGINT that lands inside h5py's file driver (its Python-level write callback, or an object's
deallocation) cannot propagate: Python prints "Exception ignored in ..." with a traceback, and the
file may be left half written. :func:`held_interrupt` lets the write finish, then raises the
``KeyboardInterrupt`` it held, so the command stops with its one line and everything saved is
whole.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


@contextmanager
def held_interrupt() -> Iterator[None]:
    """Hold SIGINT for the duration of the block (main thread only; elsewhere a no-op) and
    raise ``KeyboardInterrupt`` after it when one arrived."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: list[int] = []

    def hold(signum: int, _frame: Any) -> None:
        got.append(signum)

    try:
        previous = signal.signal(signal.SIGINT, hold)
    except ValueError:  # not the main interpreter
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if got:
        raise KeyboardInterrupt
