"""The EDDI DAQ wire protocol, version 1: frame codec and vectorised stream decoder.

The format is specified in ``docs/protocol.md``; this module is its reference implementation.
In short, every frame is::

    0x00 COBS( version:u8 | type:u8 | seq:u32 | body | crc32:u32 ) 0x00

all integers little-endian, CRC-32 (zlib polynomial) over everything before it. Data frames
carry the device's sample counter, so every lost sample is counted exactly from the next
good frame.

The bulk path (:class:`StreamDecoder`) splits on 0x00 with numpy, COBS-decodes and checks the
CRC of every frame in one compiled pass (numba), and unpacks 16/24-bit samples with numpy.
"""

from __future__ import annotations

import enum
import json
import struct
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np

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
CRC = struct.Struct("<I")

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


COMMAND_TYPES = frozenset(
    {FrameType.IDENTIFY, FrameType.CONFIGURE, FrameType.START, FrameType.STOP, FrameType.STATUS, FrameType.IMPACT}
)


class ReplyStatus(enum.IntEnum):
    """Status byte of a reply."""

    OK = 0
    BAD_COMMAND = 1  # unknown type or malformed body
    BAD_VALUE = 2  # a parameter outside what the device supports
    BAD_STATE = 3  # e.g. configure while streaming
    UNSUPPORTED = 4  # e.g. impact on a real DAQ


# --------------------------------------------------------------------------------------------
# compiled kernels


def _crc_table() -> np.ndarray:
    table = np.zeros(256, dtype=np.uint32)
    for i in range(256):
        c = i
        for _ in range(8):
            c = (c >> 1) ^ 0xEDB88320 if c & 1 else c >> 1
        table[i] = c
    return table


_CRC_TABLE = _crc_table()


@numba.njit(cache=True, nogil=True)
def _crc32(data: np.ndarray, start: int, stop: int, table: np.ndarray) -> np.uint32:
    c = np.uint32(0xFFFFFFFF)
    for i in range(start, stop):
        c = table[(c ^ data[i]) & 0xFF] ^ (c >> np.uint32(8))
    return c ^ np.uint32(0xFFFFFFFF)


@numba.njit(cache=True, nogil=True)
def _decode_frames(buf, seg_start, seg_stop, table):  # pragma: no cover - compiled
    """COBS-decode and CRC-check each segment ``buf[seg_start[k]:seg_stop[k]]`` (no zeros inside).

    Returns the decoded bytes, each frame's start and length in them, and a status per frame:
    0 ok, 1 empty, 2 COBS error, 3 too short, 4 CRC mismatch, 5 too long.
    """
    n_seg = seg_start.shape[0]
    out = np.empty(buf.shape[0], dtype=np.uint8)
    starts = np.empty(n_seg, dtype=np.int64)
    lengths = np.zeros(n_seg, dtype=np.int64)
    status = np.zeros(n_seg, dtype=np.uint8)
    o = 0
    for k in range(n_seg):
        s = seg_start[k]
        e = seg_stop[k]
        starts[k] = o
        if e == s:
            status[k] = 1
            continue
        if e - s > 65536 + 2 + 65536 // 254:
            status[k] = 5
            continue
        p = s
        fo = o
        bad = False
        while p < e:
            code = np.int64(buf[p])
            p += 1
            if p + code - 1 > e:
                bad = True
                break
            for j in range(code - 1):
                out[fo + j] = buf[p + j]
            fo += code - 1
            p += code - 1
            if code < 255 and p < e:
                out[fo] = 0
                fo += 1
        if bad:
            status[k] = 2
            continue
        length = fo - o
        if length < 10:
            status[k] = 3
            continue
        crc = _crc32(out, o, fo - 4, table)
        got = (
            np.uint32(out[fo - 4])
            | (np.uint32(out[fo - 3]) << np.uint32(8))
            | (np.uint32(out[fo - 2]) << np.uint32(16))
            | (np.uint32(out[fo - 1]) << np.uint32(24))
        )
        if crc != got:
            status[k] = 4
            continue
        lengths[k] = length
        o = fo
    return out[:o], starts, lengths, status


