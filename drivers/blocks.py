"""The bounded queue of sample blocks between a driver's reader thread and its caller.

Both drivers (:class:`drivers.daq.Daq` for the serial/USB DAQ, :class:`drivers.audio.AudioDaq`
for PortAudio inputs) read in a background thread and hand blocks over here. The reader puts
blocks, waiting while the queue is full (the link's or the device's own buffering then holds
the data: nothing is dropped silently), and records the device's failure; the caller takes
blocks, waiting at most a timeout. Blocks received before a failure are all returned first,
then the failure is raised (a fresh copy each time). Every wait is bounded.
"""

from __future__ import annotations

import collections
import threading
import time
from typing import Any, Callable

import numpy as np

from drivers.errors import DeviceGoneError, DeviceTimeoutError

#: Longest single wait of a reader on a full queue [s] (it then looks again at ``go_on``).
POLL_S = 0.05


class BlockQueue:
    """Blocks (anything with ``first_sample``, ``counts``, ``si``, ``dropped_before``, ``n_samples``).

    Parameters
    ----------
    url : str
        The device, for messages.
    max_blocks : int
        Bound of the queue.
    cond : threading.Condition, optional
        The driver's condition, when the reader also signals other waiters with it (command
        replies); default a new one.

    Attributes
    ----------
    error : BaseException or None
        The reader's failure (set by :meth:`fail`), raised once the queue is empty.
    closed : bool
    max_seen : int
        Largest number of blocks that waited at once.
    """

    def __init__(self, url: str, max_blocks: int, cond: threading.Condition | None = None) -> None:
        self.url = url
        self.max_blocks = max_blocks
        self.cond = cond if cond is not None else threading.Condition()
        self.error: BaseException | None = None
        self.closed = False
        self.max_seen = 0
        self._blocks: collections.deque[Any] = collections.deque()

    def __len__(self) -> int:
        return len(self._blocks)

    # ------------------------------------------------------------------ reader side
    def wait_for_room(self, go_on: Callable[[], bool] = lambda: True) -> None:
        """Wait while the queue is full, unless closed or ``go_on()`` turns false."""
        with self.cond:
            while len(self._blocks) >= self.max_blocks and not self.closed and go_on():
                self.cond.wait(POLL_S)

    def put(self, block: Any, go_on: Callable[[], bool] = lambda: True) -> None:
        """Append ``block`` once there is room (see :meth:`wait_for_room`) and wake the caller."""
        with self.cond:
            while len(self._blocks) >= self.max_blocks and not self.closed and go_on():
                self.cond.wait(POLL_S)
            self._blocks.append(block)
            self.max_seen = max(self.max_seen, len(self._blocks))
            self.cond.notify_all()

    def fail(self, exc: BaseException, *, unless_closed: bool = False) -> None:
        """Record the reader's failure and wake every waiter."""
        with self.cond:
            if not (unless_closed and self.closed):
                self.error = exc
            self.cond.notify_all()

    def close(self) -> None:
        """No more blocks will come; wake every waiter."""
        with self.cond:
            self.closed = True
            self.cond.notify_all()

    def clear(self) -> None:
        """Drop the blocks waiting."""
        with self.cond:
            self._blocks.clear()
            self.cond.notify_all()

    # ------------------------------------------------------------------ caller side
    def raise_error(self) -> None:
        """Raise (a copy of) the recorded failure, if any."""
        err = self.error
        if err is not None:
            raise type(err)(*err.args)

    def get(self, timeout_s: float) -> Any | None:
        """The next block, or None if none arrives within ``timeout_s`` [s].

        Raises
        ------
        DriverError
            The reader's failure, once every block received before it was taken.
        DeviceGoneError
            Closed and empty.
        """
        deadline = time.monotonic() + timeout_s
        with self.cond:
            while not self._blocks:
                self.raise_error()
                if self.closed:
                    raise DeviceGoneError(f"{self.url}: device closed")
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                self.cond.wait(left)
            block = self._blocks.popleft()
            self.cond.notify_all()
            return block

    def read_samples(self, n: int, timeout_s: float) -> tuple[int, np.ndarray, np.ndarray, int]:
        """At least ``n`` samples: ``(first_sample, counts, si, dropped)`` of consecutive blocks.

        Raises
        ------
        DeviceTimeoutError
            When a block does not come within ``timeout_s`` [s].
        """
        blocks = []
        got = 0
        while got < n:
            b = self.get(timeout_s)
            if b is None:
                raise DeviceTimeoutError(f"{self.url}: no samples within {timeout_s} s after {got} of {n}")
            blocks.append(b)
            got += b.n_samples
        return (blocks[0].first_sample, np.concatenate([b.counts for b in blocks]),
                np.concatenate([b.si for b in blocks]), sum(b.dropped_before for b in blocks[1:]))
