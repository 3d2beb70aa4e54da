"""Save time of HDF5 session files against the number of captures already in the file.

Paper settings (Sec. 3.3.1): 19200 Hz, 45 s records, 2 channels of 24-bit counts, noise-like
(the worst case for compression). Each save goes through ``CaptureWriter.append`` (writer lock,
overlay, redo journal, fsync: ``docs/capture-format.md``). Printed:

- the wall and CPU time of each save and the bytes it changed inside the existing file (the
  journal); CPU time (this process's) is the figure to compare on a busy machine;
- the ratio of save #N to save #1 (median of the last 3 over the first 3), wall and CPU: ~1
  when a save is O(1) in the number of captures already saved;
- with ``--peer``, the same for the version-1 method measured in the same run (read the whole
  file, add the capture in memory, write it beside, fsync, rename), which grows with the file;
- the time to stream every capture back (``iter_captures``, SHA-256 checked) and its peak
  memory next to one capture's size.

Examples::

    python benchmarks/bench_storage.py                 # 50 captures of 45 s (~220 MB file)
    python benchmarks/bench_storage.py --captures 20 --seconds 10 --peer
"""

from __future__ import annotations

import argparse
import io
import os
import statistics
import tempfile
import time
import tracemalloc
from pathlib import Path

import h5py
import numpy as np

from drivers.channels import ChannelInfo
from station import journal
from station.session_writer import CaptureWriter, _new_file, _record_from_capture, _write_record
from station.storage import iter_captures
from station.trigger import Capture

RATE = 19200.0  # paper Sec. 3.3.1
FORCE = ChannelInfo("force", "force", "N", scale=2.6e-4, range_si=2222.0, adc_bits=24)
ACC = ChannelInfo("acc", "acceleration", "m/s^2", scale=6e-7, range_si=5.0, adc_bits=24)


def _capture(rng: np.random.Generator, n: int) -> Capture:
    counts = np.rint(rng.normal(0, 2e4, (n, 2))).astype(np.int32)
    return Capture(counts, counts * np.array([FORCE.scale, ACC.scale]), (FORCE, ACC), RATE, 0, int(RATE), int(RATE))


def _save_v1(path: Path, cap: Capture) -> None:
    """The version-1 save, for comparison: the whole file read, rebuilt in memory, written, renamed."""
    buf = io.BytesIO(path.read_bytes()) if path.exists() else io.BytesIO()
    if not path.exists():
        _new_file(buf, {})
    with h5py.File(buf, "r+") as f:
        _write_record(f, _record_from_capture(cap), {})
    tmp = path.with_name(f".{path.name}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
    try:
        journal.pwrite_all(fd, buf.getbuffer(), 0)
        os.fsync(fd)
    finally:
        os.close(fd)
    os.replace(tmp, path)


def _ratio(times: list[float]) -> float:
    k = min(3, len(times) // 2) or 1
    return statistics.median(times[-k:]) / statistics.median(times[:k])


def run(n_captures: int, seconds: float, peer: bool, stream: bool) -> None:
    n = int(RATE * seconds)
    patched: list[int] = []
    real_commit = journal.commit

    def commit(path, overlay, hooks=None):  # type: ignore[no-untyped-def]
        patched.append(sum(len(b) for _, b in overlay.patches()))
        return real_commit(path, overlay, hooks)

    journal.commit = commit  # type: ignore[assignment]
    print(f"load average at start: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "session.h5"
        w = CaptureWriter(path)
        times, cpu = [], []
        for i in range(n_captures):
            cap = _capture(np.random.default_rng(i), n)
            t0, c0 = time.perf_counter(), time.process_time()
            w.append(cap)
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
            changed = f", {patched[-1] / 1e3:.1f} kB changed in place" if i and patched else ""
            print(f"save #{i + 1}: {times[-1]:.3f} s wall, {cpu[-1]:.3f} s CPU, file {path.stat().st_size / 1e6:.1f} MB"
                  f"{changed}")
        print(f"O(1) append: save #{n_captures} / save #1 = {_ratio(times):.2f} wall, {_ratio(cpu):.2f} CPU "
              f"(median of 3 each; 1.0 = flat); in place: max {max(patched[1:] or [0]) / 1e3:.1f} kB per save")
        if stream:
            tracemalloc.start()
            t0 = time.perf_counter()
            count = sum(1 for _ in iter_captures(path))
            dt = time.perf_counter() - t0
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            one = n * 2 * (4 + 8)  # counts + SI values of one capture [bytes]
            print(f"stream {count} captures (SHA-256 checked): {dt:.2f} s, peak memory {peak / 1e6:.0f} MB "
                  f"= {peak / one:.1f} x one capture ({one / 1e6:.0f} MB); all at once would be {count * one / 1e6:.0f} MB")
        if peer:
            v1 = Path(d) / "v1.h5"
            old, old_cpu = [], []
            for i in range(n_captures):
                cap = _capture(np.random.default_rng(i), n)
                t0, c0 = time.perf_counter(), time.process_time()
                _save_v1(v1, cap)
                old.append(time.perf_counter() - t0)
                old_cpu.append(time.process_time() - c0)
            print(f"version-1 whole-file rewrite (peer): save #1 {old_cpu[0]:.3f} s CPU, save #{n_captures} "
                  f"{old_cpu[-1]:.3f} s CPU, ratio {_ratio(old):.2f} wall, {_ratio(old_cpu):.2f} CPU; total CPU "
                  f"{sum(old_cpu):.1f} s vs {sum(cpu):.1f} s appending ({sum(old_cpu) / sum(cpu):.1f}x)")
    journal.commit = real_commit  # type: ignore[assignment]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--captures", type=int, default=50, help="captures to save (default %(default)s)")
    p.add_argument("--seconds", type=float, default=45.0, help="record length [s] (default %(default)s, paper)")
    p.add_argument("--peer", action="store_true", help="also time the version-1 whole-file rewrite")
    p.add_argument("--no-stream", dest="stream", action="store_false", help="skip the streaming read")
    args = p.parse_args()
    if args.captures < 2 or not args.seconds > 0:
        p.error("expected --captures >= 2 and --seconds > 0")
    run(args.captures, args.seconds, args.peer, args.stream)


if __name__ == "__main__":
    main()
