"""Wall time of ``station identify`` on a 45 s, 19.2 kHz force + acceleration record.

Writes the record (the simulated rig's ``duffing-smooth`` system, paper Sec. 3.3.1: 45 s
after a 1 s pre-trigger at 19200 Hz, 600 N blow, 45 dB) to a temporary CSV and times the
CLI end to end in a fresh process (interpreter start, imports, CSV read, conditioning,
identification with ``--route auto``, validation by simulation):

* **cold**: numba's on-disk cache in a fresh, empty directory (``NUMBA_CACHE_DIR``), so the
  compiled kernels (CSV parser, RK4) are compiled in that run, as on the first run after
  installation;
* **warm**: the same cache directory again, ``--runs`` times; minimum and median are printed
  (the machine may be shared: the minimum is the best estimate of an unloaded machine, the
  CPU time (user + sys of the child) is printed too).

Then an in-process breakdown (best of ``--runs``): CSV read, conditioning, identification,
validation. Target (engine issue): < 2 s wall on a 2-core machine, validation included.

Run: ``python benchmarks/bench_identify_speed.py [--runs 5]``
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from simulated_rig.bench import impact_test

ARGS = ["--mass", "0.815", "--damping", "v,x^2*v,v^3", "--stiffness", "x,x^2,x^3,x^4,x^5", "--json"]


def _run_cli(path: Path, cache_dir: str) -> tuple[float, float, str]:
    cmd = [sys.executable, "-m", "station.cli", "identify", str(path), *ARGS]
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True, check=True, env=env).stdout
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, out.split('"nrmse": ')[1].split(",")[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=5, help="warm runs (default 5)")
    runs = ap.parse_args().runs
    rec = impact_test("duffing-smooth", 600.0, snr_db=45.0, seed=1)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "long.csv"
        np.savetxt(path, np.column_stack((rec.t, rec.force_n, rec.acc_m_s2)), delimiter=",",
                   header="t,force,acc", comments="", fmt="%.9g")
        print(f"record: {rec.n_samples} samples ({rec.n_samples / rec.rate_hz:.1f} s at "
              f"{rec.rate_hz:.0f} Hz), {path.stat().st_size / 1e6:.1f} MB CSV; "
              f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
        cache = str(Path(tmp) / "numba-cache")
        wall, cpu, nrmse = _run_cli(path, cache)
        print(f"cold (empty numba cache)   wall {wall:5.2f} s, cpu {cpu:5.2f} s, nrmse {nrmse}")
        walls, cpus = [], []
        for _ in range(runs):
            wall, cpu, nrmse = _run_cli(path, cache)
            walls.append(wall)
            cpus.append(cpu)
        print(f"warm x{runs}: wall min {min(walls):.2f} s, median {statistics.median(walls):.2f} s; "
              f"cpu min {min(cpus):.2f} s, median {statistics.median(cpus):.2f} s "
              f"(load average now {os.getloadavg()[0]:.1f})")

        # in-process breakdown (warm: everything imported and compiled)
        from eddi.conditioning import condition
        from eddi.identify import identify
        from eddi.fit_record import identify_measurement
        from station.readers import read_csv

        best: dict[str, float] = {}
        for _ in range(runs):
            t0 = time.perf_counter()
            meas = read_csv(path)
            t1 = time.perf_counter()
            cond = condition(meas.t, acc=meas.channels["acc"], force=meas.channels["force"])
            t2 = time.perf_counter()
            identify(cond.t, cond.x, cond.v, 0.815, damping="v,x^2*v,v^3",
                     stiffness="x,x^2,x^3,x^4,x^5", a=cond.a, window=cond.window)
            t3 = time.perf_counter()
            identify_measurement(cond, 0.815, damping="v,x^2*v,v^3", stiffness="x,x^2,x^3,x^4,x^5")
            t4 = time.perf_counter()
            for key, dt in (("read CSV", t1 - t0), ("conditioning", t2 - t1), ("identify (auto)", t3 - t2),
                            ("identify + validate", t4 - t3)):
                best[key] = min(best.get(key, float("inf")), dt)
        print("in process, best of", runs, ": " + ", ".join(f"{k} {v:.2f} s" for k, v in best.items()))


if __name__ == "__main__":
    main()
