"""A byte relay between a device's serial port and a pty the host opens, with fault injection.

:class:`PtyRelay` holds the device's port open (so QEMU's pty always has a reader and never
discards what the firmware writes) and gives the host a pty of its own (:attr:`PtyRelay.port`).
Bytes pass unchanged, except that it can corrupt one byte of the k-th DATA frame coming from
the device (``corrupt_data_frame=k``), to show that the host counts the frame and never
delivers it. With ``tap=True`` it also decodes the clean device stream, so a test can compare
what the host delivered with what the device sent.
"""

from __future__ import annotations

import errno
import os
import select
import time
import tty
from dataclasses import dataclass

from drivers.errors import ProtocolError
from drivers.protocol import DataFrame, FrameType, Message, StreamDecoder, decode_one, encode_command
from simulated_rig.errors import EmulatorError
from simulated_rig.loop import StepLoop, close_fds


@dataclass(frozen=True)
class Corruption:
    """One corrupted frame: its device seq, first sample and sample count, and the byte changed.

    Attributes
    ----------
    seq, first_sample, n_samples : int
    offset : int
        Position of the changed byte inside the encoded frame (after its leading 0x00).
    before, after : int
        The byte's value before and after.
    """

    seq: int
    first_sample: int
    n_samples: int
    offset: int
    before: int
    after: int


class PtyRelay(StepLoop):
    """Relay between ``device_path`` and a new pty (a thread; a context manager).

    Parameters
    ----------
    device_path : str
        The device's serial port (e.g. QEMU's ``/dev/pts/N``).
    corrupt_data_frame : int or None
        Change one byte in the middle of this DATA frame (1 = the first one the device sends).
    tap : bool
        Decode the clean device stream into :attr:`tap_frames` (first_sample -> counts).
    """

    def __init__(self, device_path: str, *, corrupt_data_frame: int | None = None, tap: bool = False) -> None:
        try:
            self.device_fd = os.open(device_path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        except OSError as exc:
            raise EmulatorError(f"cannot open the emulator's port {device_path} ({exc.strerror})") from None
        tty.setraw(self.device_fd)
        self.master_fd, self.slave_fd = os.openpty()
        tty.setraw(self.slave_fd)
        os.set_blocking(self.master_fd, False)
        self.port = os.ttyname(self.slave_fd)
        self.device_path = device_path
        self.corrupt_data_frame = corrupt_data_frame
        self.corruptions: list[Corruption] = []
        self.data_frames_seen = 0
        self.bytes_to_host = 0
        self.bytes_to_device = 0
        self.tap_frames: dict[int, DataFrame] = {}
        self._tap = StreamDecoder() if tap else None
        self._segment = bytearray()
        self._to_host = bytearray()
        self._to_device = bytearray()
        super().__init__()
        self.thread_name = f"relay {device_path}"

    # ------------------------------------------------------------------ lifetime
    def wait_for_device(self, timeout_s: float = 20.0, retry_s: float = 0.5) -> None:
        """Before :meth:`start`: send IDENTIFY until the device answers (its reply is not passed on).

        A device that is still booting (QEMU's USART drops what arrives before the firmware has
        enabled it) then cannot lose the host's first command.

        Raises
        ------
        EmulatorError
            When nothing answers within ``timeout_s``.
        """
        probe = encode_command(0, FrameType.IDENTIFY)
        decoder = StreamDecoder()
        deadline = time.monotonic() + timeout_s
        next_try = 0.0
        while time.monotonic() < deadline:
            if time.monotonic() >= next_try:
                _write(self.device_fd, bytearray(probe))
                next_try = time.monotonic() + retry_s
            r, _, _ = select.select([self.device_fd], [], [], 0.05)
            if r:
                try:
                    frames = decoder.feed(_read(self.device_fd))
                except ProtocolError:
                    frames = []
                if any(isinstance(f, Message) and f.frame_type == FrameType.REPLY for f in frames):
                    time.sleep(0.05)           # let any duplicate answers to retries arrive, then drop them
                    while select.select([self.device_fd], [], [], 0.05)[0] and _read(self.device_fd):
                        pass
                    return
        raise EmulatorError(f"the device at {self.device_path} did not answer IDENTIFY within {timeout_s:g} s")

    def release(self) -> None:
        close_fds(self.master_fd, self.slave_fd, self.device_fd)
        self.master_fd = self.slave_fd = self.device_fd = -1

    @property
    def tap_stats(self):
        """Counters of the clean-stream decoder (None without ``tap``)."""
        return None if self._tap is None else self._tap.stats

    # ------------------------------------------------------------------ loop
    def step(self) -> None:
        dev, host = self.device_fd, self.master_fd
        # read the device only while what it sent has been passed on: its own flow control
        rlist = [host] + ([dev] if len(self._to_host) < (1 << 16) else [])
        wlist = ([host] if self._to_host else []) + ([dev] if self._to_device else [])
        r, w, _ = select.select(rlist, wlist, [], 0.05)
        if dev in r:
            data = _read(dev)
            if data:
                self._from_device(data)
        if host in r:
            data = _read(host)
            if data:
                self._to_device += data
        if self._to_device and dev in w:
            n = _write(dev, self._to_device)
            self.bytes_to_device += n
            del self._to_device[:n]
        if self._to_host:
            n = _write(host, self._to_host)
            self.bytes_to_host += n
            del self._to_host[:n]

    def _from_device(self, data: bytes) -> None:
        if self._tap is not None:
            for f in self._tap.feed(data):
                if isinstance(f, DataFrame):
                    self.tap_frames[f.first_sample] = f
        if self.corrupt_data_frame is None or self.corruptions:
            self._to_host += data
            return
        # hold back the unfinished frame until its end, to pick the frame to corrupt
        self._segment += data
        end = self._segment.rfind(b"\x00")
        if end < 0:
            return
        done = bytes(self._segment[: end + 1])
        del self._segment[: end + 1]
        out = bytearray()
        for part in done.split(b"\x00")[:-1]:
            out += self._maybe_corrupt(part) + b"\x00"
        self._to_host += out

    def _maybe_corrupt(self, segment: bytes) -> bytes:
        if not segment or self.corruptions:
            return segment
        try:
            frame = decode_one(b"\x00" + segment + b"\x00")
        except ProtocolError:
            return segment
        if not isinstance(frame, DataFrame):
            return segment
        self.data_frames_seen += 1
        if self.data_frames_seen != self.corrupt_data_frame:
            return segment
        seq, first, n = frame.seq, frame.first_sample, frame.counts.shape[0]
        i = len(segment) // 2
        before = segment[i]
        after = before ^ 0x55 if before != 0x55 else 0xAA   # never 0x00: one frame stays one frame
        self.corruptions.append(Corruption(seq, first, n, i, before, after))
        return segment[:i] + bytes([after]) + segment[i + 1 :]


def _read(fd: int) -> bytes:
    try:
        return os.read(fd, 65536)
    except OSError as exc:
        if exc.errno in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EIO):
            return b""   # EIO: nobody has the other side open yet
        raise


def _write(fd: int, data: bytearray) -> int:
    try:
        return os.write(fd, data)
    except OSError as exc:
        if exc.errno in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EIO):
            return 0
        raise
