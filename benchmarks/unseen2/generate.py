#!/usr/bin/env python3
"""Generate the second blind scorecard's records (CSV) and its ground truth (manifest.json).

Own physics (``physics.py``: solve_ivp DOP853, rtol 1e-10) and own sensor chain
(``sensors.py``); nothing from ``eddi``, ``station`` or ``simulated_rig`` is imported. The
station never reads the manifest: ``score.py`` does.

    python benchmarks/unseen2/generate.py --out /tmp/unseen2 --seed 1 --quick
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cases  # noqa: E402
import cases_diag  # noqa: E402
import physics  # noqa: E402
import robust  # noqa: E402
import sensors  # noqa: E402


def _free_nrmse(a, b, mask):
    den = float(np.linalg.norm(b[mask])) or 1.0
    return float(np.linalg.norm(a[mask] - b[mask]) / den)


def _write_record(job):
    """Simulate one record, write its CSV; return its truth summary."""
    out, sysd, rec, seed, null_sys = job
    rng = np.random.default_rng(seed)
    cols, truth = sensors.record(sysd, rec["hits"], rec["chain"], rng)
    sensors.write_csv(os.path.join(out, rec["file"]), cols)
    summary = {"file": rec["file"], "noise_rms": truth["noise_rms"], "peak_response": truth["peak"],
               "peak_disp_m": float(np.max(np.abs(truth["x"]))), "rows": int(cols["t"].size)}
    if null_sys is not None:  # how much the hidden physics changes the struck mass's motion
        t_true, _ = sensors.sample_times(rec["chain"])
        x0, *_ = physics.simulate(null_sys, rec["hits"], t_true)
        live = t_true > max(h["t0"] + h["dur"] for h in rec["hits"])
        summary["effect_disp_nrmse"] = _free_nrmse(truth["x"], x0, live)
    return summary


def build(out, seed, quick, jobs):
    rng = np.random.default_rng(seed)
    id_cases = cases.identify_cases(rng, quick)
    dg_cases = cases_diag.diagnose_cases(rng, quick)
    work = []
    for c in id_cases:
        for r in c["records"]:
            work.append((out, c["system"], r, int(rng.integers(2 ** 31)), None))
    physical = {"quadratic_drag", "smooth_friction", "contact_gap", "coupled_mode", "dahl_hysteresis",
                "stiffness_drift", "base_motion"}
    for c in dg_cases:
        for cap in c["captures"]:
            null = c["null_system"] if c["hidden"] in physical else None
            work.append((out, cap["system"], cap, int(rng.integers(2 ** 31)), null))
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        summaries = list(pool.map(_write_record, work))
    by_file = {s["file"]: s for s in summaries}
    for c in id_cases:
        for r in c["records"]:
            r["truth"] = by_file[r["file"]]
    for c in dg_cases:
        eff = []
        for cap in c["captures"]:
            cap["truth"] = by_file[cap["file"]]
            if cap["system"] is c["system"]:
                del cap["system"]  # the case's system; a drifting capture keeps its own
            if "effect_disp_nrmse" in cap["truth"]:
                eff.append(cap["truth"]["effect_disp_nrmse"])
        c["effect_disp_nrmse"] = float(np.median(eff)) if eff else None
    bad = robust.robust_cases(out)
    return {"seed": seed, "quick": quick, "generated_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            "identify": id_cases, "diagnose": dg_cases, "robust": bad}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="folder for the CSV files and manifest.json (created)")
    p.add_argument("--seed", type=int, default=1, help="seed of every random draw (default 1)")
    p.add_argument("--quick", action="store_true", help="the smaller set score.py --quick runs in <= 6 min")
    p.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    a = p.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    t0 = time.time()
    man = build(a.out, a.seed, a.quick, a.jobs)
    with open(os.path.join(a.out, "manifest.json"), "w") as fh:
        json.dump(man, fh, indent=1, default=float)
    n_files = sum(len(c["records"]) for c in man["identify"]) + sum(len(c["captures"]) for c in man["diagnose"])
    print(f"wrote {n_files} records ({len(man['identify'])} identify, {len(man['diagnose'])} diagnose cases) "
          f"and {len(man['robust'])} bad inputs to {a.out} in {time.time() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
