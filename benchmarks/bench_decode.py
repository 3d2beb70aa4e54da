"""Decoder throughput: MB/s of frames through :class:`drivers.protocol.StreamDecoder`.

    python benchmarks/bench_decode.py [--mb 50] [--chunk 65536]

Frames: 8 channels x 24 bit, 256 samples per frame (6 KiB), fed in chunks as a reader gets them.
Prints one line per configuration; the target is >= 50 MB/s.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from drivers.protocol import StreamDecoder, encode_data


def run(total_mb: float, chunk: int, n_channels: int, block: int, width: int) -> tuple[float, int]:
    rng = np.random.default_rng(0)
    lim = 1 << (8 * width - 1)
    counts = rng.integers(-lim, lim, (block, n_channels)).astype(np.int32)
    frame_len = len(encode_data(0, 0, counts, width, (1 << n_channels) - 1))
    n_frames = int(total_mb * 1e6 / frame_len) + 1
    stream = b"".join(encode_data(k, k * block, counts, width, (1 << n_channels) - 1) for k in range(n_frames))
    StreamDecoder().feed(stream[: 4 * frame_len])  # compile outside the timing
    dec = StreamDecoder()
    dec.expect_sample(0)
    t0 = time.perf_counter()
    for i in range(0, len(stream), chunk):
        dec.feed(stream[i : i + chunk])
    dt = time.perf_counter() - t0
    assert dec.stats.samples == n_frames * block and dec.stats.dropped_samples == 0
    return len(stream) / dt / 1e6, dec.stats.samples


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mb", type=float, default=50.0, help="megabytes of frames per run")
    ap.add_argument("--chunk", type=int, nargs="*", default=[4096, 65536, 1 << 20])
    args = ap.parse_args()
    for n_ch, block, width in [(8, 256, 3), (2, 256, 3), (8, 64, 2)]:
        for chunk in args.chunk:
            mbps, samples = run(args.mb, chunk, n_ch, block, width)
            print(f"decode {n_ch} ch x {8 * width} bit, {block} samples/frame, {chunk:>8d} B chunks: "
                  f"{mbps:7.1f} MB/s ({samples / 1e6:.2f} M samples)")


if __name__ == "__main__":
    main()
