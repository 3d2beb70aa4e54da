"""Advisory locks of a session file: one writer at a time, readers kept out of a commit.

Two ``flock`` locks, both released by the kernel when their process dies (kill -9 included):

- the **writer lock**, exclusive, on a sidecar ``.<name>.lock`` beside the file. A writer holds
  it while it appends (``station import``) or for a whole run (``station acquire``); a second
  writer waits up to a bounded time, then is refused with one line naming the holder's pid.
- the **commit lock** on the session file itself: exclusive while a save changes bytes in
  place (a few ms, :func:`station.journal.commit`), shared while a reader reads. The HDF5
  library takes the same shared lock on every file it opens, so even a plain h5py reader is
  never shown a half-committed file.

Polling with a short sleep keeps the wait bounded (``flock`` itself has no timeout).
"""

from __future__ import annotations

import errno
import fcntl
import os
import time
from pathlib import Path

from station.errors import StationError

#: Default bounded wait for another writer [s].
WRITER_WAIT_S = 60.0
#: Default bounded wait for the commit lock [s].
COMMIT_WAIT_S = 30.0


class LockTimeout(StationError, TimeoutError):
    """Another process holds the session file's lock longer than the bounded wait."""


class LockUnavailable(StationError, OSError):
    """The lock file beside the session cannot be created (a read-only or full folder)."""


def lock_path(path: Path) -> Path:
    """The writer-lock sidecar of ``path``."""
    return path.with_name(f".{path.name}.lock")


def _flock(fd: int, mode: int, wait_s: float) -> bool:
    deadline = time.monotonic() + max(0.0, wait_s)
    delay = 0.002
    while True:
        try:
            fcntl.flock(fd, mode | fcntl.LOCK_NB)
            return True
        except OSError as exc:
            if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise
        if time.monotonic() >= deadline:
            return False
        time.sleep(delay)
        delay = min(0.05, delay * 2)


class WriterLock:
    """The exclusive writer lock of a session file (re-entrant within one object).

    Parameters
    ----------
    path : Path
        The session file (the lock is its sidecar).
    wait_s : float
        Longest wait for another writer [s].
    """

    def __init__(self, path: Path, wait_s: float = WRITER_WAIT_S) -> None:
        self.path = Path(path)
        self.wait_s = wait_s
        self._fd: int | None = None
        self._depth = 0

    @property
    def held(self) -> bool:
        """True while this object holds the lock."""
        return self._fd is not None

    def acquire(self) -> None:
        """Take the lock, waiting at most ``wait_s``.

        Raises
        ------
        LockTimeout
            Another writer kept it for longer (its pid is in the message).
        """
        if self._fd is not None:
            self._depth += 1
            return
        lp = lock_path(self.path)
        try:
            fd = os.open(lp, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:  # said of the session file, not only of its sidecar
            what = "disk full" if exc.errno == errno.ENOSPC else (exc.strerror or str(exc))
            raise LockUnavailable(f"cannot write {self.path}: {what} (its lock file {lp.name} cannot be "
                                  f"created); nothing was written") from None
        try:
            if not _flock(fd, fcntl.LOCK_EX, self.wait_s):
                holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
                raise LockTimeout(
                    f"{self.path}: another process (pid {holder}) is writing this session file; waited "
                    f"{self.wait_s:g} s; nothing was written, try again when it has finished or write to another file"
                )
            os.ftruncate(fd, 0)
            os.pwrite(fd, str(os.getpid()).encode(), 0)
        except BaseException:
            os.close(fd)
            raise
        self._fd = fd
        self._depth = 1

    def release(self) -> None:
        """Give the lock back (the sidecar stays: removing it would race with a waiter)."""
        if self._fd is None:
            return
        self._depth -= 1
        if self._depth > 0:
            return
        fd, self._fd = self._fd, None
        try:
            os.ftruncate(fd, 0)
        except OSError:
            pass
        os.close(fd)

    def __enter__(self) -> "WriterLock":
        self.acquire()
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    def __del__(self) -> None:  # a dropped writer frees the lock at once, not at exit
        if self._fd is not None:
            self._depth = 1
            self.release()


class FileLock:
    """A shared or exclusive ``flock`` on the session file itself (the commit lock).

    Parameters
    ----------
    path : Path
    exclusive : bool
        Exclusive (a commit) or shared (a read).
    wait_s : float
        Longest wait [s].
    """

    def __init__(self, path: Path, exclusive: bool, wait_s: float = COMMIT_WAIT_S) -> None:
        self.path = Path(path)
        self.exclusive = exclusive
        self.wait_s = wait_s
        self._fd: int | None = None

    def __enter__(self) -> "FileLock":
        try:
            fd = os.open(self.path, os.O_RDONLY)
        except FileNotFoundError:
            return self  # nothing to lock: a missing file is reported by the caller
        mode = fcntl.LOCK_EX if self.exclusive else fcntl.LOCK_SH
        if not _flock(fd, mode, self.wait_s):
            os.close(fd)
            what = "saving to" if self.exclusive else "reading"
            raise LockTimeout(f"{self.path}: busy for more than {self.wait_s:g} s ({what} it; another program "
                              "holds it open or is saving); try again")
        self._fd = fd
        return self

    def __exit__(self, *exc: object) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
