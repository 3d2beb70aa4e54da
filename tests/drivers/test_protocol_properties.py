"""Property tests: a corrupted byte stream never yields a corrupt sample, and losses count exactly."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.protocol import FrameType, ReplyStatus, StreamDecoder, DataFrame, encode_data, encode_reply


def _stream(seed: int, n_frames: int, n_channels: int, width: int, max_block: int):
    """Frames of random blocks; returns the bytes, each frame's [start, end] (end = delimiter), counts."""
    rng = np.random.default_rng(seed)
    lim = 1 << (8 * width - 1)
    sizes = rng.integers(1, max_block + 1, n_frames)
    total = int(sizes.sum())
    counts = rng.integers(-lim, lim, (total, n_channels)).astype(np.int32)
    counts[rng.random(counts.shape) < 0.2] = 0  # plenty of zero bytes for COBS to code
    parts, spans, pos, first = [], [], 0, 0
    for k, n in enumerate(sizes):
        f = encode_data(k, first, counts[first : first + n], width, (1 << n_channels) - 1)
        parts.append(f)
        spans.append((pos, pos + len(f) - 1))
        pos += len(f)
        first += int(n)
    return b"".join(parts), spans, counts, sizes


mutation = st.tuples(
    st.sampled_from(["flip", "delete", "insert", "cut"]),
    st.floats(0, 1, exclude_max=True),
    st.integers(0, 255),
)


@settings(max_examples=250, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n_frames=st.integers(1, 12),
    n_channels=st.integers(1, 4),
    width=st.sampled_from([2, 3]),
    mutations=st.lists(mutation, max_size=6),
    chunks=st.lists(st.integers(1, 700), min_size=1, max_size=8),
)
def test_corrupted_stream_yields_only_true_samples_and_counts_every_loss(
    seed, n_frames, n_channels, width, mutations, chunks
):
    stream, spans, counts, sizes = _stream(seed, n_frames, n_channels, width, 60)
    data = bytearray(stream)
    touched = set()
    # apply from the end so every position stays in original coordinates
    placed = sorted(((int(f * len(stream)), kind, v) for kind, f, v in mutations), reverse=True)
    lowest = len(stream)
    for p, kind, v in placed:
        q = p if kind != "cut" else min(len(stream) - 1, p + v)
        if q >= lowest:
            continue  # overlaps a mutation already applied: keep positions in original coordinates
        lowest = p
        if kind == "flip":
            data[p] ^= 1 << (v % 8)
        elif kind == "delete":
            del data[p]
        elif kind == "insert":
            data.insert(p, v)
        else:  # cut: lose a run of bytes (a truncated frame)
            del data[p:q]
        for k, (a, b) in enumerate(spans):
            if a <= q and p <= b:
                touched.add(k)
                if q >= b:  # the delimiter went: the next frame merges with this one
                    touched.add(k + 1)
    total = int(sizes.sum())
    # the device's STOP reply (uncorrupted) closes the stream with its sample counter
    data += encode_reply(n_frames, 7, FrameType.STOP, ReplyStatus.OK, {"next_sample": total})

    dec = StreamDecoder()
    dec.expect_sample(0)
    got: list[DataFrame] = []
    pos, i = 0, 0
    while pos < len(data):
        n = chunks[i % len(chunks)]
        got += [f for f in dec.feed(bytes(data[pos : pos + n])) if isinstance(f, DataFrame)]
        pos += n
        i += 1

    delivered = 0
    end = 0
    starts = np.concatenate([[0], np.cumsum(sizes)])
    for f in got:
        assert f.first_sample >= end  # in order, never twice
        assert f.dropped_before == f.first_sample - end
        n = f.counts.shape[0]
        np.testing.assert_array_equal(f.counts, counts[f.first_sample : f.first_sample + n])
        end = f.first_sample + n
        delivered += n
    assert delivered + dec.stats.dropped_samples == total
    # every frame no mutation touched arrives intact
    got_first = {f.first_sample for f in got}
    for k in range(n_frames):
        if k not in touched:
            assert int(starts[k]) in got_first, f"untouched frame {k} lost"
    if not mutations:
        assert dec.stats.dropped_samples == 0 and dec.stats.resyncs == 0


@settings(max_examples=100, deadline=None)
@given(garbage=st.binary(max_size=3000), chunk=st.integers(1, 500))
def test_pure_garbage_never_raises_and_yields_nothing(garbage, chunk):
    dec = StreamDecoder()
    out = []
    for i in range(0, len(garbage), chunk):
        out += dec.feed(garbage[i : i + chunk])
    assert out == []
    assert dec.stats.frames == 0
    assert dec.stats.bytes == len(garbage)


class _GeneralPathOnly(StreamDecoder):
    """The decoder without its fast path for in-order DATA frames (the reference)."""

    def _in_order_data(self, raws):  # type: ignore[no-untyped-def]
        return None


@settings(max_examples=150, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n_frames=st.integers(1, 30),
    events=st.lists(st.tuples(st.integers(0, 29), st.sampled_from(["gap", "repeat", "back", "reply", "short"])),
                    max_size=5),
    seq0=st.sampled_from([0, 2**32 - 3]),
    expect=st.sampled_from([None, 0, 5]),
    chunks=st.lists(st.integers(1, 5000), min_size=1, max_size=5),
)
def test_fast_path_counts_and_delivers_exactly_as_the_general_path(seed, n_frames, events, seq0, expect, chunks):
    """Equal-size DATA frames take the decoder's fast path unless a seq/counter jump, a reply or
    another layout interrupts them; frames and every counter equal the general path's."""
    rng = np.random.default_rng(seed)
    block, nch, width = 16, 3, 3
    counts = rng.integers(-(1 << 23), 1 << 23, (block * (n_frames + 10), nch)).astype(np.int32)
    todo = dict(events)
    parts, seq, first = [], seq0, 0
    for k in range(n_frames):
        what = todo.get(k)
        if what == "gap":
            first += 7
            seq += 2
        elif what == "back":
            first = max(0, first - 3)
        elif what == "reply":
            parts.append(encode_reply(seq, 1, FrameType.STATUS, ReplyStatus.OK, {}))
            seq += 1
        n = block // 2 if what == "short" else block
        frame = encode_data(seq, first, counts[first : first + n], width, 7)
        parts.append(frame)
        if what == "repeat":
            parts.append(frame)
        seq += 1
        first += n
    data = b"".join(parts)
    results = []
    for cls in (StreamDecoder, _GeneralPathOnly):
        dec = cls()
        dec.expect_sample(expect)
        got, pos, i = [], 0, 0
        while pos < len(data):
            got += dec.feed(data[pos : pos + chunks[i % len(chunks)]])
            pos += chunks[i % len(chunks)]
            i += 1
        results.append((dec, got))
    (fast, got_fast), (ref, got_ref) = results
    assert fast.stats == ref.stats
    assert fast.expected_sample == ref.expected_sample and fast._expected_seq == ref._expected_seq
    assert len(got_fast) == len(got_ref)
    for a, b in zip(got_fast, got_ref):
        assert type(a) is type(b)
        if isinstance(a, DataFrame):
            assert (a.seq, a.first_sample, a.channel_mask, a.dropped_before) == (
                b.seq, b.first_sample, b.channel_mask, b.dropped_before)
            np.testing.assert_array_equal(a.counts, b.counts)
        else:
            assert a == b
