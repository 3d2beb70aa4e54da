"""Exact loss accounting from the contract (docs/protocol.md): repeated and late START replies,
duplicated and reordered frames, sequence wrap, and u64 sample counters beyond 2**63."""

from __future__ import annotations

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from drivers.protocol import DataFrame, FrameType, ReplyStatus, StreamDecoder, encode_data, encode_reply

N = 8  # samples per frame in these streams


def _data(seq: int, first: int, n: int = N) -> bytes:
    """A DATA frame whose counts are the sample counter (mod 2**23): checkable from the index."""
    k = (np.arange(first, first + n, dtype=object) % (1 << 23)).astype(np.int64)
    return encode_data(seq, first, k.reshape(n, 1).astype(np.int32), 3, 1)


def _reply(seq: int, command: FrameType, content: dict) -> bytes:
    return encode_reply(seq, 0, int(command), int(ReplyStatus.OK), content)


def _delivered(dec: StreamDecoder, stream: bytes) -> list[tuple[int, int]]:
    out = [f for f in dec.feed(stream) if isinstance(f, DataFrame)]
    for f in out:  # every delivered sample is the device's own
        want = (np.arange(f.first_sample, f.first_sample + f.counts.shape[0], dtype=object) % (1 << 23)).astype(np.int64)
        assert f.counts[:, 0].tolist() == want.tolist()
    return [(f.first_sample, f.counts.shape[0]) for f in out]


def test_a_repeated_start_reply_mid_stream_never_rewinds() -> None:
    dec = StreamDecoder()
    stream = _reply(0, FrameType.START, {"first_sample": 0}) + _data(1, 0) + _data(2, N)
    stream += _reply(3, FrameType.START, {"first_sample": 0})  # the same reply again, late
    stream += _data(4, 2 * N) + _data(2, N)  # and a duplicated frame after it
    got = _delivered(dec, stream)
    assert got == [(0, N), (N, N), (2 * N, N)]  # each sample once, in order
    assert dec.stats.dropped_samples == 0 and dec.stats.repeated_samples == N
    assert dec.stats.lost_frames == 0 and dec.stats.stale_frames == 1


def test_a_late_start_reply_naming_a_later_counter_does_not_move_the_stream() -> None:
    dec = StreamDecoder()
    stream = _reply(0, FrameType.START, {"first_sample": 100}) + _data(1, 100)
    stream += _reply(2, FrameType.START, {"first_sample": 5000}) + _data(3, 100 + N)
    assert _delivered(dec, stream) == [(100, N), (100 + N, N)]
    assert dec.stats.dropped_samples == 0


def test_configure_resets_the_counter_and_the_next_start_sets_it() -> None:
    dec = StreamDecoder()
    stream = _reply(0, FrameType.START, {"first_sample": 0}) + _data(1, 0) + _data(2, N)
    stream += _reply(3, FrameType.STOP, {"next_sample": 2 * N})
    stream += _reply(4, FrameType.CONFIGURE, {"protocol_version": 1})  # device counter back to 0
    stream += _reply(5, FrameType.START, {"first_sample": 0}) + _data(6, 0)
    assert _delivered(dec, stream) == [(0, N), (N, N), (0, N)]
    assert dec.stats.dropped_samples == 0 and dec.stats.repeated_samples == 0


def test_a_duplicated_frame_never_makes_lost_frames_jump() -> None:
    dec = StreamDecoder()
    dec.expect_sample(0)
    got = _delivered(dec, _data(0, 0) + _data(1, N) + _data(1, N) + _data(2, 2 * N))
    assert got == [(0, N), (N, N), (2 * N, N)]
    assert dec.stats.lost_frames == 0 and dec.stats.stale_frames == 1 and dec.stats.repeated_samples == N


def test_reordered_frames_count_one_loss_exactly() -> None:
    dec = StreamDecoder()
    dec.expect_sample(0)
    got = _delivered(dec, _data(0, 0) + _data(2, 2 * N) + _data(1, N) + _data(3, 3 * N))
    # frame 1 comes after frame 2: too late to deliver in order, so it counts as lost, once
    assert got == [(0, N), (2 * N, N), (3 * N, N)]
    assert dec.stats.lost_frames == 1 and dec.stats.stale_frames == 1
    assert dec.stats.dropped_samples == N and dec.stats.repeated_samples == N
    assert dec.stats.samples + dec.stats.dropped_samples == 4 * N


