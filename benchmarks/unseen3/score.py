#!/usr/bin/env python3
"""Score the station on the third blind scorecard (data from ``generate.py``).

Runs the ``station`` command line (subprocesses, in the data folder, a timeout per command) on every
case of ``DATA/manifest.json``; the station never sees the manifest.

(a) consistency  the same three blows through ``identify`` (CSV; columns reordered; the HDF5 session
                 made by ``station import``), ``replay``, ``report --json``, ``diagnose`` (its baseline)
                 and ``validate`` of identify's model: one model, one held-out error (rel. 1e-6).
(b) mdof         ``diagnose TRAIN... --save-model M.json`` (CSV ``t,force,acc1,acc2`` or named
                 columns with ``--driving-point``, and the same captures imported into HDF5), then
                 ``validate M.json HELD.csv``: cause, modal frequencies and cubic coupling within 3 %,
                 per-channel held-out nrmse <= 0.05.
(c) quirks       ``identify`` with the true library (coefficients vs truth, ci95) and the default one,
                 each validated on a held-out blow at 70 %.
(d) diagnose     nulls (6 captures, two DAQ sessions) -> ``none``; hidden effects -> the named cause
                 when catalogued, else ``unexplained``.
(e) robust       bad inputs: exit 2, one stderr line, no traceback, protected files unchanged.

    python benchmarks/unseen3/score.py --data /tmp/unseen3 --quick --jobs 2 --md-out card.md
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import scoring  # noqa: E402
import table  # noqa: E402


def _tasks(man, quick):
    tasks = []
    # the long ones first, so that --jobs keeps both cores busy to the end
    tasks += [(scoring.score_mdof, c, {}) for c in man["mdof"]]
    tasks += [(scoring.score_diagnose, c, {}) for c in man["diagnose"]]
    tasks += [(scoring.score_consistency, c, {}) for c in man["consistency"]]
    nulls = [c for c in man["diagnose"] if c["hidden"] is None]
    if nulls and not quick:
        tasks.append((scoring.score_diagnose, nulls[-1], {"via": "h5"}))
    tasks += [(scoring.score_quirk, c, {"default_lib": not quick}) for c in man["quirks"]]
    tasks += [(scoring.score_robust, c, {}) for c in man["robust"]]
    return tasks


def _matches(task, keys):
    cid = task[1]["id"]
    if task[0] is scoring.score_robust:
        cid = "bad-" + cid
    return any(cid.startswith(k) for k in keys)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True, help="folder written by generate.py")
    p.add_argument("--quick", action="store_true",
                   help="the quick scoring (no default-library identify, no HDF5 null); needs data made with --quick")
    p.add_argument("--jobs", type=int, default=2, help="cases scored at once (default 2)")
    p.add_argument("--station-cmd", default="station", help="the station command (default: station on PATH)")
    p.add_argument("--timeout-scale", type=float, default=1.0, help="multiply every command's timeout")
    p.add_argument("--only", default="", help="comma-separated case ids (or prefixes) to run")
    p.add_argument("--json-out", default=None, help="results JSON (default DATA/scorecard.json)")
    p.add_argument("--md-out", default=None, help="also write the Markdown scorecard here")
    a = p.parse_args(argv)
    try:
        with open(os.path.join(a.data, "manifest.json")) as fh:
            man = json.load(fh)
    except (OSError, ValueError) as e:
        print(f"score.py: {a.data}: no readable manifest.json ({e}); run generate.py first", file=sys.stderr)
        return 2
    if a.quick and not man.get("quick"):
        print("score.py: --quick given but the data was generated without --quick", file=sys.stderr)
        return 2
    data = os.path.abspath(a.data)
    run = scoring.Runner(a.station_cmd, data, a.timeout_scale)
    for spec in sorted({c["setup"].split(":", 1)[1] for c in man["robust"] if c.get("setup")}):
        scoring.setup_h5(run, spec)
    tasks = _tasks(man, a.quick)
    if a.only:
        tasks = [t for t in tasks if _matches(t, a.only.split(","))]
    t0 = time.time()

    def one(task):
        fn, case, kw = task
        out = fn(case, run, **kw)
        out = out if isinstance(out, list) else [out]
        for r in out:
            print(f"[{time.time() - t0:5.0f} s] {r['id']}: {r['verdict']}", file=sys.stderr, flush=True)
        return out

    with ThreadPoolExecutor(max_workers=a.jobs) as pool:
        results = [r for rs in pool.map(one, tasks) for r in rs]
    order = {"consistency": 0, "mdof": 1, "quirk": 2, "diagnose": 3, "robust": 4}
    results.sort(key=lambda r: order.get(r["kind"], 9))
    meta = {"data": data, "seed": man["seed"], "quick": man["quick"], "wall_s": round(time.time() - t0),
            "jobs": a.jobs, "date_utc": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            "load": os.getloadavg(), "station": a.station_cmd, "git": _git(),
            "pythonpath": os.environ.get("PYTHONPATH", "")}
    md = table.scorecard(results, meta)
    print(md)
    with open(a.json_out or os.path.join(data, "scorecard.json"), "w") as fh:
        json.dump({"meta": meta, "results": results}, fh, indent=1, default=str)
    if a.md_out:
        with open(a.md_out, "w") as fh:
            fh.write(md)
    return 0


def _git():
    root = (os.environ.get("PYTHONPATH") or "").split(os.pathsep)[0] or "."
    try:
        return subprocess.run(["git", "-C", root, "log", "-1", "--format=%h %cI %s"], capture_output=True,
                              text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


if __name__ == "__main__":
    sys.exit(main())
