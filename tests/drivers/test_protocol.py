"""Wire protocol: frames against the test vectors, COBS, CRC, sample packing, resync, versions."""

from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from drivers.errors import ProtocolError, ProtocolVersionError
from drivers.protocol import (
    CONFIGURE_BODY,
    IMPACT_BODY,
    DataFrame,
    FrameType,
    Message,
    ReplyStatus,
    StreamDecoder,
    cobs_encode,
    crc32,
    decode_one,
    encode_command,
    encode_data,
    encode_reply,
)

VECTORS = json.loads((Path(__file__).resolve().parents[1] / "vectors" / "protocol_v1.json").read_text())


def _cobs_decode_reference(enc: bytes) -> bytes:
    """Textbook COBS decoding, byte by byte (independent of the compiled kernel)."""
    out, i = bytearray(), 0
    while i < len(enc):
        code = enc[i]
        out += enc[i + 1 : i + code]
        i += code
        if code < 0xFF and i < len(enc):
            out.append(0)
    return bytes(out)


@pytest.mark.parametrize("vector", VECTORS["frames"], ids=lambda v: v["name"])
def test_vector_frames_encode_and_decode_exactly(vector):
    frame = bytes.fromhex(vector["frame_hex"])
    want = vector["decoded"]
    if "error" in want:
        with pytest.raises(ProtocolVersionError, match="version 2"):
            decode_one(frame)
        return
    got = decode_one(frame)
    assert got.seq == want["seq"]
    if want["type"] == "DATA":
        assert isinstance(got, DataFrame)
        assert got.first_sample == want["first_sample"] and got.channel_mask == want["channel_mask"]
        np.testing.assert_array_equal(got.counts, np.array(want["counts"]))
        again = encode_data(want["seq"], want["first_sample"], np.array(want["counts"]), want["width"],
                            want["channel_mask"])
    elif want["type"] == "REPLY":
        assert isinstance(got, Message)
        cseq, ctype, status, content = got.reply()
        assert (cseq, FrameType(ctype).name, ReplyStatus(status).name, content) == (
            want["command_seq"], want["command_type"], want["status"], want["content"])
        again = encode_reply(want["seq"], cseq, ctype, status, content)
    else:
        assert isinstance(got, Message) and FrameType(got.frame_type).name == want["type"]
        params = {k: v for k, v in want.items() if k not in ("type", "seq")}
        if want["type"] == "CONFIGURE":
            assert CONFIGURE_BODY.unpack(got.body) == (params["rate_hz"], params["channel_mask"], params["block_size"])
        if want["type"] == "IMPACT":
            assert IMPACT_BODY.unpack(got.body) == (params["peak_force_n"], 1)
        again = encode_command(want["seq"], FrameType[want["type"]], **params)
    assert again == frame


@pytest.mark.parametrize("vector", VECTORS["streams"], ids=lambda v: v["name"])
def test_vector_streams_decode_with_exact_accounting(vector):
    data = bytes.fromhex(vector["stream_hex"])
    for chunk in (len(data), 1, 7):  # the same result however the bytes arrive
        dec = StreamDecoder()
        dec.expect_sample(vector["expect_sample"])
        frames = []
        for i in range(0, len(data), chunk):
            frames += [f for f in dec.feed(data[i : i + chunk]) if isinstance(f, DataFrame)]
        assert [(f.first_sample, f.dropped_before, f.counts.tolist()) for f in frames] == [
            (b["first_sample"], b["dropped_before"], b["counts"]) for b in vector["blocks"]]
        for key, value in vector["stats"].items():
            assert getattr(dec.stats, key) == value, key


def test_frame_layout_matches_the_documented_bytes():
    frame = encode_command(0x01020304, FrameType.START)
    assert frame[0] == 0 and frame[-1] == 0 and 0 not in frame[1:-1]
    raw = _cobs_decode_reference(frame[1:-1])
    assert raw[:6] == bytes([1, 0x43, 4, 3, 2, 1])  # version, type, seq little-endian
    assert struct.unpack("<I", raw[-4:])[0] == zlib.crc32(raw[:-4])


