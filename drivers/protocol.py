"""The EDDI DAQ wire protocol, version 1: frame codec and vectorised stream decoder.

The format is specified in ``docs/protocol.md``; this module is its reference implementation.
In short, every frame is::

    0x00 COBS( version:u8 | type:u8 | seq:u32 | body | crc32:u32 ) 0x00

all integers little-endian, CRC-32 (zlib polynomial) over everything before it. Data frames
carry the device's sample counter, so every lost sample is counted exactly from the next
good frame.

The bulk path (:class:`StreamDecoder`) splits on 0x00, COBS-decodes every frame with the
``cobs`` package's C codec, checks its CRC with :func:`zlib.crc32` and unpacks the 16/24-bit
samples of all frames of one layout in one numpy pass. Nothing is compiled at run time, so the
first frame of a process decodes as fast as the millionth (no JIT inside a command timeout).
"""

from __future__ import annotations

import enum
import json
import struct
import zlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from cobs import cobs as _cobs

from drivers.errors import ProtocolError, ProtocolVersionError

#: Version of the wire protocol this module speaks (byte 0 of every frame).
PROTOCOL_VERSION = 1

#: Largest decoded frame (header + body + CRC) a conforming device sends, [bytes].
MAX_FRAME_BYTES = 65536

#: Bytes before the body: version u8, type u8, seq u32.
HEADER = struct.Struct("<BBI")
#: Data-frame body header: first_sample u64, n_samples u16, n_channels u8, width u8, mask u32.
DATA_HEADER = struct.Struct("<QHBBI")
#: Reply body header: command seq u32, command type u8, status u8 (then UTF-8 JSON).
REPLY_HEADER = struct.Struct("<IBB")
#: CONFIGURE body: rate_hz f64 (0 = keep), channel_mask u32 (0 = keep), block_size u16 (0 = keep).
CONFIGURE_BODY = struct.Struct("<dIH")
#: IMPACT body: peak_force_n f64, double_hit u8.
IMPACT_BODY = struct.Struct("<dB")
#: IMPACT_AT body: peak_force_n f64, double_hit u8, at_sample u64.
IMPACT_AT_BODY = struct.Struct("<dBQ")
CRC = struct.Struct("<I")
#: CRC-32 of any message followed by its own CRC (little-endian): checking it needs no slicing.
CRC_RESIDUE = 0x2144DF1C

DATA_OFFSET = HEADER.size + DATA_HEADER.size  # first sample byte in a decoded data frame
FRAME_OVERHEAD = HEADER.size + CRC.size


class FrameType(enum.IntEnum):
    """Frame types (byte 1 of every frame)."""

    DATA = 0x01  # device -> host: a block of samples
    REPLY = 0x02  # device -> host: the answer to one command
    IDENTIFY = 0x41  # host -> device
    CONFIGURE = 0x42
    START = 0x43
    STOP = 0x44
    STATUS = 0x45
    IMPACT = 0x46  # simulated rig only: deliver a hammer impact
    IMPACT_AT = 0x47  # simulated rig only: deliver a hammer impact at a given sample counter


COMMAND_TYPES = frozenset(
    {FrameType.IDENTIFY, FrameType.CONFIGURE, FrameType.START, FrameType.STOP, FrameType.STATUS, FrameType.IMPACT,
     FrameType.IMPACT_AT}
)


class ReplyStatus(enum.IntEnum):
    """Status byte of a reply."""

    OK = 0
    BAD_COMMAND = 1  # unknown type or malformed body
    BAD_VALUE = 2  # a parameter outside what the device supports
    BAD_STATE = 3  # e.g. configure while streaming
    UNSUPPORTED = 4  # e.g. impact on a real DAQ


# --------------------------------------------------------------------------------------------
# checksum and byte stuffing: C codecs, nothing compiled at run time


def crc32(data: bytes | bytearray | memoryview | np.ndarray) -> int:
    """CRC-32 as used by the protocol (:func:`zlib.crc32`, CRC-32/ISO-HDLC)."""
    return zlib.crc32(data)


