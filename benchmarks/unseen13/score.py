#!/usr/bin/env python3
"""Score the station on the thirteenth blind scorecard (data from ``generate.py``).

Runs the ``station`` command line (subprocesses in the data folder; each command killed after its case's CPU
limit (identify / validate / one-DOF diagnose 300 s, multi-DOF diagnose 600 s, bad inputs 120 s, help 60 s, demo
300 s) x --timeout-scale, or 4x that in wall time) on every case of
``DATA/manifest.json``; the station never sees the manifest. Prints one PASS/FAIL line per case (its neutral
label, what was checked, what the station said) and the totals per family.

    python benchmarks/unseen13/generate.py --out /tmp/unseen13 --seed SEED --quick
    nice -n 5 python benchmarks/unseen13/score.py --data /tmp/unseen13 --quick --jobs 2 --md-out card.md \
        --timeout-scale 3
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

PASS = {"ok", "correct", "abstained", "none-weak", "warned", "flagged-unstable", "refused-detected", "ok-tolerant"}
PASS |= {"ok-read"}
# long ones first
SCORERS = {"mdof": judge.score_mdof, "diagnose": judge.score_diag, "first": judge.score_first,
           "ident": judge.score_ident, "grow": judge.score_grow, "robust": judge.score_robust}
CHECKED = {"diagnose": "diagnose captures --mass: the cause and its claim",
           "ident": "identify + validate: coefficients in ci95, held-out nrmse, warnings",
           "grow": "identify: exit code and flag of the model",
           "consistency": "the same records through identify / diagnose / validate / import + identify / report: "
                          "the same numbers, and the truth in ci95",
           "mdof": "diagnose 3 captures (no mass) + validate: cause, per-channel held-out nrmse",
           "mdofreplay": "import 4 multi-channel CSVs (no mass) + replay: per-channel held-out nrmse",
           "robust": "one stderr line, exit code, inputs untouched (or a documented layout read right)",
           "first": "exit 0 and the promised files"}


def _f(x, fmt="{:.3g}"):
    try:
        return fmt.format(float(x))
    except (TypeError, ValueError):
        return "-"


def key_numbers(r):
    k = r["kind"]
    if k == "diagnose":
        c = ", ".join(f"{n} {_f(x)}" for n, x in r.get("candidates") or [])
        return (f"cause `{r.get('cause', '-')}`, baseline {_f(r.get('baseline_nrmse'))}, floor "
                f"{_f(r.get('noise_floor'))}, extended {_f(r.get('extended_nrmse'))}; {c[:80]}")
    if k in ("ident", "workflow"):
        ce = ", ".join(f"{t} {100 * e:+.2f} %" for t, e in (r.get("coef_err") or {}).items())
        cov = r.get("covered", [])
        if "coef_err" not in r:
            return ((r.get("stderr") or [""])[0][:110]).replace("|", "/")
        return (f"{ce}; ci95 {sum(cov)}/{len(cov)}; held-out nrmse {_f(r.get('held_nrmse'))}"
                + (f"; warning: {(r.get('warnings') or [''])[0][:90]}" if r.get("warnings") else "")).replace("|", "/")
    if k == "consistency":
        if "coef_err" not in r:
            return ((r.get("stderr") or [""])[0][:110]).replace("|", "/")
        ce = ", ".join(f"{t} {100 * e:+.2f} %" for t, e in (r.get("coef_err") or {}).items())
        cov = r.get("covered", [])
        dis = "; ".join(f"{k}: {v[0][:60]}" for k, v in (r.get("disagree") or {}).items())
        return (f"{ce}; ci95 {sum(cov)}/{len(cov)}; held-out nrmse {_f(r.get('held_nrmse'))}"
                + (f"; cause `{r['cause']}`" if "cause" in r else "")
                + (f"; disagree: {dis}" if dis else "; all commands agree")).replace("|", "/")
    if k == "mdofreplay":
        if "held_nrmse" not in r:
            return ((r.get("stderr") or [""])[0][:110]).replace("|", "/")
        ch = ", ".join(f"{c} {_f(v)}" for c, v in (r.get("held_nrmse") or {}).items())
        return f"held-out nrmse {ch}" + (f"; warning: {r['warnings'][0][:80]}" if r.get("warnings") else "")
    if k == "mdof":
        ch = ", ".join(f"{c} {_f(v)}" for c, v in (r.get("held_nrmse") or {}).items())
        return f"cause `{r.get('cause', '-')}`; held-out nrmse {ch}"
    if k == "grow":
        if "exit" not in r:
            return ((r.get("stderr") or [""])[0][:110]).replace("|", "/")
        return (f"exit {r['exit']}, unstable {r.get('unstable')}, b[v] {_f(r.get('b1'))}"
                + (f"; warning: {(r.get('warnings') or [''])[0][:90]}" if r.get("warnings") else "")).replace("|", "/")
    if k == "campaign":
        cov = r.get("covered", [])
        return (f"{r.get('rows', '-')} rows; ci95 {sum(cov)}/{len(cov)}; nrmse "
                f"{', '.join(_f(x) for x in r.get('nrmse', []))}; over the limit {(r.get('rows_over_limit') or ['-'])[0]} "
                f"({(r.get('rows_over_limit') or ['-', '-'])[1]} silent); k1 trend {r.get('trend', '-')}")
    return ((r.get("stderr") or [""])[0][:110]).replace("|", "/")


def category(r):
    """The card shows families only (a null and a hidden effect are both `diagnose`); the truth card names
    the category."""
    return {"diagnose": "diagnose", "ident": "identify", "consistency": "consistency", "mdof": "multi-DOF",
            "mdofreplay": "multi-DOF", "robust": "input handling", "grow": "growth", "first": "first run"}[r["kind"]]


def truth_category(r):
    if r["kind"] == "diagnose":
        return {"null": "(a) null", "cat": "(b) catalogued", "hid": "(c) out-of-catalogue",
                "chain": "(e) chain defect"}[r["id"].split("-")[0]]
    return category(r)


def card(results, meta):
    cpu = sum(c.get("cpu_s") or 0 for r in results for c in r.get("commands", []))
    out = ["# Blind scorecard unseen13" + (" (quick)" if meta["quick"] else ""), "",
           f"seed {meta['seed']}, {meta['date_utc']}, wall {meta['wall_s']} s with --jobs {meta['jobs']}, load "
           f"{', '.join(f'{x:.1f}' for x in meta['load'])} at the end; station CPU {cpu:.0f} s",
           f"station: `{meta['station']}`, commit `{meta['git']}`; CPU limit per command "
           f"{judge.CASE_WALL * meta['timeout_scale']:.0f} s (multi-DOF diagnose "
           f"{judge.MDOF_WALL * meta['timeout_scale']:.0f} s, "
           f"bad inputs {120 * meta['timeout_scale']:.0f} s), wall 4x that", "", "## Totals", ""]
    cats = sorted({category(r) for r in results})
    for c in cats:
        rs = [r for r in results if category(r) == c]
        out.append(f"- {c}: {sum(r['verdict'] in PASS for r in rs)}/{len(rs)} passed")
    cov = [c for r in results if r["kind"] in ("ident", "consistency") for c in r.get("covered", [])]
    out += [f"- **total: {sum(r['verdict'] in PASS for r in results)}/{len(results)} passed**",
            f"- ci95 coverage pooled over the identifications: {sum(cov)}/{len(cov)}"
            + (f" = {sum(cov) / len(cov):.2f} (0.95 promised; not scored)" if cov else ""), "",
            "## Cases", "", "| category | case | pass | checked | verdict | key numbers | wall / CPU s |",
            "|---|---|---|---|---|---|---|"]
    for r in sorted(results, key=lambda r: (category(r), _natural(r["label"]))):
        w = "+".join(f"{c['wall_s']}/{c.get('cpu_s')}" for c in r.get("commands", []))
        # a diagnose case's verdict word (correct / abstained / none-weak ...) would tell a null from a hidden
        # effect: the card shows what the station said; the truth card has the verdict
        shown = _shown(r)
        out.append(f"| {category(r)} | {r['label']} | {'PASS' if r['verdict'] in PASS else 'FAIL'} | "
                   f"{CHECKED[r['kind']]} | {shown} | {key_numbers(r)} | {w} |")
    fails = [r for r in results if r["verdict"] not in PASS]
    out += ["", "## Failing commands", ""] + (["none"] if not fails else [])
    for r in fails:
        for c in r.get("commands", []):
            out.append(f"- {r['label']}: `{c['cmd']}` -> exit {c['rc']}"
                       + (f": {c['stderr_tail'][-1][:200]}" if c.get("stderr_tail") else ""))
    return "\n".join(out) + "\n"


def truth_table(man, results):
    """The hidden truth per case (mechanism, expected answers, system and chain) beside its verdict."""
    verdict = {r["id"]: r["verdict"] for r in results}
    cat = {r["id"]: truth_category(r) for r in results}
    out = ["", "## Truth (hidden: not for the team that tunes the station)", "",
           "| label | case | category | verdict | truth |", "|---|---|---|---|---|"]
    for kind in ("diagnose", "ident", "grow", "mdof", "robust", "first"):
        for c in man.get(kind, []):
            cid = ("bad-" if kind == "robust" else "") + c["id"]
            sysd = c.get("system") or {}
            bits = []
            if kind == "diagnose":
                bits.append(f"hidden {c.get('hidden')}, expect {c.get('expect')}")
            if kind in ("ident", "consistency"):
                bits.append(f"defect {c.get('defect')}; truth {c['truth']['damping']} {c['truth']['stiffness']}")
            if kind == "campaign":
                bits.append(f"k1 per record {[round(k, 6) for k in c.get('k1', [])]}")
            if kind in ("mdof", "mdofreplay"):
                bits.append(f"coupling {c.get('coupling')}, gyro {c.get('gyro')}, effect {c.get('coupling_effect_nrmse')}")
                bits.append(f"masses {c['masses']}, freqs {[round(f, 3) for f in c['freqs_hz']]} Hz, driving "
                            f"{c['driving_point']}, fs {c['fs']}")
            if kind in ("robust", "first"):
                bits.append(" ".join(c["argv"]))
            if sysd:
                bits.append(f"{sysd.get('scale')} m {sysd.get('mass'):.4g} kg, fn {sysd.get('fn_hz'):.4g} Hz, zeta "
                            f"{sysd.get('zeta', 0):.4f}, laws {json.dumps(sysd.get('laws'), default=str)[:300]}")
            meta = c.get("meta")
            if isinstance(meta, dict):
                s0 = meta["captures"][0]["session"]
                bits.append(f"fs {meta['fs']}, fmt {meta['fmt']}, sensor {meta['sensor']}, chain "
                            f"{ {k: v for k, v in s0.items() if k not in ('names',)} }")
            for key in ("masses", "chain"):
                if key in c and kind == "diagnose":
                    bits.append(f"{key} {c[key]}")
            out.append(f"| {c.get('label', cid)} | {cid} | {cat.get(cid, '-')} | {verdict.get(cid, '-')} | "
                       f"{'; '.join(bits)} |".replace("\n", " "))
    return "\n".join(out) + "\n"


def _shown(r):
    """What the card may show of a verdict: nothing for diagnose (the word would tell a null from an effect),
    for multi-DOF which check failed (cause or held-out nrmse), the verdict for the others."""
    v = r["verdict"]
    if r["kind"] == "diagnose":  # a FAIL shows the station's cause (its own words), never the truth
        if "cause" not in r:
            return v
        return "-" if v in PASS else f"cause `{r['cause']}` not accepted" + (" (contract)" if "CONTRACT" in v else "")
    if r["kind"] != "mdof" or v in PASS:
        return v
    if "coupling_verdict" not in r:
        return v  # no result (refused, crashed, timed out)
    cause_ok = r.get("coupling_verdict") in PASS
    nrmse_ok = not any(f in v for f in ("NRMSE", "TIMEOUT"))
    return f"cause {'ok' if cause_ok else 'FAIL'}, nrmse {'ok' if nrmse_ok else 'FAIL'}"


def _natural(label):
    head = label.rstrip("0123456789")
    tail = label[len(head):]
    return (head, int(tail) if tail else 0, label)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", required=True, help="folder written by generate.py")
    p.add_argument("--quick", action="store_true", help="the quick scoring; needs data made with --quick")
    p.add_argument("--jobs", type=int, default=2, help="cases scored at once (default 2)")
    p.add_argument("--station-cmd", default="station", help="the station command (default: station on PATH)")
    p.add_argument("--timeout-scale", type=float, default=1.0, help="multiply every command's wall limit")
    p.add_argument("--only", default="", help="comma-separated labels (D1, I3, ...) or case id prefixes "
                   "(bad inputs: bad-...)")
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
    run = judge.Runner(a.station_cmd, data, a.timeout_scale)
    tasks = [(kind, c) for kind in SCORERS for c in man.get(kind, [])]  # long ones first
    if a.only:
        keys = a.only.split(",")
        tasks = [t for t in tasks if any((("bad-" if t[0] == "robust" else "") + t[1]["id"]).startswith(k)
                                         or t[1].get("label") == k
                                         for k in keys)]
    t0 = time.time()

    def one(task):
        kind, case = task
        try:
            out = SCORERS[kind](case, run)
        except Exception as e:  # a scorer bug must not hide the other cases
            out = {"id": case["id"], "kind": kind, "verdict": "SCORER-ERROR", "error": f"{type(e).__name__}: {e}",
                   "commands": []}
        out["label"] = case.get("label") or out["id"]
        shown = "PASS" if out["verdict"] in PASS else "FAIL"
        print(f"[{time.time() - t0:5.0f} s] {shown} {out['label']} ({CHECKED[kind]}): {_shown(out)}", file=sys.stderr,
              flush=True)
        return out

    with ThreadPoolExecutor(max_workers=a.jobs) as pool:
        results = list(pool.map(one, tasks))
    meta = {"data": data, "seed": man["seed"], "quick": man["quick"], "wall_s": round(time.time() - t0),
            "jobs": a.jobs, "timeout_scale": a.timeout_scale, "load": os.getloadavg(), "station": a.station_cmd,
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
            fh.write(md + truth_table(man, results))
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
