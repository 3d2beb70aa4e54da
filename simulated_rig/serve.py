"""Serving the emulated DAQ on a pseudo-terminal, so the host's real serial code path runs.

:class:`PtyServer` opens a pty pair, keeps the master side and gives the slave's path
(:attr:`PtyServer.port`) to the host, which opens it like any serial port
(``serial:///dev/pts/N``). The server loop moves command bytes to the firmware and DATA frames
back, advancing sample time either

* unpaced (``paced=False``): as fast as the host takes the bytes. The pty's own buffer is the
  flow control, so nothing is ever dropped and runs are fast and deterministic (tests);
* paced (``paced=True``): to a clock (``time.monotonic`` unless one is injected), like real
  hardware. If the host does not keep up, the device FIFO (``fifo_bytes``) overflows and the
  frames that do not fit are discarded, which the host sees as a gap in the sample counter.
"""

from __future__ import annotations

import errno
import os
import select
import threading
import time
import tty
from typing import Callable

from simulated_rig.device import EmulatedDaq
from simulated_rig.errors import RigError


class PtyServer:
    """The emulated DAQ behind a pty.

    Parameters
    ----------
    device : EmulatedDaq
    paced : bool
        Advance sample time with ``clock`` (True) or as fast as the host reads (False).
    clock : callable returning float, [s]
    link : str or None
        If given, a symlink to the pty at this path (a stable name across restarts).
    fifo_bytes : int
        Device output FIFO in paced mode, [bytes].
    tick_s : float
        Longest wait of the loop, [s].
    """

    def __init__(
        self,
        device: EmulatedDaq,
        *,
        paced: bool = False,
        clock: Callable[[], float] = time.monotonic,
        link: str | None = None,
        fifo_bytes: int = 4 << 20,
        tick_s: float = 0.002,
    ) -> None:
        self.device = device
        self.paced = paced
        self.clock = clock
        self.fifo_bytes = fifo_bytes
        self.tick_s = tick_s
        self.overrun_frames = 0
        self.master_fd, self.slave_fd = os.openpty()
        tty.setraw(self.slave_fd)  # no echo, no line discipline, before anyone opens it
        os.set_blocking(self.master_fd, False)
        self.port = os.ttyname(self.slave_fd)
        self.link = link
        if link is not None:
            try:
                _replace_own_link(link, self.port)
            except RigError:
                os.close(self.master_fd)
                os.close(self.slave_fd)
                raise
        self._out = bytearray()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._t0: float | None = None
        self._produced = 0
        self.error: BaseException | None = None

    # ------------------------------------------------------------------ lifetime
    def start(self) -> "PtyServer":
        """Run the loop in a daemon thread; returns self."""
        self._thread = threading.Thread(target=self.serve_forever, name=f"rig {self.port}", daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop the loop and close the pty: the host then sees the device disappear."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        for fd in (self.master_fd, self.slave_fd):
            try:
                os.close(fd)
            except OSError:
                pass
        self.master_fd = self.slave_fd = -1
        if self.link is not None and os.path.islink(self.link) and os.readlink(self.link) == self.port:
            os.unlink(self.link)  # only our own link: a later server may have taken the name

    def __enter__(self) -> "PtyServer":
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ loop
    def serve_forever(self) -> None:
        """Serve until :meth:`close` (or until the pty fails)."""
        try:
            while not self._stop.is_set():
                self.step()
        except BaseException as exc:  # recorded for whoever started the thread
            self.error = exc

    def step(self) -> None:
        """One round: wait for the pty, take commands, acquire samples, write what fits."""
        fd = self.master_fd
        dev = self.device
        want_write = bool(self._out) or (dev.streaming and not self.paced)
        timeout = self.tick_s if (dev.streaming or self._out) else 0.05
        r, w, _ = select.select([fd], [fd] if want_write else [], [], timeout)
        if r:
            try:
                data = os.read(fd, 65536)
            except OSError as exc:
                if exc.errno in (errno.EAGAIN, errno.EWOULDBLOCK):
                    data = b""
                elif exc.errno == errno.EIO:  # no host has the slave open: nothing to read
                    data = b""
                else:
                    raise
            if data:
                self._out += dev.receive(data)
        if dev.streaming:
            if self._t0 is None:
                self._t0 = self.clock()
                self._produced = 0
            if self.paced:
                due = int((self.clock() - self._t0) * dev.source.rate_hz) - self._produced
                while due > 0:  # block by block, as the firmware's acquisition interrupt would
                    n = min(due, dev.block_size)
                    frames = dev.acquire(n)
                    self._produced += n
                    due -= n
                    if len(self._out) + len(frames) > self.fifo_bytes:
                        self.overrun_frames += frames.count(b"\x00") // 2
                    else:
                        self._out += frames
            elif len(self._out) < 65536:
                n = max(dev.block_size, 4096 // max(1, len(dev.active_channels)))
                self._out += dev.acquire(n)
                self._produced += n
        else:
            self._t0 = None
        if self._out:
            try:
                written = os.write(fd, self._out)
            except OSError as exc:
                if exc.errno in (errno.EAGAIN, errno.EWOULDBLOCK):
                    written = 0
                elif exc.errno == errno.EIO:
                    written = 0
                else:
                    raise
            del self._out[:written]
            if not written and not r:
                time.sleep(0)  # let the host thread run


def serve_source(source: object, *, paced: bool, link: str | None = None, **device_options: object) -> PtyServer:
    """Start an :class:`EmulatedDaq` around ``source`` on a pty, in a thread.

    Raises
    ------
    RigError
        When the source does not fit the firmware.
    """
    if not hasattr(source, "read") or not hasattr(source, "channels"):
        raise RigError(f"a rig source needs read() and channels, got {type(source).__name__}")
    device = EmulatedDaq(source, **device_options)  # type: ignore[arg-type]
    return PtyServer(device, paced=paced, link=link).start()


def _replace_own_link(link: str, port: str) -> None:
    """Point the symlink ``link`` at ``port``, replacing only a link to a pty (a previous server's).

    Raises
    ------
    RigError
        ``link`` exists and is a regular file, a folder, or a link to something else.
    """
    if os.path.lexists(link):
        if not os.path.islink(link):
            raise RigError(f"--link {link}: exists and is not a symbolic link; refusing to replace it")
        target = os.readlink(link)
        if not target.startswith("/dev/pts/"):
            raise RigError(f"--link {link}: is a link to {target}, not to a pty a rig made; refusing to replace it")
        os.unlink(link)
    try:
        os.symlink(port, link)
    except FileNotFoundError:
        raise RigError(f"--link {link}: the folder {os.path.dirname(link) or '.'} does not exist") from None
