"""Sustained stream over a pty: 8 channels x 51.2 kHz x 24 bit, paced in real time.

    python benchmarks/bench_stream.py [--seconds 60] [--block-size 256]

The emulated DAQ runs in a separate process (``--serve`` mode of this script) so the host's
CPU is measured alone. Prints drops, CRC errors, host CPU (% of one core), and the
sample-to-block latency: the time a block is handed to the caller minus the time its last
sample was acquired (device START time + sample counter / rate, same monotonic clock).
Targets: zero drops, host < 30 % of one core, latency < 50 ms.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

import numpy as np

RATE_HZ = 51_200.0
N_CHANNELS = 8


def serve(block_size: int) -> None:
    from simulated_rig.device import EmulatedDaq, PatternSource
    from simulated_rig.serve import PtyServer

    src = PatternSource(N_CHANNELS, rate_hz=RATE_HZ, adc_bits=24)
    server = PtyServer(EmulatedDaq(src, block_size=block_size), paced=True).start()
    sys.stdout.write(json.dumps({"port": server.port}) + "\n")
    sys.stdout.flush()
    try:
        sys.stdin.read()  # until the parent closes our stdin
    finally:
        server.close()


def host(seconds: float, block_size: int) -> None:
    import drivers
    from simulated_rig.device import PatternSource

    proc = subprocess.Popen([sys.executable, __file__, "--serve", "--block-size", str(block_size)],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        port = json.loads(proc.stdout.readline())["port"]
        with drivers.open_device(f"serial://{port}") as daq:
            daq.start()
            t_start = float(daq.start_reply["started_at_s"])
            lat = []
            n = 0
            bad = 0
            cpu0, wall0 = time.process_time(), time.monotonic()
            while time.monotonic() - wall0 < seconds:
                b = daq.read_block(timeout_s=1.0)
                if b is None:
                    continue
                now = time.monotonic()
                lat.append(now - (t_start + (b.first_sample + b.n_samples) / RATE_HZ))
                if n % 50 == 0:  # spot-check values (kept cheap so the CPU figure is the reader's)
                    want = PatternSource.expected(b.first_sample, b.n_samples, N_CHANNELS)
                    bad += int(not np.array_equal(b.counts, want))
                n += b.n_samples
            cpu = time.process_time() - cpu0
            wall = time.monotonic() - wall0
            daq.stop()
            st = daq.stats
    finally:
        proc.stdin.close()
        proc.wait(timeout=10)
    lat_ms = np.array(lat) * 1e3
    mb = st.bytes / 1e6
    print(f"stream {N_CHANNELS} ch x {RATE_HZ / 1e3:.1f} kHz x 24 bit over a pty, block {block_size}, {wall:.1f} s")
    print(f"  samples {n} ({n / wall / 1e3:.1f} kS/s per channel), {mb / wall:.2f} MB/s of frames")
    print(f"  dropped samples {st.dropped_samples}, crc errors {st.crc_errors}, resyncs {st.resyncs}, "
          f"lost frames {st.lost_frames}, bad spot-checks {bad}")
    print(f"  host CPU {100 * cpu / wall:.1f} % of one core")
    print(f"  latency ms: median {np.median(lat_ms):.1f}, p99 {np.percentile(lat_ms, 99):.1f}, max {lat_ms.max():.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--block-size", type=int, default=256)
    ap.add_argument("--serve", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.serve:
        serve(args.block_size)
    else:
        host(args.seconds, args.block_size)


if __name__ == "__main__":
    main()