def test_sequence_numbers_wrap_at_2_32_without_a_loss() -> None:
    top = (1 << 32) - 2
    dec = StreamDecoder()
    dec.expect_sample(0)
    stream = b"".join(_data((top + k) & 0xFFFFFFFF, k * N) for k in range(4))
    assert len(_delivered(dec, stream)) == 4
    assert dec.stats.lost_frames == 0 and dec.stats.stale_frames == 0
    dec2 = StreamDecoder()
    dec2.expect_sample(0)
    _delivered(dec2, _data((1 << 32) - 1, 0) + _data(1, 2 * N))  # frame 0 (after the wrap) lost
    assert dec2.stats.lost_frames == 1 and dec2.stats.dropped_samples == N


def test_sample_counters_beyond_2_63_are_exact_u64() -> None:
    first = (1 << 63) - N  # the stream crosses 2**63
    dec = StreamDecoder()
    stream = _reply(0, FrameType.START, {"first_sample": first})
    stream += _data(1, first) + _data(2, first + N) + _data(4, first + 3 * N)  # one frame lost
    stream += _reply(5, FrameType.STOP, {"next_sample": first + 5 * N})  # one lost at the end
    got = _delivered(dec, stream)
    assert got == [(first, N), (first + N, N), (first + 3 * N, N)]
    assert dec.stats.dropped_samples == 2 * N and dec.stats.lost_frames == 1
    assert dec.stats.samples + dec.stats.dropped_samples == 5 * N
    top = (1 << 64) - N  # the largest block a u64 counter can hold
    dec2 = StreamDecoder()
    assert _delivered(dec2, _data(0, top)) == [(top, N)]


def test_a_start_reply_with_a_counter_outside_u64_is_malformed() -> None:
    dec = StreamDecoder()
    dec.feed(_reply(0, FrameType.START, {"first_sample": 1 << 64}) + _reply(1, FrameType.START, {"first_sample": -1}))
    assert dec.stats.malformed == 2 and dec.expected_sample is None


@settings(max_examples=200, deadline=None)
@given(
    n_frames=st.integers(1, 30),
    start=st.sampled_from([0, 12345, (1 << 63) - 40, (1 << 64) - 4000]),
    seq0=st.sampled_from([0, (1 << 32) - 5]),
    edits=st.lists(st.tuples(st.sampled_from(["dup", "swap", "drop", "start"]), st.integers(0, 29)), max_size=8),
)
@example(n_frames=1, start=0, seq0=(1 << 32) - 5, edits=[("start", 0)])  # found by hypothesis
def test_any_duplication_reorder_or_loss_keeps_every_count_exact(n_frames, start, seq0, edits) -> None:
    frames = [(seq0 + k) & 0xFFFFFFFF for k in range(n_frames)]
    order: list[object] = list(range(n_frames))
    for kind, at in edits:
        i = at % len(order)
        if kind == "dup":
            order.insert(i, order[i])
        elif kind == "swap" and i + 1 < len(order):
            order[i], order[i + 1] = order[i + 1], order[i]
        elif kind == "drop" and len(order) > 1:
            del order[i]
        elif kind == "start":
            order.insert(i, "start")
    stream = _reply(seq0 - 1 & 0xFFFFFFFF, FrameType.START, {"first_sample": start})
    for k in order:
        # a repeated START reply is the device's reply again: its own sequence number
        stream += (_reply(seq0 - 1 & 0xFFFFFFFF, FrameType.START, {"first_sample": start}) if k == "start"
                   else _data(frames[k], start + k * N))  # type: ignore[operator]
    stream += _reply(seq0 + n_frames & 0xFFFFFFFF, FrameType.STOP, {"next_sample": start + n_frames * N})
    dec = StreamDecoder()
    got = _delivered(dec, stream)
    firsts = [f for f, _ in got]
    assert firsts == sorted(set(firsts))  # every sample at most once, in order
    st_ = dec.stats
    assert st_.samples + st_.dropped_samples == n_frames * N  # exact against the STOP reply
    assert st_.lost_frames <= n_frames + len(edits) + 2  # never a jump by 2**32 - 1
