"""Save and read times of HDF5 session files at the paper's settings (19200 Hz, 45 s, 2 channels).

Run: python benchmarks/bench_storage.py [N_CAPTURES]; prints one line per save.
The counts are noise-like 24-bit values (the worst case for compression).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from drivers.channels import ChannelInfo
from station.storage import CaptureWriter, read_capture
from station.trigger import Capture

RATE = 19200.0  # paper Sec. 3.3.1
SECONDS = 45.0  # paper Sec. 3.3.1: 45 s records with 1 s pre-trigger


def main(n_captures: int = 10) -> None:
    force = ChannelInfo("force", "force", "N", scale=2.6e-4, range_si=2222.0, adc_bits=24)
    acc = ChannelInfo("acc", "acceleration", "m/s^2", scale=6e-7, range_si=5.0, adc_bits=24)
    n = int(RATE * SECONDS)
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as d:
        w = CaptureWriter(Path(d) / "session.h5")
        for i in range(n_captures):
            counts = np.rint(rng.normal(0, 2e4, (n, 2))).astype(np.int32)
            cap = Capture(counts, counts * np.array([force.scale, acc.scale]), (force, acc), RATE, 0, int(RATE), int(RATE))
            t0 = time.perf_counter()
            w.append(cap)
            dt = time.perf_counter() - t0
            print(f"save {i}: {dt:.3f} s, file {w.path.stat().st_size / 1e6:.1f} MB")
        t0 = time.perf_counter()
        read_capture(w.path, n_captures - 1)
        print(f"read last capture with SHA-256 check: {time.perf_counter() - t0:.3f} s")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("n_captures", nargs="?", type=int, default=10, help="captures to save (default: %(default)s)")
    main(ap.parse_args().n_captures)
