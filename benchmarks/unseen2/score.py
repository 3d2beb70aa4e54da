#!/usr/bin/env python3
"""Score the station on the second blind scorecard (data from ``generate.py``).

Runs the ``station`` command line as a user from another lab would, on every case of
``DATA/manifest.json`` (the station never sees the manifest), with a timeout per command:

identify   ``station identify TRAIN.csv --mass M --damping TRUE --stiffness TRUE --json``
           (coefficient errors, 95 % intervals against the truth), ``station validate`` of its
           model on a held-out record (another blow, 70 % of the level, another clock); the
           same with the default libraries (held-out nrmse, spurious terms); warnings where
           they must be (a growing model; a poor fit).
diagnose   ``station diagnose CAPTURES... --mass M --json`` with the default libraries; the
           first null is also imported into HDF5 (``station import``, one ``--new-session``
           per DAQ session) and diagnosed from there (``FILE.h5``: every capture).
robust     bad inputs: one line on stderr, exit 2, no traceback.

Verdict classes: see ``judge.py``. Prints a scorecard (Markdown) and writes everything as JSON.

    python benchmarks/unseen2/score.py --data /tmp/unseen2 --quick --jobs 2
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import judge  # noqa: E402
import table  # noqa: E402

TIMEOUT = {"identify": 180, "validate": 120, "diagnose": 600, "import": 120, "robust": 60}


class Runner:
    """Runs ``station`` subcommands in the data folder, recording each command."""

    def __init__(self, station, data, scale):
        self.station = shlex.split(station)
        self.data = data
        self.scale = scale

    def __call__(self, argv, kind):
        cmd = self.station + [str(a) for a in argv]
        t0 = time.time()
        try:
            p = subprocess.run(cmd, cwd=self.data, capture_output=True, text=True,
                               timeout=TIMEOUT[kind] * self.scale, stdin=subprocess.DEVNULL)
            rc, out, err = p.returncode, p.stdout, p.stderr
        except subprocess.TimeoutExpired:
            rc, out, err = None, "", "timeout"
        res = {"cmd": " ".join(shlex.quote(c) for c in ["station"] + cmd[len(self.station):]), "rc": rc,
               "wall_s": round(time.time() - t0, 1), "stderr": err.strip()[-2000:]}
        try:
            res["json"] = json.loads(out) if out.strip() and "--json" in argv else None
        except json.JSONDecodeError:
            res["json"] = None
        return res


def _lib(terms):
    return ",".join(terms)


def _validate(run, model, heldout, case_id, tag):
    path = os.path.join(run.data, f"_model-{case_id}-{tag}.json")
    with open(path, "w") as fh:
        json.dump(model, fh)
    v = run(["validate", os.path.basename(path), heldout, "--json"], "validate")
    nrmse = (v.get("json") or {}).get("nrmse")
    return v, nrmse


def score_identify(case, run):
    train, held = case["records"][0]["file"], case["records"][1]["file"]
    res = {"id": case["id"], "kind": "identify", "mass": case["mass"], "f1_hz": case["f1_hz"],
           "unstable": case.get("unstable", False)}
    lib = case["library"]
    t = run(["identify", train, "--mass", repr(case["mass"]), "--damping", _lib(lib["damping"]),
             "--stiffness", _lib(lib["stiffness"]), "--json"], "identify")
    out = t.get("json")
    res["true_lib"] = {k: t[k] for k in ("cmd", "rc", "wall_s")}
    if t["rc"] != 0 or out is None:
        res["true_lib"]["stderr"] = t["stderr"]
        res["verdict"] = "CRASH" if "Traceback" in t["stderr"] or t["rc"] not in (2,) else "refused"
        return res
    coeffs = judge.coefficient_table(case, out)
    v, nrmse = _validate(run, out["model"], held, case["id"], "true")
    res["true_lib"].update({"coeffs": coeffs, "warnings": out.get("warnings"),
                            "diverged": (out.get("validation") or {}).get("diverged"),
                            "fit_nrmse": (out.get("validation") or {}).get("nrmse"),
                            "heldout_nrmse": nrmse, "validate_rc": v["rc"], "validate_json": v.get("json"),
                            "equation": out.get("equation")})
    res["verdict"] = judge.identify_verdict(case, coeffs, nrmse, out)
    d = run(["identify", train, "--mass", repr(case["mass"]), "--json"], "identify")
    dout = d.get("json")
    res["default_lib"] = {k: d[k] for k in ("cmd", "rc", "wall_s")}
    if d["rc"] == 0 and dout:
        _, dn = _validate(run, dout["model"], held, case["id"], "default")
        res["default_lib"].update({"heldout_nrmse": dn, "warnings": dout.get("warnings"),
                                   "diverged": (dout.get("validation") or {}).get("diverged"),
                                   "terms": {**dout.get("damping", {}), **dout.get("stiffness", {})},
                                   "spurious": judge.spurious(case, dout), "equation": dout.get("equation")})
        poor = dn is None or dn > judge.POOR
        if case.get("unstable"):
            res["default_verdict"] = "flagged" if judge.warned(dout) else "UNSTABLE-SILENT"
        else:
            res["default_verdict"] = ("ok" if not poor else ("poor-warned" if judge.warned(dout) else "POOR-SILENT"))
    else:
        res["default_lib"]["stderr"] = d["stderr"]
        res["default_verdict"] = "CRASH" if "Traceback" in d["stderr"] or d["rc"] != 2 else "refused"
    return res


def score_diagnose(case, run):
    files = [c["file"] for c in case["captures"]]
    r = run(["diagnose", *files, "--mass", repr(case["mass"]), "--json"], "diagnose")
    return _diag_result(case, r, "csv")


def _diag_result(case, r, via):
    out = r.get("json")
    res = {"id": case["id"] + ("" if via == "csv" else "@h5"), "kind": "diagnose", "via": via,
           "hidden": case["hidden"], "strength": case["strength_tag"], "catalogued": case["catalogued"],
           "expect": case["expect"], "mass": case["mass"], "f1_hz": case["f1_hz"], "fs": case["fs"],
           "snr_db": case["snr_db"], "effect_disp_nrmse": case.get("effect_disp_nrmse"),
           "cmd": r["cmd"], "rc": r["rc"], "wall_s": r["wall_s"]}
    res["verdict"] = judge.diagnose_verdict(case, r["rc"], out, r["stderr"])
    res["symptom_needed"] = case.get("symptom")
    res["symptom_found"] = judge.symptom_found(case, out, r["stderr"])
    if out:
        cands = sorted((c for c in out.get("candidates") or [] if c.get("nrmse") is not None),
                       key=lambda c: c["nrmse"])
        res.update({"cause": out.get("cause"), "floor": (out.get("noise_floor") or {}).get("nrmse"),
                    "baseline": (out.get("baseline") or {}).get("nrmse"),
                    "extended": (out.get("extended") or {}).get("nrmse"),
                    "partial": (out.get("partial") or {}).get("name") if isinstance(out.get("partial"), dict)
                    else out.get("partial"),
                    "best": [(c["name"], c["nrmse"], c.get("gain")) for c in cands[:3]],
                    "symptoms": [s.get("kind") for s in out.get("symptoms") or []]})
    else:
        res["stderr"] = r["stderr"]
    return res


def score_h5(case, run):
    h5 = f"_{case['id']}.h5"
    p = os.path.join(run.data, h5)
    if os.path.exists(p):
        os.remove(p)
    for session in sorted({c.get("session", 0) for c in case["captures"]}):
        files = [c["file"] for c in case["captures"] if c.get("session", 0) == session]
        new = ["--new-session"] if session else []
        imp = run(["import", *files, "--out", h5, "--mass", repr(case["mass"]), *new, "--json"], "import")
        if imp["rc"] != 0:
            break
    if imp["rc"] != 0:
        return {"id": case["id"] + "@h5", "kind": "diagnose", "via": "h5", "hidden": None, "cmd": imp["cmd"],
                "rc": imp["rc"], "verdict": "refused" if imp["rc"] == 2 else "CRASH", "stderr": imp["stderr"]}
    r = run(["diagnose", h5, "--json"], "diagnose")
    return _diag_result(case, r, "h5")


def score_robust(case, run):
    r = run(case["argv"], "robust")
    lines = [ln for ln in r["stderr"].splitlines() if ln.strip()]
    ok = r["rc"] == 2 and len(lines) == 1 and "Traceback" not in r["stderr"]
    verdict = "ok" if ok else ("TIMEOUT" if r["rc"] is None else
                               "CRASH" if "Traceback" in r["stderr"] else
                               "ACCEPTED" if r["rc"] == 0 else "BAD-EXIT")
    return {"id": "bad-" + case["id"], "kind": "robust", "cmd": r["cmd"], "rc": r["rc"], "verdict": verdict,
            "stderr_lines": len(lines), "stderr": r["stderr"][-300:]}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True, help="folder written by generate.py")
    p.add_argument("--quick", action="store_true", help="refuse data not generated with --quick (a guard)")
    p.add_argument("--jobs", type=int, default=2, help="commands run at once (default 2)")
    p.add_argument("--station-cmd", default="station", help="the station command (default: station on PATH)")
    p.add_argument("--timeout-scale", type=float, default=1.0, help="multiply every command's timeout")
    p.add_argument("--only", default="", help="comma-separated case ids (or prefixes) to run")
    p.add_argument("--json-out", default=None, help="results JSON (default DATA/scorecard.json)")
    p.add_argument("--md-out", default=None, help="also write the Markdown scorecard here")
    a = p.parse_args(argv)
    with open(os.path.join(a.data, "manifest.json")) as fh:
        man = json.load(fh)
    if a.quick and not man.get("quick"):
        print("score.py: --quick given but the data was generated without --quick", file=sys.stderr)
        return 2
    run = Runner(a.station_cmd, os.path.abspath(a.data), a.timeout_scale)
    tasks = [(score_diagnose, c) for c in man["diagnose"]]
    nulls = [c for c in man["diagnose"] if c["hidden"] is None]
    tasks += [(score_h5, nulls[0])] if nulls else []
    tasks += [(score_identify, c) for c in man["identify"]] + [(score_robust, c) for c in man["robust"]]
    if a.only:
        keys = a.only.split(",")
        tasks = [t for t in tasks if any((t[1].get("id") or "").startswith(k) or ("bad-" + t[1]["id"]).startswith(k)
                                         for k in keys)]
    t0 = time.time()

    def one(task):
        fn, case = task
        r = fn(case, run)
        print(f"[{time.time() - t0:5.0f} s] {r['id']}: {r['verdict']}", file=sys.stderr, flush=True)
        return r

    with ThreadPoolExecutor(max_workers=a.jobs) as pool:
        results = list(pool.map(one, tasks))
    meta = {"data": a.data, "seed": man["seed"], "quick": man["quick"], "wall_s": round(time.time() - t0),
            "date_utc": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "load": os.getloadavg(),
            "station": a.station_cmd, "git": _git(), "pythonpath": os.environ.get("PYTHONPATH", "")}
    md = table.scorecard(results, meta)
    print(md)
    with open(a.json_out or os.path.join(a.data, "scorecard.json"), "w") as fh:
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
