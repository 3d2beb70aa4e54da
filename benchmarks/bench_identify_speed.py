"""Wall time of ``station identify`` on a 45 s, 19.2 kHz force + acceleration record.

Writes the record (the simulated rig's ``duffing-smooth`` system, paper Sec. 3.3.1: 45 s
after a 1 s pre-trigger at 19200 Hz, 600 N blow, 45 dB) to a temporary CSV and times the
CLI end to end in a fresh process (interpreter start, imports, CSV read, conditioning,
identification, validation), twice: the first run may compile numba kernels (cold), the
second uses numba's on-disk cache (warm). Target: < 2 s wall on a 2-core machine.

Run: ``python benchmarks/bench_identify_speed.py``
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from simulated_rig.bench import impact_test


def main() -> None:
    rec = impact_test("duffing-smooth", 600.0, snr_db=45.0, seed=1)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "long.csv"
        np.savetxt(path, np.column_stack((rec.t, rec.force_n, rec.acc_m_s2)), delimiter=",",
                   header="t,force,acc", comments="", fmt="%.9g")
        print(f"record: {rec.n_samples} samples ({rec.n_samples / rec.rate_hz:.1f} s at "
              f"{rec.rate_hz:.0f} Hz), {path.stat().st_size / 1e6:.1f} MB CSV; "
              f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
        cmd = [sys.executable, "-m", "station.cli", "identify", str(path), "--mass", "0.815",
               "--damping", "v,x^2*v,v^3", "--stiffness", "x,x^2,x^3,x^4,x^5", "--json"]
        for label in ("first run (cold or cached)", "warm"):
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
            wall = time.perf_counter() - t0
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
            nrmse = out.split('"nrmse": ')[1].split(",")[0]
            print(f"{label:28s} wall {wall:5.2f} s, cpu {cpu:5.2f} s, nrmse {nrmse}")
    # in-process breakdown
    from eddi.conditioning import condition
    from eddi.pipeline import identify_measurement
    from station.readers import read_csv  # noqa: F401 (import cost measured above)
    t0 = time.perf_counter()
    cond = condition(rec.t, acc=rec.acc_m_s2, force=rec.force_n)
    t1 = time.perf_counter()
    identify_measurement(cond, 0.815, damping="v,x^2*v,v^3", stiffness="x,x^2,x^3,x^4,x^5")
    t2 = time.perf_counter()
    print(f"in process: conditioning {t1 - t0:.2f} s, identify + validate {t2 - t1:.2f} s")


if __name__ == "__main__":
    main()