def cobs_encode(payload: bytes) -> bytes:
    """COBS-encode ``payload`` (the ``cobs`` package's C codec) and append the 0x00 delimiter."""
    return _cobs.encode(payload) + b"\x00"


def unpack_samples(buffer: bytes, offset: int, stride: int, n_frames: int, n: int, nch: int,
                   width: int) -> np.ndarray:
    """Little-endian two's-complement samples of ``n_frames`` equal frames -> int32, in one pass.

    Parameters
    ----------
    buffer : bytes
        The frames back to back, ``stride`` bytes each; at least one byte follows the last
        sample (a frame's CRC does).
    offset : int
        First sample byte of frame 0.
    n_frames, n, nch, width : int
        Frames, samples per frame, channels, bytes per sample (2 or 3).

    Returns
    -------
    ndarray, shape (n_frames, n, nch), int32
    """
    if width == 2:
        raw = np.ndarray((n_frames, n * nch), dtype="<i2", buffer=buffer, offset=offset, strides=(stride, 2))
        return raw.astype(np.int32).reshape(n_frames, n, nch)
    # each 24-bit sample read as the 32-bit word starting at it; the top byte is the next
    # sample's (or the CRC's) and is shifted out, the arithmetic shift extends the sign
    raw = np.ndarray((n_frames, n * nch), dtype="<i4", buffer=buffer, offset=offset, strides=(stride, 3))
    out = np.left_shift(raw, 8)
    out >>= 8
    return out.reshape(n_frames, n, nch)


# --------------------------------------------------------------------------------------------
# encoding


def encode_frame(frame_type: int, seq: int, body: bytes = b"", *, version: int = PROTOCOL_VERSION) -> bytes:
    """One frame on the wire: 0x00, COBS(header | body | CRC), 0x00.

    The leading 0x00 makes a frame that follows a truncated one arrive intact; empty
    segments between delimiters mean nothing.

    Parameters
    ----------
    frame_type : int
        A :class:`FrameType`.
    seq : int
        Sender's frame counter, wraps at 2**32.
    body : bytes
        Type-specific body.
    version : int
        Protocol version byte (only tests send another one).
    """
    raw = HEADER.pack(version, int(frame_type), seq & 0xFFFFFFFF) + body
    raw += CRC.pack(crc32(raw))
    if len(raw) > MAX_FRAME_BYTES:
        raise ProtocolError(f"frame of {len(raw)} bytes exceeds the limit of {MAX_FRAME_BYTES} bytes")
    return b"\x00" + cobs_encode(raw)


def sample_width(adc_bits: int) -> int:
    """Bytes per sample on the wire for an ADC resolution: 2 for <= 16 bits, else 3."""
    if adc_bits <= 16:
        return 2
    if adc_bits <= 24:
        return 3
    raise ProtocolError(f"ADC resolution must be at most 24 bits, got {adc_bits}")


def pack_samples(counts: np.ndarray, width: int) -> bytes:
    """Interleaved little-endian two's-complement samples.

    Parameters
    ----------
    counts : ndarray, shape (n_samples, n_channels), int
        ADC counts; must fit ``width`` bytes.
    width : int
        2 or 3 bytes per sample.
    """
    c = np.ascontiguousarray(counts, dtype="<i4")
    as_bytes = c.view(np.uint8).reshape(c.shape[0], c.shape[1], 4)
    return as_bytes[:, :, :width].tobytes()


def encode_data(seq: int, first_sample: int, counts: np.ndarray, width: int, channel_mask: int) -> bytes:
    """A DATA frame holding ``counts`` (shape (n_samples, n_channels)) from ``first_sample`` on."""
    n, nch = counts.shape
    body = DATA_HEADER.pack(first_sample, n, nch, width, channel_mask) + pack_samples(counts, width)
    return encode_frame(FrameType.DATA, seq, body)


