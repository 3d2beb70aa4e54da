"""`station identify` before and after a change: two trees of this repository, same run, interleaved.

    python benchmarks/bench_identify_ab.py --before REV [--after REV] [--rounds 3] [--no-refine]

Extracts ``--before`` (and ``--after``, default: this working tree) with ``git archive`` into
temporary directories, builds each tree's kernels ahead of time (``python -m eddi.kernels``),
writes the 45 s x 19.2 kHz record of ``bench_identify_speed.py`` (the rig's
``duffing-smooth``, 600 N, 45 dB, seed 1) as CSV and ``.npy``, and then, ``--rounds`` times,
alternating the trees so a change of load hits both alike:

* the whole process ``station identify FILE ... --json`` (CPU of the child: user + sys);
* the library call on the arrays in one child process per tree
  (:func:`station.commands.identify.run_identify`, one BLAS thread, best of ``--calls``
  after a warm-up call);
* the floor: ``python -c`` that ``np.load``s the same columns and makes one pass (whole
  process), and the same inside the in-process child.

Prints each figure as a ratio to its floor and after / before, the load average, and whether
the two trees print the same JSON (byte for byte, else the largest coefficient change in
units of its 95 % interval and the two nrmse). Test-free: it only prints.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
ARGS = ["--mass", "0.815", "--damping", "v,x^2*v,v^3", "--stiffness", "x,x^2,x^3,x^4,x^5", "--json"]
ONE_BLAS = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}

#: In-process child: prints ``floor_cpu best_call_cpu`` [s].
IN_PROCESS = """
import sys, time
import numpy as np
from station.commands.identify import run_identify
from station.readers import read_measurement
csv, npy, refine, calls = sys.argv[1], sys.argv[2], sys.argv[3] == "1", int(sys.argv[4])
meas = read_measurement(csv)
args = (meas, 0.815, "v,x^2*v,v^3", "x,x^2,x^3,x^4,x^5")
run_identify(*args, refine=refine)
floor, call = [], []
for _ in range(calls):
    c0 = time.process_time(); a = np.load(npy); np.abs(a).sum(axis=0); floor.append(time.process_time() - c0)
    c0 = time.process_time(); run_identify(*args, refine=refine); call.append(time.process_time() - c0)
print(min(floor), min(call))
"""


def child(cmd: list[str], env: dict[str, str], cwd: Path) -> tuple[float, float, str]:
    """(CPU seconds, wall seconds, stdout) of one child process (also bench_identify_process.py's)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run(cmd, env=env, cwd=cwd, capture_output=True, text=True).stdout
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), wall, out


def child_cpu(cmd: list[str], env: dict[str, str], cwd: Path) -> tuple[float, str]:
    """(CPU seconds, stdout) of one child process."""
    cpu, _wall, out = child(cmd, env, cwd)
    return cpu, out


