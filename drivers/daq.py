"""The DAQ device API: open, identify, configure, start, read blocks of samples, stop.

A :class:`Daq` owns one transport and one background reader thread. The reader decodes every
byte (:class:`drivers.protocol.StreamDecoder`), hands replies to the command that waits for
them and puts sample blocks in a bounded queue. When the queue is full the reader waits
(the link's own flow control, or the device's FIFO, then holds the data) instead of dropping
blocks silently; every sample the device lost shows in :attr:`Block.dropped_before` and in
:attr:`Daq.stats`. Nothing blocks forever: every wait has a timeout.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from drivers.blocks import BlockQueue
from drivers.channels import ChannelInfo
from drivers.errors import DeviceError, DeviceGoneError, DeviceTimeoutError, DriverError, ProtocolError, ProtocolVersionError
from drivers.protocol import PROTOCOL_VERSION, DataFrame, FrameType, Message, ReplyStatus, StreamDecoder, encode_command
from drivers.transport import Transport


@dataclass(frozen=True)
class DeviceInfo:
    """What a device says about itself (IDENTIFY / CONFIGURE reply).

    Attributes
    ----------
    model, serial, firmware : str
    protocol_version : int
    rate_hz : float
        Sample rate as the device actually runs it, [Hz].
    channels : tuple of ChannelInfo
        The active channels, in the column order of :attr:`Block.counts`.
    block_size : int
        Samples per DATA frame.
    available_channels : tuple of ChannelInfo
        Every channel of the device (``channel_mask`` selects ``channels`` from these).
    channel_mask : int
    scenario_json : str or None
        The simulated rig's scenario (None on real hardware).
    """

    model: str
    serial: str
    firmware: str
    protocol_version: int
    rate_hz: float
    channels: tuple[ChannelInfo, ...]
    block_size: int
    available_channels: tuple[ChannelInfo, ...] = ()
    channel_mask: int = 0
    scenario_json: str | None = None

    @classmethod
    def from_reply(cls, content: dict[str, Any]) -> "DeviceInfo":
        """Build from the JSON content of an IDENTIFY or CONFIGURE reply.

        Raises
        ------
        ProtocolVersionError
            When the device reports another protocol version.
        ProtocolError
            When a field is missing or malformed.
        """
        version = content.get("protocol_version")
        if version != PROTOCOL_VERSION:
            raise ProtocolVersionError(
                f"device speaks protocol version {version}, this driver speaks version {PROTOCOL_VERSION}"
            )
        try:
            fields = {f.name for f in dataclasses.fields(ChannelInfo)}
            every = tuple(ChannelInfo(**{k: v for k, v in c.items() if k in fields}) for c in content["channels"])
            mask = int(content["channel_mask"])
            return cls(
                model=str(content["model"]),
                serial=str(content["serial"]),
                firmware=str(content["firmware"]),
                protocol_version=int(version),
                rate_hz=float(content["rate_hz"]),
                channels=tuple(c for i, c in enumerate(every) if mask >> i & 1),
                block_size=int(content["block_size"]),
                available_channels=every,
                channel_mask=mask,
                scenario_json=content.get("scenario"),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ProtocolError(f"device information must hold model, serial, channels...; bad field: {exc}") from None


@dataclass(frozen=True)
class Block:
    """A block of consecutive samples.

    Attributes
    ----------
    first_sample : int
        Device sample counter of row 0 (time = first_sample / rate_hz since the last configure).
    counts : ndarray, shape (n, n_channels), int32
        Raw ADC counts.
    si : ndarray, shape (n, n_channels), float
        Values in SI units (``counts * scale + offset`` per channel).
    dropped_before : int
        Samples lost just before this block (0 when none).
    """

    first_sample: int
    counts: np.ndarray
    si: np.ndarray
    dropped_before: int = 0

    @property
    def n_samples(self) -> int:
        return int(self.counts.shape[0])


@dataclass(frozen=True)
class Stats:
    """Link statistics (exact counts since open).

    Attributes
    ----------
    frames, bytes : int
        Good frames and all bytes received.
    crc_errors, framing_errors, resyncs : int
        Frames failing their CRC, chunks that were not frames, and times the decoder skipped
        to the next delimiter.
    dropped_samples : int
        Samples missing from the stream (from the device sample counter).
    lost_frames : int
        Frames missing from the device frame sequence (forward gaps only; never wraps).
    stale_frames : int
        Frames whose sequence number lies behind the last one (duplicated or reordered).
    repeated_samples : int
        Samples of blocks going backwards in the sample counter (never delivered twice).
    samples : int
        Samples received in good blocks.
    malformed : int
        CRC-valid frames contradicting the protocol.
    queue_max : int
        Largest number of blocks waiting in the queue.
    """

    frames: int = 0
    bytes: int = 0
    crc_errors: int = 0
    framing_errors: int = 0
    resyncs: int = 0
    dropped_samples: int = 0
    lost_frames: int = 0
    stale_frames: int = 0
    repeated_samples: int = 0
    samples: int = 0
    malformed: int = 0
    queue_max: int = 0


class Daq:
    """One DAQ device speaking the EDDI wire protocol (a context manager).

    Parameters
    ----------
    transport : Transport
        An open byte transport (see :func:`drivers.open_device`).
    timeout_s : float
        How long a command waits for its reply, [s].
    queue_blocks : int
        Bound of the block queue.
    on_close : sequence of callables
        Run after the transport is closed (e.g. to stop a simulated rig).

    Raises
    ------
    DeviceTimeoutError, ProtocolVersionError, DeviceGoneError
        When the device does not identify itself properly.
    """

    READ_CHUNK = 1 << 16

    def __init__(
        self,
        transport: Transport,
        *,
        timeout_s: float = 2.0,
        queue_blocks: int = 1024,
        on_close: Sequence[Callable[[], None]] = (),
    ) -> None:
        self.transport = transport
        self.url = transport.url
        self.timeout_s = timeout_s
        self.queue_blocks = queue_blocks
        self._on_close = list(on_close)
        self._decoder = StreamDecoder()
        self._cond = threading.Condition()
        self._queue = BlockQueue(self.url, queue_blocks, self._cond)
        self._replies: dict[int, Message] = {}
        self._awaited: set[int] = set()  # seqs of commands waiting for their reply
        self._waiting_command = 0
        self._seq = 0
        self.streaming = False
        self.start_reply: dict[str, Any] = {}
        self.info: DeviceInfo
        self._scale = np.ones(0)
        self._offset = np.zeros(0)
        try:
            self.transport.flush_input()
            self._reader = threading.Thread(target=self._read_loop, name=f"daq-reader {self.url}", daemon=True)
            self._reader.start()
            self._command(FrameType.STOP)  # a stream left running by a previous session ends here
            self._set_info(DeviceInfo.from_reply(self._command(FrameType.IDENTIFY)))
            self._queue.clear()
        except BaseException:
            self.close()
            raise

    # ------------------------------------------------------------------ context manager
    def __enter__(self) -> "Daq":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Stop streaming (best effort), close the transport, run the close hooks (idempotent)."""
        if self._queue.closed:
            return
        if self.streaming and self._queue.error is None:
            try:
                self.stop()
            except DriverError:
                pass
        self._queue.close()
        reader = getattr(self, "_reader", None)
        if reader is not None and reader is not threading.current_thread():
            reader.join(timeout=2.0)
        self.transport.close()
        for hook in self._on_close:
            hook()

    # ------------------------------------------------------------------ commands
    def configure(
        self,
        rate_hz: float | None = None,
        channels: Sequence[str | int] | None = None,
        block_size: int | None = None,
    ) -> DeviceInfo:
        """Set the sample rate [Hz], the active channels (names or indices) and the block size.

        Returns the device information as the device now runs (the rate it actually uses).
        Resets the device sample counter to 0.

        Raises
        ------
        DeviceError
            When the device refuses a value (the message is the device's).
        """
        mask = 0
        if channels is not None:
            names = [c.name for c in self.info.available_channels]
            for ch in channels:
                if isinstance(ch, str):
                    if ch not in names:
                        raise DeviceError(f"unknown channel {ch!r}; the device has {names}")
                    mask |= 1 << names.index(ch)
                else:
                    if not 0 <= int(ch) < len(names):
                        raise DeviceError(f"channel index must be 0..{len(names) - 1}, got {ch}")
                    mask |= 1 << int(ch)
            if not mask:
                raise DeviceError("at least one channel must be selected, got none")
        reply = self._command(
            FrameType.CONFIGURE, rate_hz=float(rate_hz or 0.0), channel_mask=mask, block_size=int(block_size or 0)
        )
        self._set_info(DeviceInfo.from_reply(reply))
        return self.info

    def identify(self) -> DeviceInfo:
        """Ask the device for its information again."""
        self._set_info(DeviceInfo.from_reply(self._command(FrameType.IDENTIFY)))
        return self.info

    def start(self) -> None:
        """Start streaming; blocks then arrive through :meth:`read_block`."""
        self.start_reply = self._command(FrameType.START)
        self.streaming = True

    def stop(self) -> None:
        """Stop streaming. Blocks already received stay readable; samples lost at the end are counted."""
        self._command(FrameType.STOP)
        self.streaming = False

    def status(self) -> dict[str, Any]:
        """The device's STATUS reply (streaming flag, sample counter...)."""
        return self._command(FrameType.STATUS)

    def impact(self, peak_force_n: float, double_hit: bool = False, at_sample: int | None = None) -> int | None:
        """Deliver a hammer impact of ``peak_force_n`` [N] (simulated rig only).

        With ``at_sample`` the blow is scheduled at that device sample counter (sample time:
        the run is reproducible whatever the host's speed); else it comes now.

        Returns the device sample counter when the command took effect (the blow follows
        the rig's own delay), or None if the device does not say.

        Raises
        ------
        DeviceError
            On a real DAQ (no hammer) or a refused force.
        """
        if at_sample is not None:
            reply = self._command(FrameType.IMPACT_AT, peak_force_n=float(peak_force_n), double_hit=double_hit,
                                  at_sample=int(at_sample))
        else:
            reply = self._command(FrameType.IMPACT, peak_force_n=float(peak_force_n), double_hit=double_hit)
        at = reply.get("at_sample")
        return int(at) if isinstance(at, int) else None

    # ------------------------------------------------------------------ data
    def read_block(self, timeout_s: float | None = None) -> Block | None:
        """The next block of samples, or None if none arrives within ``timeout_s`` [s].

        ``timeout_s=None`` waits at most the driver timeout. Blocks received before the device
        disappeared are all returned first; then :class:`DeviceGoneError` is raised.
        """
        return self._queue.get(self.timeout_s if timeout_s is None else timeout_s)

    def read_samples(self, n: int, timeout_s: float | None = None) -> tuple[int, np.ndarray, np.ndarray, int]:
        """Read at least ``n`` samples: ``(first_sample, counts, si, dropped)`` (concatenated blocks).

        Raises
        ------
        DeviceTimeoutError
            When a block does not come within the timeout.
        """
        return self._queue.read_samples(n, self.timeout_s if timeout_s is None else timeout_s)

    @property
    def stats(self) -> Stats:
        """Snapshot of the link statistics."""
        s = self._decoder.stats
        return Stats(
            frames=s.frames, bytes=s.bytes, crc_errors=s.crc_errors, framing_errors=s.framing_errors,
            resyncs=s.resyncs, dropped_samples=s.dropped_samples, lost_frames=s.lost_frames,
            stale_frames=s.stale_frames, repeated_samples=s.repeated_samples, samples=s.samples, malformed=s.malformed, queue_max=self._queue.max_seen,
        )

    # ------------------------------------------------------------------ internals
    def _set_info(self, info: DeviceInfo) -> None:
        self.info = info
        self._scale = np.array([c.scale for c in info.channels], dtype=float)
        self._offset = np.array([c.offset for c in info.channels], dtype=float)

    def _command(self, command: FrameType, **params: Any) -> dict[str, Any]:
        if self._queue.closed and command != FrameType.STOP:
            raise DeviceGoneError(f"{self.url}: device closed")
        with self._cond:
            self._queue.raise_error()
            seq = self._seq
            self._seq = (self._seq + 1) & 0xFFFFFFFF
            self._waiting_command += 1
            self._awaited.add(seq)
        try:
            self.transport.write(encode_command(seq, command, **params))
            deadline = time.monotonic() + self.timeout_s
            with self._cond:
                self._cond.notify_all()  # let a reader waiting on a full queue go on
                while seq not in self._replies:
                    self._queue.raise_error()
                    left = deadline - time.monotonic()
                    if left <= 0:
                        raise DeviceTimeoutError(
                            f"{self.url}: no reply to {command.name} within {self.timeout_s} s "
                            "(is it an EDDI DAQ, and is it powered?)"
                        )
                    self._cond.wait(left)
                msg = self._replies.pop(seq)
        finally:
            with self._cond:
                self._waiting_command -= 1
                self._awaited.discard(seq)
                self._replies.pop(seq, None)
        _, ctype, status, content = msg.reply()
        if ctype != command:
            raise ProtocolError(f"reply to {command.name} names command 0x{ctype:02x}")
        if status != ReplyStatus.OK:
            why = content.get("error", "no reason given")
            raise DeviceError(f"{self.url}: device refused {command.name}: {why}")
        return content

    def _read_loop(self) -> None:
        try:
            while not self._queue.closed:
                data = self.transport.read(self.READ_CHUNK, 0.05)
                if not data:
                    continue
                for frame in self._decoder.feed(data):
                    if isinstance(frame, DataFrame):
                        self._put_block(frame)
                    elif frame.frame_type == FrameType.REPLY:
                        try:
                            cseq = frame.reply()[0]
                        except ProtocolError:
                            continue
                        with self._cond:
                            if cseq in self._awaited:  # a duplicated or unasked-for reply is dropped
                                self._replies[cseq] = frame
                                self._cond.notify_all()
        except DriverError as exc:
            self.streaming = False
            self._queue.fail(exc, unless_closed=True)
        except BaseException as exc:  # pragma: no cover - a bug: surface it to the caller
            self._queue.fail(DriverError(f"{self.url}: reader failed: {type(exc).__name__}: {exc}"))

    def _put_block(self, frame: DataFrame) -> None:
        counts = frame.counts
        if counts.shape[1] != self._scale.shape[0]:
            self._decoder.stats.malformed += 1
            return
        si = counts * self._scale + self._offset
        # a command waiting for its reply lets the reader go on (the reply may follow this block)
        self._queue.put(Block(frame.first_sample, counts, si, frame.dropped_before),
                        go_on=lambda: not self._waiting_command)
