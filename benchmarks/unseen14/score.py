#!/usr/bin/env python3
"""Score the station on the fourteenth blind scorecard (data from ``generate.py``).

Runs the ``station`` command line (subprocesses in the data folder; the station never sees the manifest) on
every case of ``DATA/manifest.json``, judges the answers on physics (README.md, "The judgement") and prints one
PASS/FAIL line per case and a Markdown card. Every command's stdout and stderr go to ``DATA/out/NNN-CMD.txt``
(the command on the first line).

    python benchmarks/unseen14/generate.py --out /tmp/unseen14 --seed SEED --quick
    nice -n 5 python benchmarks/unseen14/score.py --data /tmp/unseen14 --quick --jobs 2 --md-out card.md \
        --timeout-scale 4
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import shlex
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor

CPU_LIMIT = {"diagnose": 300, "ident": 300, "mdof": 600, "bad": 120}  # s of CPU per command, x --timeout-scale
NONE_X = 2.0  # `none` on a hidden effect passes only while the judged baseline is within 2x the printed floor
CI_SLACK = 1.5  # a coefficient passes within 1.5 x its own ci95 of the truth
HELD_MAX = 0.10  # identify: held-out nrmse on another blow
MDOF_MAX = 0.06  # multi-channel: per-channel held-out nrmse
READ_TOL = 0.03  # a file that must be read: the linear stiffness within 3 % of the truth
FAMILY = {"diagnose": "diagnose (one DOF, four blows, mass given)", "ident": "identify + validate",
          "mdof": "several accelerometers", "bad": "input handling"}


# ----------------------------------------------------------------------------- running the station
class Runner:
    """``station ...`` in the data folder: exit code, wall and CPU time; killed past its CPU limit (the session's
    processes, read from /proc) or 4x that in wall time; stdout and stderr kept in out/NNN-CMD.txt."""

    def __init__(self, station_cmd, data, scale):
        self.cmd, self.data, self.scale = shlex.split(station_cmd), data, scale
        self.lock, self.count = threading.Lock(), 0

    def __call__(self, argv, limit):
        argv = [str(a) for a in argv]
        t0 = time.time()
        p = subprocess.Popen(self.cmd + argv, cwd=self.data, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             stdin=subprocess.DEVNULL, start_new_session=True)
        bufs, killed, done = {}, [], threading.Event()
        readers = [threading.Thread(target=lambda k=k, f=f: bufs.__setitem__(k, f.read().decode(errors="replace")))
                   for k, f in (("out", p.stdout), ("err", p.stderr))]
        for th in readers:
            th.start()

        def watch():
            while not done.wait(1.0):
                over_cpu = _session_cpu(p.pid) > limit * self.scale
                if over_cpu or time.time() - t0 > 4 * limit * self.scale:
                    killed.append("cpu" if over_cpu else "wall")
                    try:
                        os.killpg(p.pid, signal.SIGKILL)
                    except OSError:
                        pass
                    return

        threading.Thread(target=watch, daemon=True).start()
        _, status, ru = os.wait4(p.pid, 0)
        done.set()
        for th in readers:
            th.join(30)
        out, err = bufs.get("out", ""), bufs.get("err", "")
        rec = {"cmd": "station " + " ".join(shlex.quote(a) for a in argv),
               "rc": "timeout" if killed else os.waitstatus_to_exitcode(status),
               "wall_s": round(time.time() - t0, 1), "cpu_s": round(ru.ru_utime + ru.ru_stime, 1),
               "stderr_tail": err.strip().splitlines()[-2:]}
        with self.lock:
            self.count += 1
            rec["stdout_file"] = os.path.join("out", f"{self.count:03d}-{argv[0]}.txt")
        os.makedirs(os.path.join(self.data, "out"), exist_ok=True)
        with open(os.path.join(self.data, rec["stdout_file"]), "w") as fh:
            fh.write(rec["cmd"] + "\n" + out + "\n--- stderr ---\n" + err)
        return rec, out, err


_TICK = os.sysconf("SC_CLK_TCK")


def _session_cpu(sid):
    total = 0
    for name in os.listdir("/proc"):
        if name.isdigit():
            try:
                with open(f"/proc/{name}/stat") as fh:
                    rest = fh.read().rsplit(")", 1)[1].split()
                if int(rest[3]) == sid:
                    total += sum(int(x) for x in rest[11:15])
            except (OSError, IndexError, ValueError):
                continue
    return total / _TICK


def parse_json(out):
    try:
        return json.loads(out[out.index("{"):out.rindex("}") + 1])
    except ValueError:
        return None


def no_result(rec, err):
    """Why a command gave no JSON result."""
    if rec["rc"] == "timeout":
        return "TIMEOUT"
    if "Traceback (most recent call last)" in err:
        return "CRASH"
    return f"EXIT-{rec['rc']}"


def _floor(d):
    f = d.get("noise_floor")
    return f.get("nrmse") if isinstance(f, dict) else f


# ----------------------------------------------------------------------------- one DOF: the cause
def score_diag(case, run):
    res = {"kind": "diagnose", "commands": []}
    rec, out, err = run(["diagnose", *case["files"], "--mass", repr(case["given_mass"]), *case["args"], "--json"],
                        CPU_LIMIT["diagnose"])
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] in (0, 1) else None
    if d is None:  # a refusal in one line that names the hidden chain fault is a right answer
        lines = [ln for ln in err.splitlines() if ln.strip()]
        named = (rec["rc"] not in (0, 1, "timeout") and len(lines) == 1 and "Traceback" not in err
                 and any(re.search(p, lines[0].lower()) for p in case.get("refusal_ok") or []))
        return {**res, "verdict": "ok" if named else no_result(rec, err), "stderr": lines[:1]}
    cause, floor = d.get("cause"), _floor(d)
    base = (d.get("judged_baseline") or {}).get("nrmse")
    base = base if base is not None else (d.get("baseline") or {}).get("nrmse")
    res.update(cause=cause, exit=rec["rc"], baseline_nrmse=base, noise_floor=floor)
    rule, expect = case["rule"], case["expect"]
    within = floor is not None and base is not None and float(base) <= NONE_X * float(floor)
    if rule == "null":
        v = "ok" if cause == "none" and rec["rc"] == 0 else ("FLAGGED-NULL" if cause == "none" else "NAMED-ON-NULL")
    elif cause in expect:
        v = "ok"
    elif cause == "unexplained":
        v = "ok" if rule in ("hid", "chain", "noisy") else "UNEXPLAINED-ON-KNOWN"
    elif cause == "none":
        v = "ok" if within else "NONE-ABOVE-FLOOR"
    else:
        v = "WRONG-NAME"
    return {**res, "verdict": v}


# ----------------------------------------------------------------------------- identify + validate
def score_ident(case, run):
    tr = case["truth"]
    res = {"kind": "ident", "commands": []}
    rec, out, err = run(["identify", case["files"]["fit"], "--mass", repr(case["given_mass"]), "--damping",
                         ",".join(tr["damping"]), "--stiffness", ",".join(tr["stiffness"]), "--json"],
                        CPU_LIMIT["ident"])
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] == 0 else None
    if d is None:
        return {**res, "verdict": no_result(rec, err) if rec["rc"] != 1 else "FLAGGED"}
    errs, outside = {}, []
    for group in ("damping", "stiffness"):
        for term, true in tr[group].items():
            est = (d.get(group) or {}).get(term)
            ci = ((d.get("ci95") or {}).get(group) or {}).get(term)
            if est is None or ci is None:
                outside.append(f"{term} missing")
                continue
            errs[term] = (est - true) / abs(true)
            if abs(est - true) > CI_SLACK * float(ci) + 1e-12 * abs(true):
                outside.append(f"{term} {100 * errs[term]:+.2f} % ({abs(est - true) / max(float(ci), 1e-300):.1f} "
                               f"x ci95)")
    model = f"score-{case['label']}-model.json"
    with open(os.path.join(run.data, model), "w") as fh:
        json.dump(d.get("model"), fh)
    rec, out, err = run(["validate", model, case["files"]["held"], "--json"], CPU_LIMIT["ident"])
    res["commands"].append(rec)
    v = parse_json(out) if rec["rc"] in (0, 1) else None
    held = float(v["nrmse"]) if v and v.get("nrmse") is not None else float("inf")
    res.update(coef_err=errs, outside=outside, held_nrmse=held)
    bad = outside + ([f"held-out nrmse {held:.3g}"] if held > HELD_MAX else [])
    return {**res, "verdict": "ok" if not bad else "OFF: " + "; ".join(bad)}


# ----------------------------------------------------------------------------- several accelerometers
def _channel_nrmse(v):
    """Per-channel held-out nrmse from `validate --json` of a multi-DOF model (searched, the layout aside)."""
    found = {}

    def walk(o):
        if isinstance(o, dict):
            for k, x in o.items():
                if re.fullmatch(r"acc\d+", str(k)) and isinstance(x, (int, float)):
                    found[k] = max(found.get(k, 0.0), float(x))
                elif re.fullmatch(r"acc\d+", str(k)) and isinstance(x, dict) and "nrmse" in x:
                    found[k] = max(found.get(k, 0.0), float(x["nrmse"]))
                else:
                    walk(x)
        elif isinstance(o, list):
            for x in o:
                walk(x)
    walk(v)
    return found


def score_mdof(case, run):
    res = {"kind": "mdof", "commands": []}
    model = f"score-{case['label']}-model.json"
    rec, out, err = run(["diagnose", *case["files"], "--driving-point", case["driving_point"], "--save-model", model,
                         "--json"], CPU_LIMIT["mdof"])
    res["commands"].append(rec)
    dead = case.get("dead")
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if dead and rec["rc"] not in (0, 1, "timeout") and len(lines) == 1 and "Traceback" not in err:
        ok = re.search(rf"\b{dead}\b", lines[0]) is not None
        return {**res, "verdict": "ok" if ok else "REFUSED-WITHOUT-NAMING-THE-CHANNEL", "said": lines[0][:160]}
    d = parse_json(out) if rec["rc"] in (0, 1) else None
    if d is None:
        return {**res, "verdict": no_result(rec, err)}
    cause = d.get("cause")
    res["cause"] = cause
    if dead:
        text = json.dumps(d.get("warnings") or []) + " " + err
        named = re.search(rf"\b{dead}\b", text) and re.search(r"dead|flat|no signal|silent|noise only|disconnect|"
                                                              r"unplugged|constant|broken|no response", text, re.I)
        return {**res, "verdict": "ok" if named else "DEAD-CHANNEL-UNNOTICED"}
    rec, out, err = run(["validate", model, case["held"], "--json"], CPU_LIMIT["ident"])
    res["commands"].append(rec)
    v = parse_json(out) if rec["rc"] in (0, 1) else None
    ch = _channel_nrmse(v) if v else {}
    res["held_nrmse"] = ch
    fails = []
    if cause != case["expect"]:
        fails.append("CAUSE")
    if not ch or max(ch.values()) > MDOF_MAX:
        fails.append("HELD-NRMSE" if ch else "NO-VALIDATION")
    return {**res, "verdict": "ok" if not fails else "+".join(fails)}


# ----------------------------------------------------------------------------- bad and odd files
def _sha(path):
    try:
        with open(path, "rb") as fh:
            return hashlib.sha256(fh.read()).hexdigest()
    except OSError:
        return None


def score_bad(case, run):
    res = {"kind": "bad", "commands": []}
    path = os.path.join(run.data, case["file"])
    before = _sha(path)
    rec, out, err = run(case["argv"], CPU_LIMIT["bad"])
    res["commands"].append(rec)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    refused = (rec["rc"] not in (0, "timeout") and parse_json(out) is None and len(lines) == 1
               and "Traceback" not in err)
    res["stderr"] = lines[:2]
    if "Traceback (most recent call last)" in err:
        v = "CRASH"
    elif rec["rc"] == "timeout":
        v = "TIMEOUT"
    elif case["rule"] == "must-read":
        k = ((parse_json(out) or {}).get("stiffness") or {}).get("x") if rec["rc"] == 0 else None
        res["read_k1_err"] = None if k is None else (k - case["k1"]) / case["k1"]
        v = ("ok" if abs(k - case["k1"]) <= READ_TOL * case["k1"] else "READ-WRONG") if k is not None else \
            f"NOT-READ-EXIT-{rec['rc']}"
    elif refused:
        v = "ok"
    elif case["rule"] == "read-or-refuse" and rec["rc"] == 0:
        k = ((parse_json(out) or {}).get("stiffness") or {}).get("x")
        ok = k is not None and abs(k - case["k1"]) <= READ_TOL * case["k1"]
        res["read_k1_err"] = None if k is None else (k - case["k1"]) / case["k1"]
        v = "ok" if ok else "READ-WRONG"
    elif case["rule"] == "refuse-or-warn" and rec["rc"] in (0, 1):
        d = parse_json(out) or {}
        text = " ".join(str(w) for w in (d.get("warnings") or []) + ((d.get("validation") or {}).get("warnings")
                                                                      or [])) + " " + err
        ok = any(re.search(p, text.lower()) for p in case.get("words", []))
        v = "ok" if ok and text.strip() else "SILENT"
    elif rec["rc"] in (0, 1):
        v = "ACCEPTED"
    else:
        v = f"EXIT-{rec['rc']}-{len(lines)}-LINES"
    if _sha(path) != before:
        v = "INPUT-CHANGED" if v == "ok" else v + "+INPUT-CHANGED"
    return {**res, "verdict": v}


SCORERS = {"mdof": score_mdof, "diagnose": score_diag, "ident": score_ident, "bad": score_bad}
CHECKED = {"diagnose": "the cause and the held-out error against the printed floor",
           "ident": "coefficients within 1.5 x ci95, held-out nrmse",
           "mdof": "the cause, per-channel held-out nrmse (or the dead channel named)",
           "bad": "one stderr line, non-zero exit, no traceback (or read right)"}


def answer(r):
    """What the station said, in its own words (never the truth)."""
    if "cause" in r:
        extra = (f", baseline {r['baseline_nrmse']:.3g} / floor {r['noise_floor']:.3g}"
                 if isinstance(r.get("baseline_nrmse"), (int, float)) and isinstance(r.get("noise_floor"),
                                                                                     (int, float)) else "")
        held = (", held-out " + ", ".join(f"{k} {x:.3g}" for k, x in r["held_nrmse"].items())
                if r.get("held_nrmse") else "")
        return f"cause `{r['cause']}`{extra}{held}"
    if "held_nrmse" in r:
        return (", ".join(f"{t} {100 * e:+.2f} %" for t, e in r.get("coef_err", {}).items())
                + f"; held-out nrmse {r['held_nrmse']:.3g}")
    c = r.get("commands") or [{}]
    tail = (r.get("stderr") or c[-1].get("stderr_tail") or [""])
    return f"exit {c[-1].get('rc')}: {(tail[0] if tail else '')[:120]}".replace("|", "/")


def card(results, meta):
    ok = [r for r in results if r["verdict"] == "ok"]
    cpu = sum(c.get("cpu_s") or 0 for r in results for c in r["commands"])
    out = [f"# Blind scorecard unseen14{' (quick)' if meta['quick'] else ''}", "",
           f"seed {meta['seed']}, {meta['date_utc']}; wall {meta['wall_s']} s with --jobs {meta['jobs']}, station "
           f"CPU {cpu:.0f} s, load {', '.join(f'{x:.1f}' for x in meta['load'])} at the end",
           f"station `{meta['station']}`, commit `{meta['git']}`; CPU limits per command x {meta['timeout_scale']}: "
           + ", ".join(f"{k} {v} s" for k, v in CPU_LIMIT.items()), "", "## Totals", ""]
    for kind, name in FAMILY.items():
        rs = [r for r in results if r["kind"] == kind]
        if rs:
            out.append(f"- {name}: {sum(r['verdict'] == 'ok' for r in rs)}/{len(rs)} passed")
    out += [f"- **total: {len(ok)}/{len(results)} passed**", "", "## Cases", "",
            "| case | family | pass | checked | the station's answer | wall / CPU s |", "|---|---|---|---|---|---|"]
    for r in sorted(results, key=lambda r: (r["label"][0], int(r["label"][1:]))):
        w = " + ".join(f"{c['wall_s']}/{c['cpu_s']}" for c in r["commands"])
        out.append(f"| {r['label']} | {r['kind']} | {'PASS' if r['verdict'] == 'ok' else 'FAIL'} | "
                   f"{CHECKED[r['kind']]} | {answer(r)} | {w} |")
    return "\n".join(out) + "\n"


def truth_table(cases, results):
    by = {r["label"]: r for r in results}
    out = ["", "## Truth (hidden: not for the team that tunes the station)", "",
           "| case | id | verdict | truth |", "|---|---|---|---|"]
    for c in cases:
        r = by.get(c["label"])
        if r is None:
            continue
        bits = {k: c.get(k) for k in ("rule", "expect", "hidden", "chain", "driving_point", "dead", "masses",
                                      "freqs_hz", "cubic_n_per_m3", "truth", "layout", "argv") if c.get(k) is not None}
        if c.get("system"):
            s = c["system"]
            bits["system"] = f"m {s['mass']:.4g} kg, fn {s['fn_hz']:.4g} Hz, zeta {s['zeta']:.4f}, fs {s['fs']}"
        out.append(f"| {c['label']} | {c['id']} | {r['verdict']} | {json.dumps(bits, default=str)[:600]} |"
                   .replace("\n", " "))
    return "\n".join(out) + "\n"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True, help="folder written by generate.py")
    p.add_argument("--quick", action="store_true", help="the quick set; the data must be generated with --quick")
    p.add_argument("--jobs", type=int, default=2, help="cases scored at once (default 2)")
    p.add_argument("--station-cmd", default="station", help="the station command (default: station on PATH)")
    p.add_argument("--timeout-scale", type=float, default=1.0, help="multiply every command's CPU limit")
    p.add_argument("--only", default="", help="comma-separated labels (D3,I1,M2,B4)")
    p.add_argument("--json-out", default=None, help="results JSON (default DATA/scorecard.json)")
    p.add_argument("--md-out", default=None, help="also write the Markdown card here")
    p.add_argument("--truth-md", default=None, help="also write the card with each case's hidden truth here "
                   "(keep it away from the team that tunes the station)")
    a = p.parse_args(argv)
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
    run = Runner(a.station_cmd, data, a.timeout_scale)
    order = list(SCORERS)  # the long ones first
    cases = sorted(man["cases"], key=lambda c: order.index(c["kind"]))
    if a.only:
        cases = [c for c in cases if c["label"] in a.only.split(",")]
    t0 = time.time()

    def one(case):
        try:
            r = SCORERS[case["kind"]](case, run)
        except Exception as e:  # a scorer bug must not hide the other cases
            r = {"kind": case["kind"], "verdict": f"SCORER-ERROR {type(e).__name__}: {e}", "commands": []}
        r["label"], r["id"] = case["label"], case["id"]
        print(f"[{time.time() - t0:5.0f} s] {'PASS' if r['verdict'] == 'ok' else 'FAIL'} {r['label']} "
              f"({CHECKED[r['kind']]}): {answer(r)}", file=sys.stderr, flush=True)
        return r

    with ThreadPoolExecutor(max_workers=a.jobs) as pool:
        results = list(pool.map(one, cases))
    meta = {"seed": man["seed"], "quick": man["quick"], "wall_s": round(time.time() - t0), "jobs": a.jobs,
            "timeout_scale": a.timeout_scale, "load": os.getloadavg(), "station": a.station_cmd,
            "date_utc": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "git": _git()}
    md = card(results, meta)
    print(md)
    with open(a.json_out or os.path.join(data, "scorecard.json"), "w") as fh:
        json.dump({"meta": meta, "results": results}, fh, indent=1, default=str)
    if a.md_out:
        with open(a.md_out, "w") as fh:
            fh.write(md)
    if a.truth_md:
        with open(a.truth_md, "w") as fh:
            fh.write(md + truth_table(man["cases"], results))
    return 0


def _git():
    root = (os.environ.get("PYTHONPATH") or "").split(os.pathsep)[0] or "."
    try:
        return subprocess.run(["git", "-C", root, "log", "-1", "--format=%h %s"], capture_output=True, text=True,
                              timeout=10).stdout.strip()[:80]
    except (OSError, subprocess.SubprocessError):
        return ""


if __name__ == "__main__":
    sys.exit(main())