def extract(rev: str, into: Path) -> Path:
    """The tree of ``rev`` (``git archive``) in ``into``."""
    into.mkdir(parents=True)
    archive = subprocess.run(["git", "-C", str(REPO), "archive", rev], capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


def tree_env(tree: Path, aot: Path) -> dict[str, str]:
    """Environment that runs ``tree``'s code with its own ahead-of-time kernels."""
    env = {**os.environ, **ONE_BLAS, "PYTHONPATH": str(tree), "EDDI_AOT_DIR": str(aot)}
    env.pop("EDDI_JIT", None)
    return env


def json_change(a: str, b: str) -> str:
    """How the two trees' JSON differ: identical, or the largest coefficient change in ci95."""
    if a == b:
        return "byte-identical"
    try:
        ja, jb = json.loads(a), json.loads(b)
    except ValueError:
        return "differs (not both JSON)"
    worst = 0.0
    for group in ("damping", "stiffness"):
        for term, c in ja[group].items():
            other = jb[group].get(term)
            ci = ja["ci95"][group].get(term) or float("inf")
            worst = max(worst, float("inf") if other is None else abs(other - c) / ci)
    keys = sorted(k for k in set(ja) | set(jb) if ja.get(k) != jb.get(k))
    return (f"differs: largest coefficient change {worst:.2g} of its ci95; nrmse "
            f"{ja['validation']['nrmse']:.6g} -> {jb['validation']['nrmse']:.6g}; keys that differ: "
            f"{', '.join(keys)}" + (" (validation: " + ", ".join(sorted(
                k for k in set(ja['validation']) | set(jb['validation'])
                if ja['validation'].get(k) != jb['validation'].get(k))) + ")" if "validation" in keys else ""))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", required=True, metavar="REV", help="git revision measured as 'before'")
    ap.add_argument("--after", default=None, metavar="REV", help="git revision as 'after' (default: this working tree)")
    ap.add_argument("--rounds", type=int, default=3, help="interleaved rounds; the best of each is kept (default 3)")
    ap.add_argument("--calls", type=int, default=3, help="library calls per in-process child (default 3)")
    ap.add_argument("--no-refine", action="store_true", help="pass --no-refine")
    args = ap.parse_args()
    sys.path.insert(0, str(REPO))
    import numpy as np

    from simulated_rig.bench import impact_test

    rec = impact_test("duffing-smooth", 600.0, snr_db=45.0, seed=1)
    extra = ["--no-refine"] if args.no_refine else []
    with tempfile.TemporaryDirectory() as tmp_s:
        tmp = Path(tmp_s)
        csv, npy = tmp / "long.csv", tmp / "long.npy"
        cols = np.column_stack((rec.t, rec.force_n, rec.acc_m_s2))
        np.savetxt(csv, cols, delimiter=",", header="t,force,acc", comments="", fmt="%.9g")
        np.save(npy, cols)
        trees = {"before": extract(args.before, tmp / "before"),
                 "after": extract(args.after, tmp / "after") if args.after else REPO}
        envs = {}
        for name, tree in trees.items():
            aot = tmp / f"aot-{name}"
            aot.mkdir()
            env = tree_env(tree, aot)
            built = subprocess.run([sys.executable, "-m", "eddi.kernels", "--output-dir", str(aot)], env=env,
                                   cwd=tree, capture_output=True, text=True)
            if built.returncode:
                print(f"({name}: building the kernels ahead of time failed; numba's JIT is used)")
            envs[name] = env
        whole = {name: [] for name in trees}
        inproc = {name: [] for name in trees}
        outputs: dict[str, str] = {}
        floor_whole, floor_in = [], []
        floor_cmd = [sys.executable, "-c", f"import numpy as np; a = np.load({str(npy)!r}); np.abs(a).sum(axis=0)"]
        for _ in range(args.rounds):
            floor_whole.append(child_cpu(floor_cmd, {**os.environ, **ONE_BLAS}, REPO)[0])
            for name, tree in trees.items():
                cpu, out = child_cpu([sys.executable, "-m", "station.cli", "identify", str(csv), *ARGS, *extra],
                                     envs[name], tree)
                whole[name].append(cpu)
                outputs[name] = out
                _, out = child_cpu([sys.executable, "-c", IN_PROCESS, str(csv), str(npy),
                                    "0" if args.no_refine else "1", str(args.calls)], envs[name], tree)
                f, c = (float(v) for v in out.split())
                floor_in.append(f)
                inproc[name].append(c)
        fw, fi = min(floor_whole), min(floor_in)
        print(f"`station identify FILE{' --no-refine' if extra else ''}` on {rec.n_samples} samples "
              f"({rec.n_samples / rec.rate_hz:.0f} s at {rec.rate_hz:.0f} Hz); before = {args.before}, after = "
              f"{args.after or 'this working tree'}; {args.rounds} interleaved rounds, best kept; "
              f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
        print(f"  whole process   floor (np.load + one pass) cpu {fw:.3f} s")
        for name in trees:
            print(f"  whole process   {name:<7} cpu min {min(whole[name]):.3f} s = {min(whole[name]) / fw:5.1f}x the floor "
                  f"(runs {', '.join(f'{c:.2f}' for c in whole[name])})")
        print(f"  in process      floor (np.load + one pass) cpu {1000 * fi:.1f} ms")
        for name in trees:
            print(f"  in process      {name:<7} cpu min {1000 * min(inproc[name]):.1f} ms = "
                  f"{min(inproc[name]) / fi:5.1f}x the floor")
        print(f"  after / before: whole process {min(whole['after']) / min(whole['before']):.3f}, "
              f"in process {min(inproc['after']) / min(inproc['before']):.3f}")
        print(f"  JSON: {json_change(outputs['before'], outputs['after'])}")


if __name__ == "__main__":
    main()