@pytest.mark.parametrize("n", [0, 1, 253, 254, 255, 256, 508, 509, 1000])
def test_cobs_round_trips_against_reference_decoder(n):
    rng = np.random.default_rng(n)
    payload = rng.integers(0, 4, n).astype(np.uint8).tobytes()
    runs = bytes(range(1, 256)) * 3  # long runs without zeros
    for data in (payload, runs[:n], bytes(n)):
        enc = cobs_encode(data)
        assert enc[-1] == 0 and 0 not in enc[:-1]
        assert _cobs_decode_reference(enc[:-1]) == data


def test_crc_is_zlib_crc32():
    for data in (b"", b"123456789", bytes(range(256)) * 5):
        assert crc32(data) == zlib.crc32(data)
    assert crc32(b"123456789") == 0xCBF43926  # the CRC-32 check value


@pytest.mark.parametrize("width,bits", [(2, 16), (3, 24)])
def test_samples_round_trip_full_range(width, bits):
    lo, hi = -(1 << (bits - 1)), (1 << (bits - 1)) - 1
    counts = np.array([[lo, hi, 0], [-1, 1, lo + 1], [hi - 1, -256, 256]], dtype=np.int32)
    got = decode_one(encode_data(0, 0, counts, width, 0b111))
    np.testing.assert_array_equal(got.counts, counts)
    assert got.counts.dtype == np.int32


def test_decoder_resyncs_after_garbage_and_counts_it():
    counts = np.arange(40, dtype=np.int32).reshape(20, 2)
    f0 = encode_data(0, 0, counts[:10], 3, 3)
    f1 = encode_data(1, 10, counts[10:], 3, 3)
    dec = StreamDecoder()
    dec.expect_sample(0)
    out = dec.feed(b"\x05\xff\xfe\x00\x07junk" + f0 + b"\x03\x01" + f1)
    assert [f.first_sample for f in out] == [0, 10]
    np.testing.assert_array_equal(np.concatenate([f.counts for f in out]), counts)
    assert dec.stats.resyncs == 3 and dec.stats.dropped_samples == 0 and dec.stats.frames == 2


def test_lost_frame_counts_samples_and_sequence_gap():
    frames = [encode_data(k, 8 * k, np.full((8, 1), k, dtype=np.int32), 2, 1) for k in range(4)]
    dec = StreamDecoder()
    dec.expect_sample(0)
    out = dec.feed(frames[0] + frames[3])
    assert out[1].dropped_before == 16
    assert dec.stats.dropped_samples == 16 and dec.stats.lost_frames == 2


def test_overlong_garbage_without_delimiter_is_discarded():
    dec = StreamDecoder(max_frame_bytes=1000)
    dec.feed(b"\x01" * 999)
    assert dec.stats.resyncs == 0
    dec.feed(b"\x01" * 2)
    assert dec.stats.resyncs == 1 and dec.stats.discarded_bytes == 1001
    out = dec.feed(encode_data(0, 0, np.ones((3, 1), np.int32), 3, 1))
    assert len(out) == 1


def test_frame_with_wrong_length_field_is_malformed_not_delivered():
    from drivers.protocol import DATA_HEADER, encode_frame

    body = DATA_HEADER.pack(0, 5, 1, 3, 1) + b"\x01" * 12  # says 5 samples, holds 4
    dec = StreamDecoder()
    assert dec.feed(encode_frame(FrameType.DATA, 0, body)) == []
    assert dec.stats.malformed == 1


def test_decode_one_refuses_anything_but_one_good_frame():
    with pytest.raises(ProtocolError, match="exactly one good frame"):
        decode_one(b"\x02\x01\x00")
    # ProtocolError is also an IOError for callers that catch that
    assert issubclass(ProtocolError, IOError)
