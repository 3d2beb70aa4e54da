"""Cost of ``station diagnose --refine`` on multi-channel captures: the polish's Jacobian from forward
sensitivities (default) beside scipy's finite differences, same captures, same run.

The output-error polish (:mod:`eddi.mdof.refine`) refines every held-out fold's models and the
final one; its Jacobian was one simulation per parameter (``jac="2-point"``) and is now one
simulation with its variational equations (:mod:`eddi.mdof.sensitivity`). Printed per mode: CPU
seconds (this process and its forked fold workers), the verdict, the baseline / coupled held-out
nrmse and every fold's nrmse; then the CPU ratio and the largest fold-nrmse difference. Floor:
the verdict and the fold rows must agree (nrmse within 2 % relative), and the ratio is printed
against the finite-difference run of the same process (no absolute time floor: the machine is shared).

    PYTHONPATH=. python benchmarks/bench_mdof_polish.py [--system benchmarks/mdof_heldout/three-mass-chain.toml]
        [--record-s 3] [--modes sensitivity,2-point]
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import io
import json
import resource
import tempfile
from pathlib import Path

import eddi.mdof.refine as refine
from simulated_rig.mdof_systems import load_mdof_system, mdof_impact_test
from station.cli import main


def _cpu() -> float:
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


def _diagnose(files: list[str], mode: str) -> tuple[float, dict]:
    original = refine.refine_identified
    refine.refine_identified = functools.partial(original, jac=mode)  # station imports it at call time
    try:
        out = io.StringIO()
        start = _cpu()
        with contextlib.redirect_stdout(out):
            code = main(["diagnose", *files, "--json"])
        spent = _cpu() - start
    finally:
        refine.refine_identified = original
    obj = json.loads(out.getvalue())
    obj["_exit"] = code
    return spent, obj


def _folds(obj: dict) -> list[float]:
    rows = []
    for side in ("baseline", "coupled"):
        rows.append(float(obj[side]["nrmse"]))
        rows.extend(float(f) for f in obj[side]["folds"])
    return rows


def main_(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--system", default="benchmarks/mdof_heldout/three-mass-chain.toml")
    ap.add_argument("--record-s", type=float, default=None, help="record length [s] (default: the system's)")
    ap.add_argument("--modes", default="sensitivity,2-point")
    args = ap.parse_args(argv)
    system = load_mdof_system(args.system)
    with tempfile.TemporaryDirectory() as tmp:
        files = []
        for k, peak in enumerate(system.impacts_n):
            kw = {} if args.record_s is None else {"record_s": args.record_s}
            rec = mdof_impact_test(system, peak, seed=10 + k, **kw)
            files.append(str(rec.write_csv(Path(tmp) / f"c{k}.csv")))
        results = {}
        for mode in args.modes.split(","):
            cpu, obj = _diagnose(files, mode)
            results[mode] = (cpu, obj)
            print(f"{mode:12s} cpu {cpu:7.1f} s  exit {obj['_exit']}  cause {obj['cause']}  "
                  f"baseline {obj['baseline']['nrmse']:.5f}  coupled {obj['coupled']['nrmse']:.5f}  "
                  f"folds {[round(x, 5) for x in _folds(obj)]}", flush=True)
    if len(results) == 2:
        (m1, (c1, o1)), (m2, (c2, o2)) = results.items()
        f1, f2 = _folds(o1), _folds(o2)
        diff = max((abs(a - b) / max(abs(b), 1e-12) for a, b in zip(f1, f2)), default=0.0)
        same = o1["cause"] == o2["cause"] and len(f1) == len(f2) and diff <= 0.02
        print(f"cpu {m1} / {m2}: {c1 / c2:.2f}  largest fold-nrmse difference {diff:.2%}  "
              f"{'same verdict and folds' if same else 'DIFFERENT'}")
        return 0 if same else 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main_())
