"""Whole-process `station identify` of two trees, every way the kernels run, as ratios to the floor.

    python benchmarks/bench_identify_process.py --before REV [--after REV] [--rounds 7] [--cold 2]

Issue 13, item 1 (<= 0.5 s warm, <= 1.5 s with an empty JIT cache). Extracts ``--before`` (and
``--after``, default: this working tree) with ``git archive``, writes the 45 s x 19.2 kHz
record of ``bench_identify_speed.py`` (the rig's ``duffing-smooth``, 600 N, 45 dB, seed 1) as
CSV and ``.npy``, and times ``station identify FILE ... --json`` as a whole process (CPU of the
child, user + sys, and wall), ``--rounds`` times, the trees alternated so a change of load hits
both alike, in three set-ups per tree:

* ``aot``: the kernels built ahead of time (``python -m eddi.kernels`` into a temporary
  directory, ``EDDI_AOT_DIR``): an installation that ran the build;
* ``jit``: numba's JIT with a warm on-disk cache (``EDDI_JIT=1``, the cache filled once
  before): a fresh clone after its first run;
* ``cold``: numba's JIT with an empty ``NUMBA_CACHE_DIR`` every run (``--cold`` runs per tree,
  interleaved): a fresh clone's first run (CI).

Beside them the floor: ``python -c`` that ``np.load``s the same three columns and makes one
pass, timed in every round. Prints min and median per line, each as a ratio to the floor's
min, after / before, the load average, and whether the trees print the same JSON (byte for
byte). Each tree's bytecode is cached under its own ``PYTHONPYCACHEPREFIX`` (written by a first
run; ``PYTHONDONTWRITEBYTECODE``, set on the shared machine, is dropped for the children), as an
installed package has it: neither tree pays a compile of the project's modules at each start,
and a working tree's stale ``__pycache__`` cannot favour one side. Test-free: it only prints.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_identify_ab import ARGS, ONE_BLAS, REPO, child, extract, json_change  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", required=True, metavar="REV", help="git revision measured as 'before'")
    ap.add_argument("--after", default=None, metavar="REV", help="git revision as 'after' (default: this working tree)")
    ap.add_argument("--rounds", type=int, default=7, help="interleaved warm rounds (default %(default)s)")
    ap.add_argument("--cold", type=int, default=2, help="empty-cache runs per tree (default %(default)s; 0: none)")
    args = ap.parse_args()
    import numpy as np

    sys.path.insert(0, str(REPO))
    from simulated_rig.bench import impact_test

    rec = impact_test("duffing-smooth", 600.0, snr_db=45.0, seed=1)
    with tempfile.TemporaryDirectory() as tmp_s:
        tmp = Path(tmp_s)
        csv, npy = tmp / "long.csv", tmp / "long.npy"
        cols = np.column_stack((rec.t, rec.force_n, rec.acc_m_s2))
        np.savetxt(csv, cols, delimiter=",", header="t,force,acc", comments="", fmt="%.9g")
        np.save(npy, cols)
        trees = {"before": extract(args.before, tmp / "before"),
                 "after": extract(args.after, tmp / "after") if args.after else REPO}
        envs: dict[str, dict[str, str]] = {}
        for name, tree in trees.items():
            base = {**os.environ, **ONE_BLAS, "PYTHONPATH": str(tree), "PYTHONPYCACHEPREFIX": str(tmp / f"pyc-{name}")}
            base.pop("EDDI_AOT_DIR", None)
            base.pop("PYTHONDONTWRITEBYTECODE", None)
            aot = tmp / f"aot-{name}"
            aot.mkdir()
            built = subprocess.run([sys.executable, "-m", "eddi.kernels", "--output-dir", str(aot)],
                                   env={**base, "NUMBA_CACHE_DIR": str(tmp / f"nc-build-{name}")}, cwd=tree,
                                   capture_output=True, text=True)
            if built.returncode:
                print(f"({name}: building the kernels ahead of time failed; its aot line runs the JIT)")
            envs[f"{name} aot"] = {**base, "EDDI_AOT_DIR": str(aot), "EDDI_JIT": "0",
                                   "NUMBA_CACHE_DIR": str(tmp / f"nc-aot-{name}")}
            envs[f"{name} jit"] = {**base, "EDDI_JIT": "1", "NUMBA_CACHE_DIR": str(tmp / f"nc-{name}")}
            for how in ("jit", "aot"):  # numba's cache and the bytecode written before any timing
                child([sys.executable, "-m", "station.cli", "identify", str(csv), *ARGS], envs[f"{name} {how}"], tree)
        cmd = [sys.executable, "-m", "station.cli", "identify", str(csv), *ARGS]
        floor_cmd = [sys.executable, "-c", f"import numpy as np; a = np.load({str(npy)!r}); np.abs(a).sum(axis=0)"]
        runs: dict[str, list[tuple[float, float]]] = {"floor": [], **{k: [] for k in envs}}
        outputs: dict[str, str] = {}
        loads = []
        for _ in range(args.rounds):
            loads.append(os.getloadavg()[0])
            cpu, wall, _ = child(floor_cmd, {**os.environ, **ONE_BLAS}, REPO)
            runs["floor"].append((cpu, wall))
            for key, env in envs.items():
                name = key.split()[0]
                cpu, wall, out = child(cmd, env, trees[name])
                runs[key].append((cpu, wall))
                outputs[key] = out
        for i in range(args.cold):
            for name, tree in trees.items():
                key = f"{name} cold"
                env = {**envs[f"{name} jit"], "NUMBA_CACHE_DIR": str(tmp / f"nc-cold-{name}-{i}")}
                cpu, wall, out = child(cmd, env, tree)
                runs.setdefault(key, []).append((cpu, wall))
                outputs[key] = out
        f_cpu, f_wall = min(c for c, _ in runs["floor"]), min(w for _, w in runs["floor"])
        print(f"whole-process `station identify FILE --json` on {rec.n_samples} samples "
              f"({rec.n_samples / rec.rate_hz:.0f} s at {rec.rate_hz:.0f} Hz); before = {args.before}, after = "
              f"{args.after or 'this working tree'}; {args.rounds} interleaved rounds ({args.cold} cold); "
              f"load average {min(loads):.1f}-{max(loads):.1f} (now {os.getloadavg()[0]:.1f}) "
              f"on {os.cpu_count()} cores")
        for key, xs in runs.items():
            cpus, walls = [c for c, _ in xs], [w for _, w in xs]
            print(f"  {key:<12} cpu min {min(cpus):6.3f} s ({min(cpus) / f_cpu:5.2f}x floor) median "
                  f"{statistics.median(cpus):6.3f} s ({statistics.median(cpus) / f_cpu:5.2f}x); wall min "
                  f"{min(walls):6.3f} s ({min(walls) / f_wall:5.2f}x) median {statistics.median(walls):6.3f} s")
        for how in ("aot", "jit", "cold"):
            b, a = runs.get(f"before {how}"), runs.get(f"after {how}")
            if a and b:
                print(f"  after / before, {how}: cpu min {min(c for c, _ in a) / min(c for c, _ in b):.3f}, median "
                      f"{statistics.median(c for c, _ in a) / statistics.median(c for c, _ in b):.3f}")
        ref = outputs.get("before aot", "")
        for key, out in outputs.items():
            print(f"  JSON {key:<12} vs before aot: {json_change(ref, out)}")


if __name__ == "__main__":
    main()