def encode_reply(seq: int, command_seq: int, command_type: int, status: int, content: dict[str, Any]) -> bytes:
    """A REPLY frame answering command ``command_seq`` with a JSON object."""
    body = REPLY_HEADER.pack(command_seq & 0xFFFFFFFF, command_type, status)
    body += json.dumps(content, separators=(",", ":")).encode()
    return encode_frame(FrameType.REPLY, seq, body)


def encode_command(
    seq: int,
    command: FrameType,
    *,
    rate_hz: float = 0.0,
    channel_mask: int = 0,
    block_size: int = 0,
    peak_force_n: float = 0.0,
    double_hit: bool = False,
    at_sample: int = 0,
) -> bytes:
    """A command frame from the host (only the arguments its type uses are read)."""
    if command == FrameType.CONFIGURE:
        body = CONFIGURE_BODY.pack(rate_hz, channel_mask, block_size)
    elif command == FrameType.IMPACT:
        body = IMPACT_BODY.pack(peak_force_n, int(double_hit))
    elif command == FrameType.IMPACT_AT:
        body = IMPACT_AT_BODY.pack(peak_force_n, int(double_hit), at_sample)
    else:
        body = b""
    return encode_frame(command, seq, body)


# --------------------------------------------------------------------------------------------
# decoding


@dataclass(frozen=True)
class DataFrame:
    """A decoded block of samples.

    Attributes
    ----------
    seq : int
        Device frame counter.
    first_sample : int
        Device sample counter of ``counts[0]``.
    counts : ndarray, shape (n_samples, n_channels), int32
    channel_mask : int
        Bit i set when device channel i is in the block (in ascending order).
    dropped_before : int
        Samples lost between the previous good block and this one (0 if none or unknown).
    """

    seq: int
    first_sample: int
    counts: np.ndarray
    channel_mask: int
    dropped_before: int = 0


@dataclass(frozen=True)
class Message:
    """Any other decoded frame (replies from a device, commands at a device)."""

    frame_type: int
    seq: int
    body: bytes

    def reply(self) -> tuple[int, int, int, dict[str, Any]]:
        """``(command_seq, command_type, status, content)`` of a REPLY frame."""
        if len(self.body) < REPLY_HEADER.size:
            raise ProtocolError(f"reply body must hold at least {REPLY_HEADER.size} bytes, got {len(self.body)}")
        cseq, ctype, status = REPLY_HEADER.unpack_from(self.body)
        try:
            content = json.loads(self.body[REPLY_HEADER.size :].decode() or "{}")
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ProtocolError(f"reply content must be UTF-8 JSON: {exc}") from None
        if not isinstance(content, dict):
            raise ProtocolError(f"reply content must be a JSON object, got {type(content).__name__}")
        return cseq, ctype, status, content


@dataclass
class DecoderStats:
    """Counters of a :class:`StreamDecoder` (all exact, never reset, never wrapping).

    Attributes
    ----------
    bytes : int
        Bytes fed.
    frames : int
        Frames that passed the CRC.
    data_frames : int
        Of which DATA frames delivered.
    samples : int
        Samples (rows) delivered in DATA frames.
    crc_errors : int
        Well-framed frames whose CRC did not match.
    framing_errors : int
        Chunks between delimiters that were not valid COBS, too short or too long.
    resyncs : int
        Times bytes were thrown away to find the next delimiter (= crc_errors + framing_errors
        + overlong discards).
    malformed : int
        CRC-valid frames whose content contradicts the protocol (e.g. a wrong length).
    lost_frames : int
        Frames missing from the sender's sequence: the forward gaps of ``seq`` (mod 2**32,
        a gap of less than 2**31 frames). A frame whose ``seq`` lies behind the last one seen
        (duplicated, reordered, or a restarted sender) is counted in ``stale_frames``
        instead and never makes this counter jump.
    stale_frames : int
        CRC-valid frames whose ``seq`` lies behind the last one seen.
    repeated_samples : int
        Samples of DATA frames that go backwards in the device sample counter (a duplicated
        or reordered frame): never delivered, since each sample is delivered at most once.
    dropped_samples : int
        Samples missing between good DATA frames (from the device sample counter).
    discarded_bytes : int
        Bytes not part of a good frame.
    """

    bytes: int = 0
    frames: int = 0
    data_frames: int = 0
    samples: int = 0
    crc_errors: int = 0
    framing_errors: int = 0
    resyncs: int = 0
    malformed: int = 0
    lost_frames: int = 0
    stale_frames: int = 0
    repeated_samples: int = 0
    dropped_samples: int = 0
    discarded_bytes: int = 0


