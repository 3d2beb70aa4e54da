"""The emulated DAQ firmware: speaks the wire protocol (``docs/protocol.md``) over any byte pipe.

:class:`EmulatedDaq` is transport-free and clock-free: the host's bytes go in through
:meth:`EmulatedDaq.receive`, which returns the reply frames, and sample time advances only when
:meth:`EmulatedDaq.acquire` is called, which returns the DATA frames of the samples acquired.
The pty server (:mod:`simulated_rig.serve`) and the USB backend (:mod:`simulated_rig.usb`)
decide how fast sample time runs: unpaced (as fast as the host reads) or paced to a clock.

The physics is any object with the ``RigSource`` interface (``rate_hz``, ``channels``,
``read(n)``, ``configure(rate_hz=)``, optionally ``deliver_impact`` and ``scenario_json``).
"""

from __future__ import annotations

import dataclasses
import json
import time
from typing import Any, Callable, Protocol, Sequence

import numpy as np

from drivers.channels import ChannelInfo
from drivers.protocol import (
    CONFIGURE_BODY,
    IMPACT_AT_BODY,
    IMPACT_BODY,
    PROTOCOL_VERSION,
    FrameType,
    Message,
    ReplyStatus,
    StreamDecoder,
    encode_data,
    encode_reply,
    sample_width,
)
from drivers.errors import ProtocolError
from simulated_rig.errors import RigError

#: Largest samples per DATA frame the emulated firmware accepts.
MAX_BLOCK_SIZE = 4096


class SampleSource(Protocol):
    """What the firmware needs from the physics (``simulated_rig.source.RigSource`` fits)."""

    rate_hz: float
    channels: tuple[ChannelInfo, ...]

    def read(self, n: int) -> np.ndarray: ...

    def configure(self, rate_hz: float | None = None) -> None: ...


