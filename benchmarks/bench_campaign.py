"""Throughput of ``station campaign`` on 1 and 2 local Dask workers, and what 1M captures would take.

1. Generates ``--n`` captures (default 1000) on the simulated rig: its systems in turn
   (``--systems``, default paper-duffing and duffing-struts, whose ring-downs last 1 s and 4 s),
   each at its three demo blow levels, seed = capture number, 45 dB, ``--rate`` Hz (default
   10 kHz), 0.2 s pre-trigger; saved as raw ADC counts through ``station.storage.CaptureWriter``
   into HDF5 sessions of ``--per-session`` captures (default 50). Reused when ``--data`` already
   holds the same set (``manifest.json``).
2. Floor: the same per-capture work (read + identify, :func:`station.campaign.tasks.run_capture`)
   in a plain loop in this process, on the first ``--floor-n`` captures (no Dask).
3. The campaign on a LocalCluster of 1, then 2 worker processes (one thread each), after a
   warm-up on every worker (imports, JIT cache loads: printed apart). Prints captures/s, the
   ratio to the floor, the speed-up of 2 workers over 1 (target >= 1.8x on 2 cores), the peak
   resident memory of each worker, and the projected time for 1M captures on N workers.

The machine may be shared: for each run the 1-minute load average and the CPU the rest of the
machine used meanwhile (all busy CPU time minus this benchmark's processes) are printed, since
a speed-up measured while other processes hold the cores says little about the code.

Run: ``python benchmarks/bench_campaign.py [--n 1000] [--workers 1,2] [--data DIR]``
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

# the floor loop runs BLAS single-threaded, as the CLI and Dask's workers do (station.cli, the
# nanny's pre-spawn environment): set before numpy is imported
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
import psutil  # noqa: E402

from simulated_rig.bench import impact_test
from simulated_rig.systems import system_info
from station.campaign import tasks
from station.campaign.run import MAX_AUTO_CHUNK, dask_client, run_campaign
from station.campaign.sources import expand_sources
from station.campaign.table import Journal
from station.storage import CaptureWriter
from station.trigger import Capture

OPTS = tasks.TaskOptions(task="identify", mass=None, damping="v,x^2*v,v^3", stiffness="x,x^2,x^3")


def generate(data: Path, n: int, systems: list[str], rate: float, per_session: int) -> float:
    """Write the captures (or reuse them); return the seconds spent."""
    manifest = {"n": n, "systems": systems, "rate": rate, "per_session": per_session, "snr_db": 45.0}
    mf = data / "manifest.json"
    if mf.exists() and json.loads(mf.read_text()) == manifest:
        return 0.0
    data.mkdir(parents=True, exist_ok=True)
    for old in data.glob("session-*.h5"):
        old.unlink()
    t0 = time.perf_counter()
    writer = None
    for i in range(n):
        if i % per_session == 0:
            writer = CaptureWriter(data / f"session-{i // per_session:04d}.h5")
        name = systems[i % len(systems)]
        info = system_info(name)
        force = info.demo_forces_n[(i // len(systems)) % len(info.demo_forces_n)]
        r = impact_test(name, force, rate_hz=rate, pretrigger_s=0.2, seed=i)
        cap = Capture(counts=r.counts, si=np.column_stack([r.force_n, r.acc_m_s2]), channels=r.channels,
                      rate_hz=r.rate_hz, first_sample=0, trigger_sample=r.pretrigger_samples,
                      pretrigger_samples=r.pretrigger_samples)
        writer.append(cap, mass_kg=info.eom.mass, source=f"simulated rig {name} {force:g} N seed {i}")
        if sys.stderr.isatty():
            print(f"\rgenerating {i + 1}/{n}", end="", file=sys.stderr)
    if sys.stderr.isatty():
        print(file=sys.stderr)
    mf.write_text(json.dumps(manifest))
    return time.perf_counter() - t0


def _busy_cpu_s() -> float:
    c = psutil.cpu_times()
    return c.user + c.nice + c.system + getattr(c, "irq", 0.0) + getattr(c, "softirq", 0.0) + getattr(c, "steal", 0.0)


def _own_cpu_s(client=None) -> float:
    """CPU seconds of this process and its children (+ the workers of ``client``)."""
    me = psutil.Process()
    total = sum(me.cpu_times()[:2])
    for ch in me.children(recursive=True):
        try:
            total += sum(ch.cpu_times()[:2])
        except psutil.NoSuchProcess:
            pass
    return total


def floor_loop(refs: list, n: int, opts: tasks.TaskOptions) -> tuple[float, float, int]:
    """Plain in-process loop after one warm-up capture: (wall s, CPU s, captures)."""
    tasks.warm_up()
    tasks.run_capture(refs[0], opts)
    part = refs[1:n + 1]
    t0, c0 = time.perf_counter(), time.process_time()
    for r in part:
        tasks.run_capture(r, opts)
    return time.perf_counter() - t0, time.process_time() - c0, len(part)


def run_on(workers: int, refs: list, out: Path, chunk: int, opts: tasks.TaskOptions, idle_s: float = 5.0) -> dict:
    """One campaign on a fresh LocalCluster; figures of merit and the machine's load."""
    with dask_client(None, workers) as client:
        client.run(tasks.warm_up)
        i0, c0 = time.perf_counter(), _own_cpu_s()
        time.sleep(idle_s)  # the cluster idle: its background CPU (heartbeats, event loops)
        idle_cores = (_own_cpu_s() - c0) / (time.perf_counter() - i0)
        load0 = os.getloadavg()[0]
        busy0, own0 = _busy_cpu_s(), _own_cpu_s()
        res = run_campaign(client, refs, opts, Journal(out, opts.as_dict()), chunk=chunk, quiet=True)
        busy1, own1 = _busy_cpu_s(), _own_cpu_s()
        load1 = os.getloadavg()[0]
    import pyarrow.parquet as pq

    rows = pq.read_table(res.parquet, columns=["status", "seconds"]).to_pylist()
    task_s = [r["seconds"] for r in rows if r["seconds"] is not None]
    others = max(0.0, (busy1 - busy0) - (own1 - own0))
    return {"workers": workers, "rate": res.captures_per_s, "wall": res.wall_s, "warm": res.warm_up_s,
            "failed": res.failed, "processed": res.processed, "mem": sorted(res.peak_memory_mb.values()),
            "task_median_s": statistics.median(task_s), "task_sum_s": sum(task_s),
            "load": (load0, load1), "others_cores": others / res.wall_s if res.wall_s else 0.0,
            "own_cores": (own1 - own0) / res.wall_s if res.wall_s else 0.0,
            "cpu_per_capture_s": (own1 - own0) / res.processed if res.processed else float("nan"),
            "idle_cores": idle_cores,
            "net_cpu_per_capture_s": ((own1 - own0) - idle_cores * res.wall_s) / res.processed
            if res.processed else float("nan")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                 epilog="See the module docstring: python -c 'import benchmarks.bench_campaign as b; help(b)'")
    ap.add_argument("--n", type=int, default=1000, help="captures to generate and process (default 1000)")
    ap.add_argument("--systems", default="paper-duffing,duffing-struts", help="rig systems, in turn")
    ap.add_argument("--rate", type=float, default=10000.0, help="sample rate [Hz] (default 10000)")
    ap.add_argument("--per-session", type=int, default=50, help="captures per HDF5 session file (default 50)")
    ap.add_argument("--workers", default="1,2", help="worker counts to run, comma-separated (default 1,2)")
    ap.add_argument("--chunk", type=int, default=None,
                    help="captures per Dask task (default: as station campaign, station.campaign.run.auto_chunk)")
    ap.add_argument("--floor-n", type=int, default=100, help="captures of the in-process floor loop (default 100)")
    ap.add_argument("--data", help="folder for the generated sessions (kept; default: a temporary folder)")
    ap.add_argument("--refine", action=argparse.BooleanOptionalAction, default=None,
                    help="output-error refinement (default: as station identify)")
    args = ap.parse_args()
    opts = tasks.TaskOptions(task=OPTS.task, damping=OPTS.damping, stiffness=OPTS.stiffness, refine=args.refine)
    systems = [s.strip() for s in args.systems.split(",") if s.strip()]
    counts = [int(w) for w in args.workers.split(",")]

    with tempfile.TemporaryDirectory(prefix="bench-campaign-") as tmp:
        data = Path(args.data) if args.data else Path(tmp) / "data"
        gen_s = generate(data, args.n, systems, args.rate, args.per_session)
        refs = expand_sources([str(data / "session-*.h5")])
        size_mb = sum(p.stat().st_size for p in data.glob("session-*.h5")) / 2**20
        print(f"{len(refs)} captures ({', '.join(systems)}; {args.rate:g} Hz; {size_mb:.0f} MiB in "
              f"{len(list(data.glob('session-*.h5')))} sessions)" + (f", generated in {gen_s:.1f} s" if gen_s else ", reused"))
        print(f"machine: {os.cpu_count()} cores, load average now {os.getloadavg()[0]:.2f}")
        fl_s, fl_cpu, fl_n = floor_loop(refs, min(args.floor_n, len(refs) - 1), opts)
        floor_rate = fl_n / fl_s
        print(f"floor (plain loop in one process, no Dask, {fl_n} captures): {floor_rate:.2f} captures/s, "
              f"CPU per capture {1000 * fl_cpu / fl_n:.0f} ms (this process got {fl_cpu / fl_s:.2f} of a core)")
        results = []
        for w in counts:
            r = run_on(w, refs, Path(tmp) / f"out-{w}", args.chunk, opts)
            results.append(r)
            print(f"{w} worker(s): {r['rate']:.2f} captures/s ({r['processed']} in {r['wall']:.1f} s, "
                  f"{r['failed']} failed rows; {r['rate'] / floor_rate:.2f}x the floor), "
                  f"warm-up {r['warm']:.1f} s, median task {1000 * r['task_median_s']:.0f} ms, "
                  f"peak memory per worker {', '.join(f'{m:.0f}' for m in r['mem'])} MiB; "
                  f"load avg {r['load'][0]:.2f} -> {r['load'][1]:.2f}, this run used {r['own_cores']:.2f} cores, "
                  f"other processes {r['others_cores']:.2f} cores; CPU per capture {1000 * r['cpu_per_capture_s']:.0f} ms "
                  f"(client + scheduler + nannies + workers; {1000 * r['net_cpu_per_capture_s']:.0f} ms without the "
                  f"idle cluster's {r['idle_cores']:.3f} cores of background)")
        base = next((r for r in results if r["workers"] == 1), None)
        if base is not None:
            for r in results:
                if r["workers"] > 1:
                    sp = r["rate"] / base["rate"]
                    print(f"speed-up {r['workers']} workers / 1: {sp:.2f}x wall (target >= {0.9 * r['workers']:.1f}x)"
                          + ("" if sp >= 0.9 * r["workers"] else "  [below target; see the load above]"))
                    cpu_sp = r["workers"] * base["cpu_per_capture_s"] / r["cpu_per_capture_s"]
                    print(f"  on {r['workers']} cores of its own it would be {cpu_sp:.2f}x (workers x the ratio of CPU "
                          f"per capture, {1000 * base['cpu_per_capture_s']:.0f} ms on 1 worker vs "
                          f"{1000 * r['cpu_per_capture_s']:.0f} ms on {r['workers']}): an estimate, not a measurement")
                    print(f"  floor CPU per capture {1000 * fl_cpu / fl_n:.0f} ms vs campaign net "
                          f"{1000 * r['net_cpu_per_capture_s']:.0f} ms: Dask's cost per capture "
                          f"{1000 * (r['net_cpu_per_capture_s'] - fl_cpu / fl_n):.0f} ms")
            widest = max(results, key=lambda r: r["workers"])
            big_chunk = args.chunk or MAX_AUTO_CHUNK  # a million captures: the automatic chunk's cap
            eff = min(1.0, widest["rate"] / (widest["workers"] * base["rate"]))
            per_worker = base["rate"]
            print(f"projection for 1,000,000 captures (per-worker rate {per_worker:.2f}/s measured on 1 worker, "
                  f"parallel efficiency {eff:.2f} measured on {widest['workers']}; the Dask scheduler handles a few thousand "
                  f"tasks/s, so beyond ~{int(2000 * big_chunk / max(per_worker, 1e-9))} workers use larger --chunk):")
            cpu_rate = 1.0 / widest["net_cpu_per_capture_s"]  # captures per core-second, net of idle background
            print(f"  {'workers':>7}  {'from wall rates here':>20}  {'from CPU per capture (own cores)':>32}")
            for n in (2, 16, 64, 256, 1024):
                rate = min(n * per_worker * eff, 2000.0 * big_chunk)
                rate_cpu = min(n * cpu_rate, 2000.0 * big_chunk)
                print(f"  {n:7d}  {1e6 / rate / 3600:18.2f} h  {1e6 / rate_cpu / 3600:30.2f} h")


if __name__ == "__main__":
    main()