@numba.njit(cache=True, nogil=True)
def _cobs_encode(data):  # pragma: no cover - compiled
    """COBS-encode ``data`` (uint8) and append the 0x00 delimiter."""
    n = data.shape[0]
    out = np.empty(n + n // 254 + 2, dtype=np.uint8)
    code_pos = 0
    o = 1
    code = 1
    for i in range(n):
        b = data[i]
        if b == 0:
            out[code_pos] = code
            code_pos = o
            o += 1
            code = 1
        else:
            out[o] = b
            o += 1
            code += 1
            if code == 255:
                out[code_pos] = code
                code_pos = o
                o += 1
                code = 1
    out[code_pos] = code
    out[o] = 0
    return out[: o + 1]


@numba.njit(cache=True, nogil=True)
def _unpack_samples(out, offsets, n, nch, width):  # pragma: no cover - compiled
    """Little-endian two's-complement samples of ``offsets.size`` frames -> int32 (g, n, nch)."""
    g = offsets.shape[0]
    res = np.empty((g, n, nch), dtype=np.int32)
    for f in range(g):
        p = offsets[f]
        for i in range(n):
            for c in range(nch):
                if width == 3:
                    v = np.int32(out[p]) | (np.int32(out[p + 1]) << 8) | (np.int32(out[p + 2]) << 16)
                    res[f, i, c] = (v ^ 0x800000) - 0x800000
                else:
                    v = np.int32(out[p]) | (np.int32(out[p + 1]) << 8)
                    res[f, i, c] = (v ^ 0x8000) - 0x8000
                p += width
    return res


@numba.njit(cache=True, nogil=True)
def _parse_headers(out, starts, lengths):  # pragma: no cover - compiled
    """Header fields of every decoded frame: (version, type, seq, first, n, nch, width, mask)."""
    g = starts.shape[0]
    version = np.empty(g, dtype=np.int64)
    ftype = np.empty(g, dtype=np.int64)
    seq = np.empty(g, dtype=np.int64)
    first = np.zeros(g, dtype=np.int64)
    n = np.zeros(g, dtype=np.int64)
    nch = np.zeros(g, dtype=np.int64)
    width = np.zeros(g, dtype=np.int64)
    mask = np.zeros(g, dtype=np.int64)
    for k in range(g):
        p = starts[k]
        version[k] = out[p]
        ftype[k] = out[p + 1]
        seq[k] = np.int64(out[p + 2]) | (np.int64(out[p + 3]) << 8) | (np.int64(out[p + 4]) << 16) | (
            np.int64(out[p + 5]) << 24)
        if ftype[k] == 1 and lengths[k] >= 26:
            q = p + 6
            v = np.int64(0)
            for j in range(8):  # u64, kept below 2**63
                v |= np.int64(out[q + j]) << (8 * j)
            first[k] = v
            n[k] = np.int64(out[q + 8]) | (np.int64(out[q + 9]) << 8)
            nch[k] = out[q + 10]
            width[k] = out[q + 11]
            mask[k] = np.int64(out[q + 12]) | (np.int64(out[q + 13]) << 8) | (np.int64(out[q + 14]) << 16) | (
                np.int64(out[q + 15]) << 24)
    return version, ftype, seq, first, n, nch, width, mask


def crc32(data: bytes | np.ndarray) -> int:
    """CRC-32 as used by the protocol (same as :func:`zlib.crc32`)."""
    arr = np.frombuffer(bytes(data), dtype=np.uint8)
    return int(_crc32(arr, 0, arr.shape[0], _CRC_TABLE))


def cobs_encode(payload: bytes) -> bytes:
    """COBS-encode ``payload`` and append the 0x00 frame delimiter."""
    return _cobs_encode(np.frombuffer(payload, dtype=np.uint8)).tobytes()


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
) -> bytes:
    """A command frame from the host (only the arguments its type uses are read)."""
    if command == FrameType.CONFIGURE:
        body = CONFIGURE_BODY.pack(rate_hz, channel_mask, block_size)
    elif command == FrameType.IMPACT:
        body = IMPACT_BODY.pack(peak_force_n, int(double_hit))
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
    """Counters of a :class:`StreamDecoder` (all exact, never reset).

    Attributes
    ----------
    bytes : int
        Bytes fed.
    frames : int
        Frames that passed the CRC.
    data_frames : int
        Of which DATA frames.
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
        Gaps in the device's frame sequence numbers.
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
    dropped_samples: int = 0
    discarded_bytes: int = 0


@dataclass
class StreamDecoder:
    """Turns an arbitrary chunking of the byte stream into frames, counting every loss.

    Feed bytes as they arrive; :meth:`feed` returns the frames completed by them, in stream
    order. Corrupt input never raises: it is counted in :attr:`stats` and skipped. Only a
    CRC-valid frame of another protocol version raises :class:`ProtocolVersionError`.

    Parameters
    ----------
    max_frame_bytes : int
        Pending bytes without a delimiter beyond which they are discarded (a resync).
    """

    max_frame_bytes: int = MAX_FRAME_BYTES + MAX_FRAME_BYTES // 254 + 2
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
        self._pending += data
        buf = np.frombuffer(self._pending, dtype=np.uint8)
        zeros = np.flatnonzero(buf == 0)
        if zeros.size == 0:
            del buf
            if len(self._pending) > self.max_frame_bytes:
                st.resyncs += 1
                st.framing_errors += 1
                st.discarded_bytes += len(self._pending)
                self._pending = bytearray()
            return []
        end = int(zeros[-1]) + 1
        seg_start = np.empty(zeros.size, dtype=np.int64)
        seg_start[0] = 0
        seg_start[1:] = zeros[:-1] + 1
        seg_stop = zeros.astype(np.int64)
        chunk = buf[:end].copy()
        del buf
        del self._pending[:end]
        out, starts, lengths, status = _decode_frames(chunk, seg_start, seg_stop, _CRC_TABLE)
        n_crc = int(np.count_nonzero(status == 4))
        n_framing = int(np.count_nonzero((status == 2) | (status == 3) | (status == 5)))
        st.crc_errors += n_crc
        st.framing_errors += n_framing
        st.resyncs += n_crc + n_framing
        bad = (status > 1)
        st.discarded_bytes += int(np.sum(seg_stop[bad] - seg_start[bad] + 1))
        good = np.flatnonzero(status == 0)
        if good.size == 0:
            return []
        return self._interpret(out, starts[good], lengths[good])

    def _interpret(self, out: np.ndarray, starts: np.ndarray, lengths: np.ndarray) -> list[DataFrame | Message]:
        st = self.stats
        st.frames += starts.size
        version, ftype, seq, first, n, nch, width, mask = _parse_headers(out, starts, lengths)
        if np.any(version != PROTOCOL_VERSION):
            other = int(version[np.flatnonzero(version != PROTOCOL_VERSION)[0]])
            raise ProtocolVersionError(
                f"device speaks protocol version {other}, this driver speaks version {PROTOCOL_VERSION}"
            )
        results: list[DataFrame | Message | None] = [None] * starts.size
        is_data = ftype == FrameType.DATA
        if np.any(is_data):
            ok = is_data & ((width == 2) | (width == 3)) & (nch > 0) & (n > 0) & (nch <= 32)
            ok &= lengths == DATA_OFFSET + n * nch * width + CRC.size
            st.malformed += int(np.count_nonzero(is_data & ~ok))
            idx_ok = np.flatnonzero(ok)
            if idx_ok.size:
                key = (n * 256 + nch) * 4 + width
                keys = key[idx_ok]
                groups = [keys[0]] if keys.min() == keys.max() else np.unique(keys)
                for kv in groups:
                    sel = idx_ok if len(groups) == 1 else idx_ok[keys == kv]
                    k0 = int(sel[0])
                    vals = _unpack_samples(out, starts[sel] + DATA_OFFSET, int(n[k0]), int(nch[k0]), int(width[k0]))
                    for j, i in enumerate(sel.tolist()):
                        results[i] = DataFrame(seq=int(seq[i]), first_sample=int(first[i]), counts=vals[j],
                                               channel_mask=int(mask[i]))
        for k in np.flatnonzero(~is_data).tolist():
            s = int(starts[k])
            results[k] = Message(int(ftype[k]), int(seq[k]), out[s + HEADER.size : s + int(lengths[k]) - CRC.size].tobytes())
        frames: list[DataFrame | Message] = []
        seqs = seq.tolist()
        for k, r in enumerate(results):
            if r is None:
                continue
            if self._expected_seq is not None and seqs[k] != self._expected_seq:
                st.lost_frames += (seqs[k] - self._expected_seq) & 0xFFFFFFFF
            self._expected_seq = (seqs[k] + 1) & 0xFFFFFFFF
            if isinstance(r, DataFrame):
                r = self._account(r)
                if r is None:
                    continue
            elif r.frame_type == FrameType.REPLY:
                self._track_reply(r)
            frames.append(r)
        return frames

    def _track_reply(self, msg: Message) -> None:
        """A START reply sets the expected sample counter; a STOP reply counts the tail lost."""
        if len(msg.body) < REPLY_HEADER.size:
            return
        _, ctype, status = REPLY_HEADER.unpack_from(msg.body)
        if status != ReplyStatus.OK or ctype not in (FrameType.START, FrameType.STOP):
            return
        try:
            content = msg.reply()[3]
            if ctype == FrameType.START:
                self.expect_sample(int(content["first_sample"]))
            else:
                self.account_tail(int(content["next_sample"]))
        except (ProtocolError, KeyError, TypeError, ValueError):
            self.stats.malformed += 1

    def _account(self, frame: DataFrame) -> DataFrame | None:
        st = self.stats
        n = frame.counts.shape[0]
        exp = self._expected_sample
        dropped = 0
        if exp is not None:
            if frame.first_sample < exp:
                st.malformed += 1  # goes backwards: never deliver a sample twice
                return None
            dropped = frame.first_sample - exp
            st.dropped_samples += dropped
        self._expected_sample = frame.first_sample + n
        st.data_frames += 1
        st.samples += n
        if dropped:
            return DataFrame(frame.seq, frame.first_sample, frame.counts, frame.channel_mask, dropped)
        return frame


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
