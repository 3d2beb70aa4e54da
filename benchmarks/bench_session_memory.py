"""Peak memory of a session over many long captures: streamed vs all read at once (issue 13).

    python benchmarks/bench_session_memory.py [--n 20] [--seconds 45] [--refine]

Writes ``--n`` captures of the simulated rig's ``duffing-smooth`` system (``--seconds`` at
19.2 kHz after a 1 s pre-trigger, force levels 300-1200 N, 45 dB) into one HDF5 session file,
then runs :func:`station.session.run_session` on it in two fresh processes, as ``station
replay`` / ``report`` / ``identify`` (several records) do:

* **streamed** (today): ``run_session(read_all([FILE]))``: the records are read one at a time
  (:class:`station.records.Records`) and each held-out record is conditioned when validated;
* **all at once** (before): ``run_session(tuple(read_all([FILE])))``: every capture in memory,
  every held-out record conditioned before the fit.

Prints each process's peak resident memory (``ru_maxrss``), its CPU and wall time, the same
model check (mean held-out nrmse must agree), the floor (a process that only reads one capture)
and the load average. ``--refine`` weighs the refinement on the held-out records (the default of
the commands; the streamed run then reads and conditions each held-out record twice).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)}

CHILD = """
import json, resource, sys, time
from station.session import read_all, run_session
from station.readers import read_measurement
path, mode, refine = sys.argv[1], sys.argv[2], sys.argv[3] == "1"
t0, c0 = time.perf_counter(), time.process_time()
if mode == "floor":
    read_measurement(path + ":0")
    out = {}
else:
    recs = read_all([path])
    if mode == "eager":
        recs = tuple(recs)
    s = run_session(recs, damping="v,x^2*v,v^3", stiffness="x,x^2,x^3,x^4,x^5", refine=refine)
    out = {"mean_nrmse": s.mean_nrmse, "k3": s.fit.model.eom.stiffness.get("x^3")}
out.update(wall=time.perf_counter() - t0, cpu=time.process_time() - c0,
           peak_mib=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
print(json.dumps(out))
"""


def generate(path: Path, n: int, seconds: float) -> float:
    """``n`` captures into one session file; returns the seconds it took."""
    sys.path.insert(0, str(REPO))
    from simulated_rig.bench import impact_test
    from station.readers import Measurement
    from station.storage import CaptureWriter
    from station.session_writer import import_measurement

    t0 = time.perf_counter()
    writer = CaptureWriter(path)
    for i in range(n):
        force = 300.0 + 900.0 * i / max(n - 1, 1)
        r = impact_test("duffing-smooth", force, snr_db=45.0, seed=i, record_s=seconds)
        meas = Measurement(t=r.t, channels={"force": r.force_n, "acc": r.acc_m_s2}, rate_hz=r.rate_hz,
                           pretrigger_samples=r.pretrigger_samples, mass=0.815, source=f"rig seed {i}")
        import_measurement(writer, meas)
    return time.perf_counter() - t0


def child(path: Path, mode: str, refine: bool) -> dict:
    res = subprocess.run([sys.executable, "-c", CHILD, str(path), mode, "1" if refine else "0"], env=ENV,
                         capture_output=True, text=True)
    if res.returncode != 0:
        raise SystemExit(f"{mode} run failed: {res.stderr.strip().splitlines()[-1]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=20, help="captures (default: %(default)s)")
    ap.add_argument("--seconds", type=float, default=45.0, help="record length after the trigger [s] (default: %(default)s)")
    ap.add_argument("--refine", action="store_true", help="weigh the refinement on the held-out records")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "session.h5"
        gen = generate(path, args.n, args.seconds)
        print(f"{args.n} captures x {args.seconds:g} s at 19.2 kHz: {path.stat().st_size / 2**20:.0f} MiB on disk "
              f"(written in {gen:.0f} s); load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
        floor = child(path, "floor", args.refine)
        rows = [("floor (read one capture)", floor), ("streamed (read_all: Records)", child(path, "stream", args.refine)),
                ("all at once (tuple, before)", child(path, "eager", args.refine))]
        for name, r in rows:
            extra = f"; mean held-out nrmse {r['mean_nrmse']:.5g}" if "mean_nrmse" in r else ""
            print(f"  {name:<30} peak {r['peak_mib']:7.0f} MiB = {r['peak_mib'] / floor['peak_mib']:5.2f}x the floor; "
                  f"cpu {r['cpu']:6.1f} s, wall {r['wall']:6.1f} s{extra}")
        s, e = rows[1][1], rows[2][1]
        print(f"streamed / all at once: peak memory {s['peak_mib'] / e['peak_mib']:.2f}x, CPU {s['cpu'] / e['cpu']:.2f}x; "
              f"same model: {'yes' if s['mean_nrmse'] == e['mean_nrmse'] and s['k3'] == e['k3'] else 'NO'}; "
              f"load average now {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
