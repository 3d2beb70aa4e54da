#!/usr/bin/env python3
"""Generate the third blind scorecard's records (CSV) and its manifest (the truth, never shown to
the station).

    python benchmarks/unseen3/generate.py --out /tmp/unseen3 --seed 7 --quick

Mechanics: scipy solve_ivp (``physics.py``); sensors and DAQ: ``sensors.py``; cases:
``cases_id.py`` (cross-command consistency, multi-channel, record quirks), ``cases_diag.py``
(diagnosis nulls and hidden effects), ``robust.py`` (bad inputs). Nothing is imported from the
project (eddi, station, simulated_rig). Every draw follows from ``--seed`` and the case's id.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import zlib
from concurrent.futures import ProcessPoolExecutor

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cases_diag  # noqa: E402
import cases_id  # noqa: E402
import robust  # noqa: E402


def _rng(seed, key):
    return np.random.default_rng([seed, zlib.crc32(key.encode())])


def _jobs(quick):
    """(section, function name, args, kwargs) of every case."""
    jobs = [("consistency", "make_consistency", ("cons-duff",),
             dict(m=1.5, f_hz=22.0, zeta=0.008, r3=0.25, fs=5000, peaks=(30.0, 60.0, 110.0), width=1.2e-3))]
    if not quick:
        jobs.append(("consistency", "make_consistency", ("cons-soft",),
                     dict(m=0.25, f_hz=90.0, zeta=0.005, r3=-0.1, rc3=0.6, fs=12800, peaks=(12.0, 25.0, 40.0),
                          width=0.5e-3, snr=40.0)))
    jobs.append(("mdof", "make_chain", ("mdof-chain",), dict(via_h5=True)))
    jobs.append(("mdof", "make_internal13", ("mdof-13",), {}))
    if not quick:
        jobs.append(("mdof", "make_nes", ("mdof-nes",), dict(via_h5=True)))
    for cid, kw in cases_id.quirk_specs(quick):
        jobs.append(("quirks", "make_quirk", (cid,), kw))
    nulls = cases_diag.NULLS[:2] if quick else cases_diag.NULLS
    for spec in nulls:
        jobs.append(("diagnose", "make_null", (spec,), {}))
    hidden = ["make_backlash", "make_thermal", "make_rattle", "make_massload"]
    if not quick:
        hidden += ["make_iepe", "make_drag", "make_friction"]
    jobs += [("diagnose", fn, (), {}) for fn in hidden]
    return jobs


def _run(out, seed, job):
    section, fn, args, kw = job
    key = fn + ":" + (args[0] if args and isinstance(args[0], str) else args[0][0] if args else "")
    module = cases_id if hasattr(cases_id, fn) else cases_diag
    t0 = time.time()
    entry = getattr(module, fn)(out, _rng(seed, key), *args, **kw)
    return section, entry, time.time() - t0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="folder for the records and manifest.json (created)")
    p.add_argument("--seed", type=int, default=7, help="every draw follows from it (default 7)")
    p.add_argument("--quick", action="store_true", help="the smaller set that scores in <= 6 min on 2 cores")
    p.add_argument("--jobs", type=int, default=2, help="processes simulating at once (default 2)")
    a = p.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    t0 = time.time()
    man = {"seed": a.seed, "quick": a.quick, "consistency": [], "mdof": [], "quirks": [], "diagnose": []}
    jobs = _jobs(a.quick)
    with ProcessPoolExecutor(max_workers=a.jobs) as pool:
        futures = [pool.submit(_run, a.out, a.seed, j) for j in jobs]
        for f in futures:
            section, entry, dt = f.result()
            man[section].append(entry)
            print(f"[{time.time() - t0:5.0f} s] {entry['id']} ({dt:.1f} s)", file=sys.stderr, flush=True)
    robust.make_files(a.out, _rng(a.seed, "robust"))
    man["robust"] = robust.cases()
    with open(os.path.join(a.out, "manifest.json"), "w") as fh:
        json.dump(man, fh, indent=1)
    n = sum(len(v) for v in man.values() if isinstance(v, list))
    print(f"{n} cases in {a.out} ({time.time() - t0:.0f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
