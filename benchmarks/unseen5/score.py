#!/usr/bin/env python3
"""Score the station on the fifth blind scorecard (data from ``generate.py``).

Runs the ``station`` command line (subprocesses in the data folder, a time limit per command judged
on its CPU time from wait4, a wall-clock kill at --wall-factor times the limit) on every case of
``DATA/manifest.json``; the station never sees the manifest.

(a) nulls     ``diagnose`` on 6 captures (two DAQ sessions) of systems inside the default
              libraries -> ``none``.
(b) effects   ``diagnose`` on 4 captures with a hidden effect -> its catalogue name, or
              ``unexplained`` when it is outside the catalogue; a wrong name is a failure.
(c) ident     ``identify`` with the true library: every true coefficient inside estimate +- ci95
              (or a warning), the model validated on a held-out blow at 65 %.
(d) mdof      ``diagnose TRAIN... --save-model M.json --driving-point CH`` (acc only, no mass),
              ``validate M.json HELD``: per-channel held-out nrmse <= 0.05, modal frequencies within
              3 %, each command within its time limit.
(e) robust    bad inputs: exit 2, one stderr line, no traceback, protected files unchanged.

    python benchmarks/unseen5/score.py --data /tmp/unseen5 --quick --jobs 2 --md-out card.md
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

import judge  # noqa: E402
import table  # noqa: E402

KIND = {judge.score_mdof: "mdof", judge.score_diag: "diagnose", judge.score_ident: "ident",
        judge.score_robust: "robust"}


def _tasks(man):
    # the long ones first, so that --jobs keeps both cores busy to the end
    return ([(judge.score_mdof, c) for c in man["mdof"]] + [(judge.score_diag, c) for c in man["diagnose"]]
            + [(judge.score_ident, c) for c in man["ident"]] + [(judge.score_robust, c) for c in man["robust"]])


def _matches(task, keys):
    cid = ("bad-" if task[0] is judge.score_robust else "") + task[1]["id"]
    return any(cid.startswith(k) for k in keys)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", help="folder written by generate.py (required unless --render)")
    p.add_argument("--quick", action="store_true", help="the quick scoring; needs data made with --quick")
    p.add_argument("--jobs", type=int, default=2, help="cases scored at once (default 2)")
    p.add_argument("--station-cmd", default="station", help="the station command (default: station on PATH)")
    p.add_argument("--timeout-scale", type=float, default=1.0, help="multiply every command's time limit")
    p.add_argument("--wall-factor", type=float, default=3.0,
                   help="kill a command after this many times its limit in wall time (default 3; the limit "
                        "itself is judged on CPU time)")
    p.add_argument("--only", default="", help="comma-separated case ids (or prefixes; bad inputs: bad-...)")
    p.add_argument("--json-out", default=None, help="results JSON (default DATA/scorecard.json)")
    p.add_argument("--md-out", default=None, help="also write the Markdown scorecard here")
    p.add_argument("--render", default=None, nargs="+", metavar="SCORECARD.json",
                   help="only re-render the Markdown card of an earlier run's JSON (no station run); with "
                        "several, a later file's cases replace the earlier ones' (a partial re-run, --only)")
    a = p.parse_args(argv)
    if a.render:
        saved, merged = None, {}
        for path in a.render:
            with open(path) as fh:
                part = json.load(fh)
            saved = saved or part
            merged.update({r["id"]: r for r in part["results"]})
            if part is not saved:
                saved["meta"].setdefault("merged", []).append(
                    f"{path}: {', '.join(r['id'] for r in part['results'])} ({part['meta']['date_utc']}, "
                    f"load {part['meta']['load'][0]:.1f}, {part['meta']['git']})")
        md = table.scorecard(list(merged.values()), saved["meta"])
        print(md)
        if a.md_out:
            with open(a.md_out, "w") as fh:
                fh.write(md)
        return 0
    if not a.data:
        p.error("--data is required (unless --render)")
    try:
        with open(os.path.join(a.data, "manifest.json")) as fh:
            man = json.load(fh)
    except (OSError, ValueError) as e:
        print(f"score.py: {a.data}: no readable manifest.json ({e}); run generate.py first", file=sys.stderr)
        return 2
    if a.quick != bool(man.get("quick")):
        print(f"score.py: --quick {'given' if a.quick else 'missing'} but the data was generated "
              f"{'without' if a.quick else 'with'} --quick", file=sys.stderr)
        return 2
    data = os.path.abspath(a.data)
    run = judge.Runner(a.station_cmd, data, a.timeout_scale, a.wall_factor)
    judge.DIAG_TIMEOUT = 300 if a.quick else 600
    tasks = _tasks(man)
    if a.only:
        tasks = [t for t in tasks if _matches(t, a.only.split(","))]
    t0 = time.time()
    cpu0 = os.times()
    if any(t[0] is judge.score_robust and t[1].get("needs_h5") for t in tasks):
        rec = judge.setup_h5(run, f"{man['ident'][0]['truth']['mass']:.6g}")
        print(f"[{time.time() - t0:5.0f} s] setup: {rec['cmd']} -> exit {rec['rc']}", file=sys.stderr)

    def one(task):
        fn, case = task
        try:
            out = judge.slow(fn(case, run))
        except Exception as e:  # a scorer bug must not hide the other cases
            out = {"id": case["id"], "kind": KIND[fn], "verdict": "SCORER-ERROR",
                   "error": f"{type(e).__name__}: {e}", "commands": []}
        print(f"[{time.time() - t0:5.0f} s] {out['id']}: {out['verdict']}", file=sys.stderr, flush=True)
        return out

    with ThreadPoolExecutor(max_workers=a.jobs) as pool:
        results = list(pool.map(one, tasks))
    order = {"diagnose": 0, "ident": 1, "mdof": 2, "robust": 3}
    results.sort(key=lambda r: order.get(r["kind"], 9))
    cpu1 = os.times()
    meta = {"data": data, "seed": man["seed"], "quick": man["quick"], "wall_s": round(time.time() - t0),
            "cpu_children_s": round(cpu1.children_user + cpu1.children_system
                                    - cpu0.children_user - cpu0.children_system, 1),
            "jobs": a.jobs, "wall_factor": a.wall_factor, "timeout_scale": a.timeout_scale, "date_utc": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
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
    """The commit of the checkout whose station runs: the first PYTHONPATH entry, else where the
    `station` package imports from in this environment (an editable install's checkout)."""
    root = (os.environ.get("PYTHONPATH") or "").split(os.pathsep)[0]
    try:
        if not root:
            root = subprocess.run([sys.executable, "-c", "import os, station; print(os.path.dirname("
                                   "os.path.dirname(os.path.abspath(station.__file__))))"],
                                  capture_output=True, text=True, timeout=60, cwd="/").stdout.strip() or "."
        head = subprocess.run(["git", "-C", root, "log", "-1", "--format=%h %cI %s"], capture_output=True,
                              text=True, timeout=10).stdout.strip()
        return f"{root}: {head}"
    except (OSError, subprocess.SubprocessError):
        return ""


if __name__ == "__main__":
    sys.exit(main())