class EmulatedDaq:
    """Firmware of the simulated DAQ.

    Parameters
    ----------
    source : SampleSource
        Produces ADC counts in sample time, shape (n, n_channels) int32 per ``read(n)``.
    model, serial, firmware : str
        Identity reported to the host.
    block_size : int
        Samples per DATA frame at power-on.
    clock : callable returning float, [s]
        Only used to stamp the START reply (``started_at_s``) so a host can measure latency.
    """

    def __init__(
        self,
        source: SampleSource,
        *,
        model: str = "EDDI-SIM-8",
        serial: str = "SIM00001",
        firmware: str = "1.0.0",
        block_size: int = 256,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if len(source.channels) > 32:
            raise RigError(f"the firmware supports at most 32 channels, the source has {len(source.channels)}")
        self.source = source
        self.model = model
        self.serial = serial
        self.firmware = firmware
        self.block_size = block_size
        self.clock = clock
        self.channel_mask = (1 << len(source.channels)) - 1
        self.streaming = False
        self.started_at_s: float | None = None
        self.next_sample = 0  # device sample counter: samples acquired since the last configure
        self.frames_sent = 0
        self._seq = 0
        self._pending: list[np.ndarray] = []  # acquired samples not yet in a frame
        self._pending_n = 0
        self._scheduled: list[tuple[int, float, bool]] = []  # IMPACT_AT blows: (at_sample, peak, double)
        self.impact_errors: list[str] = []
        self._decoder = StreamDecoder()

    # ------------------------------------------------------------------ information
    @property
    def active_channels(self) -> tuple[int, ...]:
        """Indices of the channels in the current mask, ascending."""
        return tuple(i for i in range(len(self.source.channels)) if self.channel_mask >> i & 1)

    @property
    def pending_samples(self) -> int:
        """Samples acquired and not yet sent in a frame."""
        return self._pending_n

    @property
    def width(self) -> int:
        """Bytes per sample on the wire for the active channels."""
        return sample_width(max(self.source.channels[i].adc_bits for i in self.active_channels))

    def info(self) -> dict[str, Any]:
        """The IDENTIFY reply content (see ``docs/protocol.md``)."""
        return {
            "model": self.model,
            "serial": self.serial,
            "firmware": self.firmware,
            "protocol_version": PROTOCOL_VERSION,
            "rate_hz": float(self.source.rate_hz),
            "block_size": self.block_size,
            "channel_mask": self.channel_mask,
            "channels": [dataclasses.asdict(c) for c in self.source.channels],
            "scenario": getattr(self.source, "scenario_json", None),
        }

    # ------------------------------------------------------------------ host -> device
    def receive(self, data: bytes) -> bytes:
        """Take bytes from the host; return the reply frames (and any flushed DATA) to send."""
        out = []
        try:
            messages = self._decoder.feed(data)
        except ProtocolError:
            messages = []  # a host of another version: nothing it says can be trusted
        for msg in messages:
            if isinstance(msg, Message):
                out.append(self._handle(msg))
        return b"".join(out)

    def _reply(self, msg: Message, status: ReplyStatus, content: dict[str, Any]) -> bytes:
        frame = encode_reply(self._seq, msg.seq, msg.frame_type, int(status), content)
        self._seq = (self._seq + 1) & 0xFFFFFFFF
        self.frames_sent += 1
        return frame

    def _handle(self, msg: Message) -> bytes:
        t = msg.frame_type
        if t == FrameType.IDENTIFY:
            return self._reply(msg, ReplyStatus.OK, self.info())
        if t == FrameType.STATUS:
            return self._reply(msg, ReplyStatus.OK, self.status())
        if t == FrameType.START:
            if not self.streaming:
                self.streaming = True
                self.started_at_s = self.clock()
            return self._reply(
                msg, ReplyStatus.OK, {"first_sample": self.next_sample, "started_at_s": self.started_at_s}
            )
        if t == FrameType.STOP:
            flushed = self._flush() if self.streaming else b""
            self.streaming = False
            return flushed + self._reply(msg, ReplyStatus.OK, {"next_sample": self.next_sample})
        if t == FrameType.CONFIGURE:
            return self._configure(msg)
        if t == FrameType.IMPACT:
            return self._impact(msg)
        if t == FrameType.IMPACT_AT:
            return self._impact_at(msg)
        return self._reply(msg, ReplyStatus.BAD_COMMAND, {"error": f"unknown command type 0x{t:02x}"})

    def _configure(self, msg: Message) -> bytes:
        if len(msg.body) != CONFIGURE_BODY.size:
            return self._reply(
                msg, ReplyStatus.BAD_COMMAND,
                {"error": f"configure body must be {CONFIGURE_BODY.size} bytes, got {len(msg.body)}"},
            )
        if self.streaming:
            return self._reply(msg, ReplyStatus.BAD_STATE, {"error": "configure while streaming: stop first"})
        rate_hz, mask, block_size = CONFIGURE_BODY.unpack(msg.body)
        n_ch = len(self.source.channels)
        if mask and mask >> n_ch:
            return self._reply(
                msg, ReplyStatus.BAD_VALUE,
                {"error": f"channel mask 0x{mask:x} names channels beyond the {n_ch} this device has"},
            )
        if block_size and not 1 <= block_size <= MAX_BLOCK_SIZE:
            return self._reply(
                msg, ReplyStatus.BAD_VALUE,
                {"error": f"block size must be 1..{MAX_BLOCK_SIZE} samples, got {block_size}"},
            )
        if rate_hz:
            if not np.isfinite(rate_hz) or rate_hz <= 0:
                return self._reply(msg, ReplyStatus.BAD_VALUE, {"error": f"rate must be positive, got {rate_hz}"})
            try:
                self.source.configure(rate_hz=rate_hz)
            except (RigError, ValueError) as exc:
                return self._reply(msg, ReplyStatus.BAD_VALUE, {"error": str(exc)})
        if mask:
            self.channel_mask = mask
        if block_size:
            self.block_size = block_size
        self.next_sample = 0
        self._pending, self._pending_n = [], 0
        self._scheduled = []
        return self._reply(msg, ReplyStatus.OK, self.info())

    def _impact(self, msg: Message) -> bytes:
        deliver = getattr(self.source, "deliver_impact", None)
        if not callable(deliver):
            return self._reply(msg, ReplyStatus.UNSUPPORTED, {"error": "this device has no hammer"})
        if len(msg.body) != IMPACT_BODY.size:
            return self._reply(
                msg, ReplyStatus.BAD_COMMAND,
                {"error": f"impact body must be {IMPACT_BODY.size} bytes, got {len(msg.body)}"},
            )
        peak, double = IMPACT_BODY.unpack(msg.body)
        try:
            deliver(peak, double_hit=bool(double))
        except (RigError, ValueError) as exc:
            return self._reply(msg, ReplyStatus.BAD_VALUE, {"error": str(exc)})
        return self._reply(msg, ReplyStatus.OK, {"at_sample": self.next_sample + self._pending_n})

    def _impact_at(self, msg: Message) -> bytes:
        """Schedule a blow at a sample counter: sample time, so a run is reproducible."""
        deliver = getattr(self.source, "deliver_impact", None)
        if not callable(deliver):
            return self._reply(msg, ReplyStatus.UNSUPPORTED, {"error": "this device has no hammer"})
        if len(msg.body) != IMPACT_AT_BODY.size:
            return self._reply(
                msg, ReplyStatus.BAD_COMMAND,
                {"error": f"impact-at body must be {IMPACT_AT_BODY.size} bytes, got {len(msg.body)}"},
            )
        peak, double, at = IMPACT_AT_BODY.unpack(msg.body)
        now = self.next_sample + self._pending_n
        if at < now:
            return self._reply(msg, ReplyStatus.BAD_VALUE,
                               {"error": f"impact at sample {at} is in the past (the device is at {now})"})
        if not (np.isfinite(peak) and peak > 0):
            return self._reply(msg, ReplyStatus.BAD_VALUE, {"error": f"impact peak force must be > 0 N, got {peak}"})
        self._scheduled.append((at, peak, bool(double)))
        self._scheduled.sort(key=lambda x: x[0])
        return self._reply(msg, ReplyStatus.OK, {"at_sample": at})

    def status(self) -> dict[str, Any]:
        """The STATUS reply content."""
        return {
            "streaming": self.streaming,
            "next_sample": self.next_sample,
            "pending_samples": self._pending_n,
            "frames_sent": self.frames_sent,
            "rate_hz": float(self.source.rate_hz),
        }

    # ------------------------------------------------------------------ sample time
    def acquire(self, n_samples: int) -> bytes:
        """Advance sample time by ``n_samples`` (if streaming); return the DATA frames completed.

        Samples that do not fill a block wait for the next call (or for STOP, which flushes them).
        """
        if not self.streaming or n_samples <= 0:
            return b""
        counts = self._read_source(n_samples)
        if counts.shape != (n_samples, len(self.source.channels)):
            raise RigError(
                f"source returned shape {counts.shape}, expected ({n_samples}, {len(self.source.channels)})"
            )
        active = self.active_channels
        if len(active) != counts.shape[1]:
            counts = counts[:, active]
        self._pending.append(counts)
        self._pending_n += n_samples
        if self._pending_n < self.block_size:
            return b""
        allc = np.concatenate(self._pending) if len(self._pending) > 1 else self._pending[0]
        n_full = (self._pending_n // self.block_size) * self.block_size
        rest = allc[n_full:]
        self._pending = [rest] if rest.shape[0] else []
        self._pending_n = rest.shape[0]
        return self._frames(allc[:n_full])

    def _read_source(self, n_samples: int) -> np.ndarray:
        """``n_samples`` from the source, delivering scheduled blows at their exact sample."""
        parts = []
        pos = self.next_sample + self._pending_n
        left = n_samples
        while self._scheduled and self._scheduled[0][0] < pos + left:
            at, peak, double = self._scheduled.pop(0)
            if at > pos:
                parts.append(np.asarray(self.source.read(at - pos), dtype=np.int32))
                left -= at - pos
                pos = at
            try:
                self.source.deliver_impact(peak, double_hit=double)  # type: ignore[attr-defined]
            except (RigError, ValueError) as exc:  # e.g. the system diverges: no blow
                self.impact_errors.append(str(exc))
        if left or not parts:
            parts.append(np.asarray(self.source.read(left), dtype=np.int32))
        return parts[0] if len(parts) == 1 else np.concatenate(parts)

    def _flush(self) -> bytes:
        if not self._pending_n:
            return b""
        allc = np.concatenate(self._pending)
        self._pending, self._pending_n = [], 0
        return self._frames(allc)

    def _frames(self, counts: np.ndarray) -> bytes:
        out = []
        width = self.width
        for start in range(0, counts.shape[0], self.block_size):
            block = counts[start : start + self.block_size]
            out.append(encode_data(self._seq, self.next_sample, block, width, self.channel_mask))
            self._seq = (self._seq + 1) & 0xFFFFFFFF
            self.frames_sent += 1
            self.next_sample += block.shape[0]
        return b"".join(out)


class PatternSource:
    """A sample source with exactly known counts, for tests and benchmarks.

    Channel ``c`` at sample ``k`` reads ``(k * (c + 1) + 1000 * c) mod 2**(bits-1)`` with the sign
    alternating per channel, so every count is checkable from its sample index alone.

    Parameters
    ----------
    n_channels : int
    rate_hz : float
    adc_bits : int
        16 or 24.
    rates_hz : sequence of float or None
        Rates :meth:`configure` accepts (None: any positive rate).
    """

    def __init__(
        self, n_channels: int = 2, rate_hz: float = 10_000.0, adc_bits: int = 24,
        rates_hz: Sequence[float] | None = None,
    ) -> None:
        self.rate_hz = rate_hz
        self.rates_hz = tuple(rates_hz) if rates_hz is not None else None
        self.channels = tuple(
            ChannelInfo(
                name=f"ch{c}", quantity="acceleration", unit="m/s^2", scale=1e-3 * (c + 1),
                offset=0.1 * c, range_si=1e-3 * (c + 1) * (1 << (adc_bits - 1)), adc_bits=adc_bits,
                sensitivity=1.0, sensitivity_unit="mV/(m/s^2)",
            )
            for c in range(n_channels)
        )
        self.sample = 0
        self.impacts: list[tuple[int, float, bool]] = []
        self.scenario_json = json.dumps({"source": "pattern", "n_channels": n_channels})

    @staticmethod
    def expected(first_sample: int, n: int, n_channels: int, adc_bits: int = 24) -> np.ndarray:
        """The counts of samples ``first_sample .. first_sample + n - 1``, shape (n, n_channels)."""
        k = np.arange(first_sample, first_sample + n, dtype=np.int64)[:, None]
        c = np.arange(n_channels, dtype=np.int64)[None, :]
        modulus = 1 << (adc_bits - 1)
        sign = np.where(c % 2 == 0, 1, -1)
        return (sign * ((k * (c + 1) + 1000 * c) % modulus)).astype(np.int32)

    def read(self, n: int) -> np.ndarray:
        out = self.expected(self.sample, n, len(self.channels), self.channels[0].adc_bits)
        self.sample += n
        return out

    def configure(self, rate_hz: float | None = None) -> None:
        if rate_hz is not None:
            if self.rates_hz is not None and rate_hz not in self.rates_hz:
                raise RigError(f"rate must be one of {list(self.rates_hz)} Hz, got {rate_hz} Hz")
            self.rate_hz = float(rate_hz)
        self.sample = 0

    def deliver_impact(self, peak_force_n: float, double_hit: bool = False) -> None:
        if peak_force_n <= 0:
            raise RigError(f"impact peak force must be positive, got {peak_force_n} N")
        self.impacts.append((self.sample, peak_force_n, double_hit))
