"""Throughput of the open firmware in QEMU (netduinoplus2): how fast the emulated DAQ streams.

    python benchmarks/bench_qemu_stream.py [--seconds 10] [--rates 3906.25,7812.5,15625,31250]
                                           [--channels 1,2] [--block-size 256]

For every rate x channel count the firmware (built with ``make -C firmware``) runs in QEMU
behind the relay pty, paced to its own clock, and the host's unchanged serial driver reads it
for ``--seconds``. QEMU's USART writes each byte to the pty as the guest stores it (no baud
rate), so the ceiling is the emulated CPU plus one host write per byte. Prints, per case,
the rate asked and reported, the wire bytes/s required (the floor) and achieved (ratio), the
samples received and dropped (exact, from the device counter), the firmware's FIFO overruns,
and the host and QEMU CPU (% of one core). A case keeps up when it drops nothing.
"""

from __future__ import annotations

import argparse
import os
import resource
import time

import drivers
from simulated_rig.qemu import QemuRig


def _cpu_of(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def run_case(rate: float, n_ch: int, seconds: float, block: int) -> dict:
    with QemuRig("duffing") as rig, drivers.open_device(rig.url, timeout_s=5.0) as daq:
        info = daq.configure(rate_hz=rate, channels=list(range(n_ch)), block_size=block)
        width = 3
        q0, h0 = _cpu_of(rig.proc.pid), resource.getrusage(resource.RUSAGE_SELF)
        t0 = time.monotonic()
        daq.start()
        while time.monotonic() - t0 < seconds:
            daq.read_block(1.0)
        daq.stop()
        while daq.read_block(0.2) is not None:
            pass
        wall = time.monotonic() - t0
        q1, h1 = _cpu_of(rig.proc.pid), resource.getrusage(resource.RUSAGE_SELF)
        st = daq.stats
        status = daq.status()
    host_cpu = (h1.ru_utime + h1.ru_stime - h0.ru_utime - h0.ru_stime) / wall
    need = info.rate_hz * n_ch * width * (1 + 26 / (block * n_ch * width))
    return {"rate": info.rate_hz, "ch": n_ch, "need_Bps": need, "got_Bps": st.bytes / wall,
            "samples": st.samples, "dropped": st.dropped_samples, "next_sample": status["next_sample"],
            "overruns": status["overrun_frames"], "crc": st.crc_errors, "qemu_cpu": (q1 - q0) / wall,
            "host_cpu": host_cpu}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--rates", default="3906.25,7812.5,15625,31250")
    ap.add_argument("--channels", default="1,2")
    ap.add_argument("--block-size", type=int, default=256)
    args = ap.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    print(f"{'rate Hz':>9} {'ch':>2} {'need B/s':>9} {'got B/s':>9} {'ratio':>6} {'samples':>9} {'dropped':>8} "
          f"{'overruns':>8} {'crc':>3} {'qemu cpu':>8} {'host cpu':>8}")
    for rate in (float(r) for r in args.rates.split(",")):
        for n_ch in (int(c) for c in args.channels.split(",")):
            r = run_case(rate, n_ch, args.seconds, args.block_size)
            assert r["samples"] + r["dropped"] == r["next_sample"], r  # exact accounting
            print(f"{r['rate']:>9g} {r['ch']:>2} {r['need_Bps']:>9.0f} {r['got_Bps']:>9.0f} "
                  f"{r['got_Bps'] / r['need_Bps']:>6.2f} {r['samples']:>9} {r['dropped']:>8} {r['overruns']:>8} "
                  f"{r['crc']:>3} {100 * r['qemu_cpu']:>7.0f}% {100 * r['host_cpu']:>7.0f}%")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