#: A DATA frame's two headers at once: version, type, seq, first_sample, n, n_channels, width, mask.
_DATA_HEAD = struct.Struct("<" + HEADER.format.lstrip("<") + DATA_HEADER.format.lstrip("<"))

#: Longest COBS-encoded segment of a conforming frame, [bytes].
MAX_ENCODED_BYTES = MAX_FRAME_BYTES + 2 + MAX_FRAME_BYTES // 254
#: Half the sequence space: a ``seq`` this far or more ahead of the expected one is behind it.
_SEQ_HALF = 1 << 31


@dataclass
class StreamDecoder:
    """Turns an arbitrary chunking of the byte stream into frames, counting every loss.

    Feed bytes as they arrive; :meth:`feed` returns the frames completed by them, in stream
    order. Corrupt input never raises: it is counted in :attr:`stats` and skipped. Only a
    CRC-valid frame of another protocol version raises :class:`ProtocolVersionError`.

    Sample accounting (``docs/protocol.md``): the decoder keeps the device sample counter
    the next DATA frame should start at. Only the first START reply after opening or after a
    CONFIGURE (which resets the device counter) sets it; a repeated or late START reply never
    moves it, so the stream is never rewound. Counters are Python integers: the u64 sample
    counter is exact beyond 2**63.

    Parameters
    ----------
    max_frame_bytes : int
        Pending bytes without a delimiter beyond which they are discarded (a resync).
    """

    max_frame_bytes: int = MAX_ENCODED_BYTES
    stats: DecoderStats = field(default_factory=DecoderStats)
    _pending: bytearray = field(default_factory=bytearray)
    _expected_sample: int | None = None
    _expected_seq: int | None = None

    def expect_sample(self, sample: int | None) -> None:
        """Set the device sample counter the next DATA frame should start at (None: unknown)."""
        self._expected_sample = sample

    @property
    def expected_sample(self) -> int | None:
        """Counter the next DATA frame should start at (None before the first one)."""
        return self._expected_sample

    def account_tail(self, next_sample: int) -> int:
        """Count samples lost after the last good frame, given the device's final counter.

        Returns the number of samples newly counted as dropped.
        """
        if self._expected_sample is None or next_sample <= self._expected_sample:
            return 0
        lost = next_sample - self._expected_sample
        self.stats.dropped_samples += lost
        self._expected_sample = next_sample
        return lost

    def feed(self, data: bytes) -> list[DataFrame | Message]:
        """Decode the frames completed by ``data``.

        Returns
        -------
        list of DataFrame or Message
            In stream order.

        Raises
        ------
        ProtocolVersionError
            When a CRC-valid frame carries another protocol version.
        """
        st = self.stats
        st.bytes += len(data)
        if not data:
            return []
        pending = self._pending
        pending += data
        end = pending.rfind(0)
        if end < 0:
            if len(pending) > self.max_frame_bytes:
                st.resyncs += 1
                st.framing_errors += 1
                st.discarded_bytes += len(pending)
                pending.clear()
            return []
        # one copy of the complete frames, split at the delimiters by bytes.split (C): cheaper
        # than a numpy scan and a view per frame (issue 13's decoder profile)
        segments = pending.split(b"\x00")
        tail = segments.pop()  # the bytes after the last delimiter: the next frame's beginning
        pending.clear()
        pending += tail
        raws = []
        decode, crc, DecodeError = _cobs.decode, zlib.crc32, _cobs.DecodeError
        for seg in segments:
            if not seg:  # (two delimiters in a row mean nothing; the last split is empty)
                continue
            raw = None
            if len(seg) <= MAX_ENCODED_BYTES:
                try:
                    raw = decode(seg)
                except DecodeError:
                    raw = None
            if raw is None or len(raw) < FRAME_OVERHEAD:
                st.framing_errors += 1
            elif crc(raw) != CRC_RESIDUE:  # the CRC over the frame with its own CRC appended
                st.crc_errors += 1
            else:
                raws.append(raw)
                continue
            st.resyncs += 1  # not a good frame: skipped to its delimiter
            st.discarded_bytes += len(seg) + 1
        return self._interpret(raws) if raws else []

    def _interpret(self, raws: list[bytes]) -> list[DataFrame | Message]:
        """Turn CRC-valid frames into DataFrame / Message, in order, with the loss accounting."""
        fast = self._in_order_data(raws)
        if fast is not None:
            return fast
        st = self.stats
        st.frames += len(raws)
        kinds: list[Any] = []  # per frame: a Message, a DATA header tuple, or None (malformed)
        layouts: dict[tuple[int, int, int], list[int]] = {}
        seqs = []
        for k, raw in enumerate(raws):
            version, ftype, seq = HEADER.unpack_from(raw)
            if version != PROTOCOL_VERSION:
                raise ProtocolVersionError(
                    f"device speaks protocol version {version}, this driver speaks version {PROTOCOL_VERSION}"
                )
            seqs.append(seq)
            if ftype != FrameType.DATA:
                kinds.append(Message(ftype, seq, raw[HEADER.size : -CRC.size]))
                continue
            head = DATA_HEADER.unpack_from(raw, HEADER.size) if len(raw) >= DATA_OFFSET + CRC.size else None
            if head is None or head[3] not in (2, 3) or not 0 < head[2] <= 32 or head[1] == 0 or (
                    len(raw) != DATA_OFFSET + head[1] * head[2] * head[3] + CRC.size):
                st.malformed += 1  # still counts in the sequence, delivers nothing
                kinds.append(None)
                continue
            layouts.setdefault(head[1:4], []).append(k)
            kinds.append(head)
        values: dict[int, np.ndarray] = {}
        for (n, nch, width), ks in layouts.items():
            joined = b"".join([raws[k] for k in ks]) if len(ks) > 1 else raws[ks[0]]
            block = unpack_samples(joined, DATA_OFFSET, len(raws[ks[0]]), len(ks), n, nch, width)
            values.update(zip(ks, block))
        frames: list[DataFrame | Message] = []
        for k, kind in enumerate(kinds):
            self._count_seq(seqs[k])
            if kind is None:
                continue
            if isinstance(kind, Message):
                if kind.frame_type == FrameType.REPLY:
                    self._track_reply(kind)
                frames.append(kind)
                continue
            frame = self._account(seqs[k], kind[0], values[k], kind[4])
            if frame is not None:
                frames.append(frame)
        return frames

    def _in_order_data(self, raws: list[bytes]) -> list[DataFrame | Message] | None:
        """The common case with less per-frame work, or None for :meth:`_interpret`'s general path.

        Applies when every frame is a well-formed DATA frame of this version and of one layout,
        continuing the sender's ``seq`` and the device sample counter with no gap, step back or
        ``seq`` wrap (each expected value known, or unknown as at the start): exactly the case
        in which the general path counts no loss, so the counters agree with it.
        """
        size = len(raws[0])
        if size < DATA_OFFSET + CRC.size:
            return None
        head = _DATA_HEAD.unpack_from
        version, ftype, seq, first, n, nch, width, _ = head(raws[0])
        if (version != PROTOCOL_VERSION or ftype != FrameType.DATA or width not in (2, 3) or not 0 < nch <= 32
                or n == 0 or size != DATA_OFFSET + n * nch * width + CRC.size):
            return None
        if (self._expected_seq is not None and seq != self._expected_seq) or (
                self._expected_sample is not None and first != self._expected_sample):
            return None
        for raw in raws:
            if len(raw) != size:
                return None
        heads = [head(raw) for raw in raws]
        want = (version, ftype, seq, first, n, nch, width)
        for h in heads:
            if h[:7] != want:
                return None
            want = (version, ftype, want[2] + 1, want[3] + n, n, nch, width)
        if want[2] > 0xFFFFFFFF:
            return None
        k = len(raws)
        joined = b"".join(raws) if k > 1 else raws[0]
        counts = unpack_samples(joined, DATA_OFFSET, size, k, n, nch, width)
        st = self.stats
        st.frames += k
        st.data_frames += k
        st.samples += k * n
        self._expected_seq = want[2] & 0xFFFFFFFF
        self._expected_sample = want[3]
        return [DataFrame(h[2], h[3], block, h[7]) for h, block in zip(heads, counts)]

    def _count_seq(self, seq: int) -> None:
        """Forward gaps of the sender's ``seq`` are lost frames; a frame behind is stale."""
        exp = self._expected_seq
        if exp is not None:
            gap = (seq - exp) & 0xFFFFFFFF
            if gap >= _SEQ_HALF:  # behind: duplicated, reordered or a restarted sender
                self.stats.stale_frames += 1
                return
            self.stats.lost_frames += gap
        self._expected_seq = (seq + 1) & 0xFFFFFFFF

    def _track_reply(self, msg: Message) -> None:
        """The first START reply sets the expected counter, a CONFIGURE resets it, a STOP counts the tail."""
        if len(msg.body) < REPLY_HEADER.size:
            return
        _, ctype, status = REPLY_HEADER.unpack_from(msg.body)
        if status != ReplyStatus.OK or ctype not in (FrameType.START, FrameType.STOP, FrameType.CONFIGURE):
            return
        if ctype == FrameType.CONFIGURE:
            self._expected_sample = None  # the device counter restarts at 0
            return
        try:
            content = msg.reply()[3]
            if ctype == FrameType.START:
                first = _counter(content["first_sample"])
                if self._expected_sample is None:
                    self._expected_sample = first
            else:
                self.account_tail(_counter(content["next_sample"]))
        except (ProtocolError, KeyError, TypeError, ValueError):
            self.stats.malformed += 1

    def _account(self, seq: int, first: int, counts: np.ndarray, mask: int) -> DataFrame | None:
        """Check a block against the expected sample counter; None when it goes backwards."""
        st = self.stats
        n = counts.shape[0]
        exp = self._expected_sample
        dropped = 0
        if exp is not None:
            if first < exp:  # goes backwards: never deliver a sample twice
                st.repeated_samples += n
                return None
            dropped = first - exp
            st.dropped_samples += dropped
        self._expected_sample = first + n
        st.data_frames += 1
        st.samples += n
        return DataFrame(seq, first, counts, mask, dropped)


def _counter(value: object) -> int:
    """A u64 sample counter from a reply's JSON (an integer in [0, 2**64))."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 1 << 64:
        raise ValueError(f"sample counter must be an integer in [0, 2**64), got {value!r}")
    return value


def decode_one(frame: bytes) -> DataFrame | Message:
    """Decode exactly one complete frame (with its trailing 0x00); for tests and vectors.

    Raises
    ------
    ProtocolError
        When ``frame`` is not exactly one good frame.
    """
    dec = StreamDecoder()
    frames = dec.feed(frame)
    st = dec.stats
    if len(frames) != 1 or dec._pending:
        raise ProtocolError(
            f"expected exactly one good frame, got {len(frames)} "
            f"(crc errors {st.crc_errors}, framing errors {st.framing_errors}, malformed {st.malformed})"
        )
    return frames[0]
