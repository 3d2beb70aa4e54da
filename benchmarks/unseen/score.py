#!/usr/bin/env python3
"""Blind held-out scorecard: run the ``station`` CLI on the cases of ``generate.py``.

For every case of ``DATA/manifest.json`` it runs the command line a user would run, with a
per-command timeout, and judges the output against the ground truth the generator wrote:

identify   ``station identify train.csv --mass M --damping <true terms> --stiffness <true terms>
           --json`` (coefficient errors), the same with the default libraries (spurious terms),
           and ``station validate model.json heldout.csv --json`` for both models (held-out
           nrmse on a record at another impact level whose clock differs by 50-150 ppm).
           A model is *poor* when its held-out (or in-sample) nrmse exceeds 0.1, its simulation
           diverged, or k1 is off by more than 5 %; it should then carry a warning (``warnings`` non-empty
           or ``validation.diverged: true``).
diagnose   ``station diagnose capture-*.csv --mass M --json`` (plus the case's extra flags);
           the cause is compared with the expected one. Classes: ``pass``; ``abstained``
           (``unexplained`` where a catalogued mechanism was hidden: an honest miss);
           ``silent-poor-fit`` (``none`` while the baseline's held-out nrmse exceeds
           POOR_FIT = 0.15: wrong); ``silent-fit-ok`` (``none`` with a baseline within 0.15: the
           effect was absorbed, a miss); ``wrong-name`` (a mechanism that was not hidden: the
           worst); ``false-alarm`` / ``false-alarm-named`` on nulls; ``refused`` (exit 2 with
           one line), ``crash`` (traceback or another exit code), ``timeout``.

The flags each command offers are read from its ``--help`` at run time and recorded; a flag
the case needs but the command lacks is dropped and noted. Writes ``--json-out`` (everything)
and prints the scorecard as Markdown (``--md-out`` too).

Usage::

    python benchmarks/unseen/score.py --data /tmp/unseen-data --station-cmd station --jobs 2 --quick
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import shlex
import statistics
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

POOR_FIT = 0.15  # baseline held-out nrmse above which "none" is a wrong verdict
POOR_MODEL_NRMSE = 0.10  # identify: held-out nrmse above which a warning is expected
POOR_K1 = 5.0  # identify: |k1 error| [%] above which a warning is expected
CONTRACT_KEYS = ("cause", "noise_floor", "baseline.nrmse", "extended.nrmse", "candidates", "symptoms")
CATALOGUE_ALIASES = {"quadratic_drag": "quadratic_damping"}
#: a name that is right for an effect once the catalogue holds it (older manifests lack "also_right")
ALSO_RIGHT = {"x_abs_x": ["smooth_stiffening"], "mode_1to3": ["second_mode"]}


# --------------------------------------------------------------------------------------------
# running commands
# --------------------------------------------------------------------------------------------

def run(argv, timeout, cwd):
    """Run one command; everything a judge needs about it."""
    t0 = time.time()
    try:
        p = subprocess.run(argv, capture_output=True, text=True, timeout=timeout, cwd=cwd,
                           env=_env())
        rc, out, err, to = p.returncode, p.stdout, p.stderr, False
    except subprocess.TimeoutExpired as exc:
        rc, to = None, True
        out = exc.stdout.decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        err = exc.stderr.decode() if isinstance(exc.stderr, bytes) else (exc.stderr or "")
    wall = time.time() - t0
    data = None
    if out.strip():
        try:
            data = json.loads(out)
        except ValueError:
            data = None
    tb = "Traceback (most recent call last)" in err or "Traceback (most recent call last)" in out
    return {
        "cmd": " ".join(shlex.quote(a) for a in argv), "rc": rc, "timeout": to, "wall_s": round(wall, 2),
        "traceback": tb, "stderr_tail": err.strip().splitlines()[-3:] if err.strip() else [],
        "stderr_lines": len(err.strip().splitlines()), "json_ok": data is not None, "json": data,
    }


def _env():
    env = dict(os.environ)
    env.setdefault("PYTHONWARNINGS", "ignore")
    return env


def flags_of(station, sub):
    try:
        p = subprocess.run(station + [sub, "--help"], capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        return set()
    return set(re.findall(r"(--[a-z][a-z0-9-]*)", p.stdout))


def status_of(r):
    if r["timeout"]:
        return "timeout"
    if r["traceback"] or r["rc"] not in (0, 1, 2, 130):
        return "crash"
    if r["rc"] == 0 and not r["json_ok"]:
        return "no-json"
    if r["rc"] != 0:
        return "refused"
    return "ok"


# --------------------------------------------------------------------------------------------
# identify
# --------------------------------------------------------------------------------------------

def basis_value(term, x, v):
    """Magnitude of a library term at displacement x [m] and velocity v [m/s]."""
    expr = term.replace("^", "**").replace("abs", "abs")
    try:
        return abs(eval(expr, {"abs": abs}, {"x": x, "v": v}))  # terms are tiny expressions
    except Exception:
        return float("nan")


def judge_identify(case, data, station, flags, timeouts, workdir, skip_default_validate=False):
    m = case["mass"]
    truth = case["truth"]
    amp = case["params"]["amp_m"]
    w = 2 * math.pi * case["params"]["fn_hz"]
    train, held = (str(data / f) for f in case["files"])
    res = {"id": case["id"], "group": case["group"], "kind": "identify", "commands": [], "notes": []}
    true_lib = ["--damping", ",".join(truth["damping"]), "--stiffness", ",".join(truth["stiffness"])]
    for label, extra in (("true-structure", true_lib), ("default", [])):
        argv = station + ["identify", train, "--mass", repr(m)] + _keep(extra, flags["identify"], res) + ["--json"]
        r = run(argv, timeouts["identify"], workdir)
        r["label"] = f"identify ({label})"
        res["commands"].append(r)
        out = {"status": status_of(r)}
        res[label] = out
        d = r["json"] if r["rc"] == 0 else None
        if not d:
            continue
        est = {**(d.get("damping") or {}), **(d.get("stiffness") or {})}
        true = {**truth["damping"], **truth["stiffness"]}
        errs = {}
        for term, tv in true.items():
            if term in est and est[term] is not None:
                errs[term] = 100.0 * (est[term] - tv) / tv
        out["coef_err_pct"] = errs
        ci = {**((d.get("ci95") or {}).get("damping") or {}), **((d.get("ci95") or {}).get("stiffness") or {})}
        out["ci95_covers"] = {t: bool(abs(est[t] - tv) <= ci[t]) for t, tv in true.items()
                              if t in est and est[t] is not None and ci.get(t) is not None}
        # error as a force at the typical amplitude, relative to the spring force k1 A
        ref = truth["stiffness"]["x"] * amp
        fe = {}
        for term in set(est) | set(true):
            e = est.get(term) or 0.0
            tv = true.get(term, 0.0)
            b = basis_value(term, amp, w * amp)
            fe[term] = 100.0 * abs(e - tv) * b / ref
        out["force_err_pct_of_k1A"] = fe
        out["spurious_pct_of_k1A"] = {t: v for t, v in fe.items() if t not in true}
        val = d.get("validation") or {}
        out["insample_nrmse"] = val.get("nrmse")
        warns = (d.get("warnings") or (d.get("validation") or {}).get("warnings")
                 or (d.get("pipeline") or {}).get("warnings") or [])
        out["warnings"] = warns
        out["diverged"] = bool(val.get("diverged"))
        out["refined"] = _refined(d)
        model = d.get("model")
        if model and (label == "true-structure" or not skip_default_validate):
            mp = Path(workdir) / (case["id"].replace("/", "_") + f"-{label}.json")
            mp.write_text(json.dumps(model))
            rv = run(station + ["validate", str(mp), held, "--json"], timeouts["identify"], workdir)
            rv["label"] = f"validate held-out ({label})"
            res["commands"].append(rv)
            if rv["rc"] == 0 and rv["json"]:
                out["heldout_nrmse"] = rv["json"].get("nrmse")
                recs = rv["json"].get("records") or [{}]
                out["heldout_diverged"] = bool(recs[0].get("diverged"))
            else:
                out["heldout_status"] = status_of(rv)
        out["heldout_skipped"] = bool(model) and label == "default" and skip_default_validate
        out["poor"] = _poor(out)
        out["warned"] = bool(warns) or out["diverged"]
    return res


def _poor(out):
    """Poor model: held-out or in-sample nrmse > 0.1, diverged, or |k1 error| > 5 %."""
    k1e = abs((out.get("coef_err_pct") or {}).get("x", float("nan")))
    hn = out.get("heldout_nrmse")
    ins = out.get("insample_nrmse")
    bad_heldout = (hn is None and not out.get("heldout_skipped")) or (
        hn is not None and (not math.isfinite(hn) or hn > POOR_MODEL_NRMSE))
    return bool(bad_heldout or out.get("diverged") or out.get("heldout_diverged")
                or (ins is not None and ins > POOR_MODEL_NRMSE)
                or (out.get("coef_err_pct") is not None and "x" in out["coef_err_pct"] and not k1e <= POOR_K1))


def _refined(d):
    for key in ("refinement", "refine", "pipeline"):
        if key in d:
            v = d[key]
            return v if isinstance(v, (str, bool, int, float)) else json.dumps(v)[:200]
    return None


def _keep(extra, available, res):
    """Drop flags the command does not offer (and say so)."""
    out = []
    i = 0
    while i < len(extra):
        flag = extra[i]
        takes = i + 1 < len(extra) and not extra[i + 1].startswith("--")
        if flag in available or not available:
            out.extend(extra[i:i + 2] if takes else [flag])
        else:
            res["notes"].append(f"flag {flag} not offered: dropped")
        i += 2 if takes else 1
    return out


# --------------------------------------------------------------------------------------------
# diagnose
# --------------------------------------------------------------------------------------------

def judge_diagnose(case, data, station, flags, timeouts, workdir):
    res = {"id": case["id"], "group": case["group"], "kind": "diagnose", "commands": [], "notes": [],
           "expected": case["expected"], "note": case.get("note", "")}
    files = [str(data / f) for f in case["files"]]
    argv = station + ["diagnose"] + files + ["--mass", repr(case["mass"])]
    argv += _keep(list(case.get("diagnose_args", [])), flags["diagnose"], res) + ["--json"]
    r = run(argv, timeouts["diagnose"], workdir)
    r["label"] = "diagnose"
    res["commands"].append(r)
    st = status_of(r)
    res["status"] = st
    d = r["json"] if r["rc"] == 0 else None
    if not d:
        res["outcome"] = st if st != "ok" else "no-json"
        res["message"] = " | ".join(r["stderr_tail"])
        return res
    cause = d.get("cause")
    res["cause"] = cause
    base = _num((d.get("baseline") or {}).get("nrmse"))
    ext = _num((d.get("extended") or {}).get("nrmse"))
    res["baseline_nrmse"] = base
    res["extended_nrmse"] = ext
    res["noise_floor"] = d.get("noise_floor")
    res["gain"] = d.get("gain")
    res["symptoms"] = d.get("symptoms")
    res["verdict_text"] = (d.get("verdict") or "")[:300]
    res["contract_missing"] = [k for k in CONTRACT_KEYS if _dig(d, k) is None]
    cands = d.get("candidates") or []
    ranked = sorted((c for c in cands if isinstance(c, dict) and c.get("gain") is not None),
                    key=lambda c: -float(c["gain"]))
    res["candidates"] = [(c.get("name"), round(float(c["gain"]), 3)) for c in ranked[:3]]
    res["outcome"] = _outcome(case, cause, base)
    text = res["verdict_text"].lower()
    if base is not None and base > POOR_FIT and "follows" in text:
        res["notes"].append(f"text says 'follows' at baseline nrmse {base:.2f}")
    return res


def _outcome(case, cause, base):
    """The class of a diagnosis verdict (see the module docstring)."""
    effect = case["id"].split("/", 1)[1].split("-b")[0]
    exp = [CATALOGUE_ALIASES.get(e, e) for e in case["expected"] + case.get("also_right", ALSO_RIGHT.get(effect, []))]
    c = CATALOGUE_ALIASES.get(cause, cause)
    if exp == ["none"]:
        outcome = "pass" if c == "none" else ("false-alarm" if c == "unexplained" else "false-alarm-named")
    elif c in exp:
        outcome = "pass"
    elif c == "unexplained":
        outcome = "abstained"
    elif c == "none":
        outcome = "silent-poor-fit" if (base is None or base > POOR_FIT) else "silent-fit-ok"
    else:
        outcome = "wrong-name"
    return outcome


def _num(v):
    """A float from a number or a one-number dict (mean of a list), else None."""
    if isinstance(v, bool) or v is None:
        return None
    if isinstance(v, (int, float)):
        return float(v)
    if isinstance(v, list) and v and all(isinstance(x, (int, float)) for x in v):
        return float(statistics.mean(v))
    if isinstance(v, dict):
        for k in ("nrmse", "mean", "value"):
            if k in v:
                return _num(v[k])
    return None


def _dig(d, key):
    for part in key.split("."):
        if not isinstance(d, dict) or part not in d:
            return None
        d = d[part]
    return d


# --------------------------------------------------------------------------------------------
# scorecard
# --------------------------------------------------------------------------------------------

def _fmt(v, f="{:.3g}"):
    """Format a number; anything else (a dict, a string: contracts change) compactly."""
    if v is None:
        return "-"
    if isinstance(v, dict):
        nums = {k: x for k, x in v.items() if isinstance(x, (int, float)) and not isinstance(x, bool)}
        key = next((k for k in ("nrmse", "value", "floor", "mean") if k in nums), None)
        if key is not None:
            return _fmt(float(nums[key]), f)
        return json.dumps(v, default=str)[:60]
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return str(v)[:60]
    if isinstance(v, float) and not math.isfinite(v):
        return str(v)
    try:
        return f.format(v)
    except (TypeError, ValueError):
        return str(v)


def _med_worst(vals):
    vals = [abs(v) for v in vals if v is not None and math.isfinite(v)]
    if not vals:
        return "-"
    return f"{statistics.median(vals):.3g} / {max(vals):.3g} (n={len(vals)})"


def scorecard(results, meta):
    L = [f"# Blind held-out scorecard ({meta['when']})", "",
         f"station: `{meta['station_cmd']}` at `{meta['cwd']}` (git {meta.get('git', '?')}); data: "
         f"`{meta['data']}` (seed {meta['seed']}, {'quick' if meta['quick'] else 'full'}); jobs {meta['jobs']}; "
         f"wall {meta['wall_s']:.0f} s; load before {meta['load']}.", ""]
    L.append("Flags offered: " + "; ".join(f"`{k}`: {' '.join(sorted(v - {'--help'}))}" for k, v in meta["flags"].items()))
    L.append("")
    ids = [r for r in results if r["kind"] == "identify"]
    dgs = [r for r in results if r["kind"] == "diagnose"]
    if ids:
        L += ["## Identification (coefficient errors in %, median / worst of |error|)", "",
              "| case | group | k1 | k3 | c (v) | x^2*v | v^3 | held-out nrmse (true lib / default) | in-sample (true / default) | spurious max (% k1A) | warned / poor (true ; default) |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in ids:
            t = r.get("true-structure", {})
            dft = r.get("default", {})
            e = t.get("coef_err_pct", {})
            sp = dft.get("spurious_pct_of_k1A") or {}
            spm = max(sp.values()) if sp else (0.0 if dft.get("status") == "ok" else None)
            L.append("| {} | {} | {} | {} | {} | {} | {} | {} / {} | {} | {} | {} |".format(
                r["id"].split("/", 1)[1], r["group"], _fmt(e.get("x"), "{:+.2f}"), _fmt(e.get("x^3"), "{:+.1f}"),
                _fmt(e.get("v"), "{:+.1f}"), _fmt(e.get("x^2*v"), "{:+.0f}"), _fmt(e.get("v^3"), "{:+.0f}"),
                _fmt(t.get("heldout_nrmse")) if t.get("status") == "ok" else t.get("status"),
                _fmt(dft.get("heldout_nrmse")) if dft.get("status") == "ok" else dft.get("status"),
                f'{_fmt(t.get("insample_nrmse"))} / {_fmt(dft.get("insample_nrmse"))}', _fmt(spm),
                f"{_yn(t.get('warned'))}/{_yn(t.get('poor'))} ; {_yn(dft.get('warned'))}/{_yn(dft.get('poor'))}"))
        L.append("")
        groups = sorted({r["group"] for r in ids})
        L += ["| group | k1 | k3 | c | held-out nrmse (true lib) | held-out nrmse (default lib) |", "|---|---|---|---|---|---|"]
        for g in groups + ["ALL"]:
            rs = [r for r in ids if g == "ALL" or r["group"] == g]
            col = lambda term: _med_worst([r.get("true-structure", {}).get("coef_err_pct", {}).get(term) for r in rs])
            L.append(f"| {g} | {col('x')} | {col('x^3')} | {col('v')} | "
                     f"{_med_worst([r.get('true-structure', {}).get('heldout_nrmse') for r in rs])} | "
                     f"{_med_worst([r.get('default', {}).get('heldout_nrmse') for r in rs])} |")
        cov = [v for r in ids if r["group"] != "stress"
               for v in (r.get("true-structure", {}).get("ci95_covers") or {}).values()]
        covs = [v for r in ids if r["group"] == "stress"
                for v in (r.get("true-structure", {}).get("ci95_covers") or {}).values()]
        L += ["", f"ci95 coverage of the true coefficients (true-structure library): {sum(cov)} / {len(cov)} "
              f"on the regular cases, {sum(covs)} / {len(covs)} on the stress cases"
              + (" (no ci95 in the JSON)" if not cov and not covs else "") + "."]
        for r in ids:
            for lab in ("true-structure", "default"):
                o = r.get(lab) or {}
                if o.get("status") == "ok":
                    if lab == "default" and "heldout_nrmse" not in o and "heldout_status" not in o:
                        o["heldout_skipped"] = True
                    o["poor"] = _poor(o)
        poor = [(r["id"], lab) for r in ids for lab in ("true-structure", "default") if r.get(lab, {}).get("poor")]
        silent = [(i, lab) for i, lab in poor if not next(r for r in ids if r["id"] == i)[lab].get("warned")]
        warned_good = [(r["id"], lab) for r in ids for lab in ("true-structure", "default")
                       if r.get(lab, {}).get("warned") and not r.get(lab, {}).get("poor")]
        L += ["", f"Warnings: {len(poor)} poor models (held-out or in-sample nrmse > {POOR_MODEL_NRMSE}, diverged, or |k1| > {POOR_K1} %), "
              f"{len(silent)} of them without any warning: {', '.join(f'{i} ({l})' for i, l in silent) or 'none'}; "
              f"{len(warned_good)} warnings on good models.", ""]
    if dgs:
        L += ["## Diagnosis", "",
              "| set | expected | cause | outcome | baseline nrmse | extended | noise_floor | best candidates (gain) | symptoms | wall s |",
              "|---|---|---|---|---|---|---|---|---|---|"]
        for r in dgs:
            wall = r["commands"][0]["wall_s"] if r["commands"] else None
            L.append("| {} | {} | {} | **{}** | {} | {} | {} | {} | {} | {} |".format(
                r["id"], "/".join(r["expected"]), r.get("cause", "-"), r["outcome"], _fmt(r.get("baseline_nrmse")),
                _fmt(r.get("extended_nrmse")), _fmt(r.get("noise_floor")),
                ", ".join(f"{n} {g:+.2f}" for n, g in r.get("candidates", [])) or r.get("message", "")[:120],
                _symptoms(r.get("symptoms")), _fmt(wall, "{:.0f}")))
        nulls = [r for r in dgs if r["expected"] == ["none"]]
        eff = [r for r in dgs if r["expected"] != ["none"]]
        fa = [r for r in nulls if r["outcome"].startswith("false-alarm")]
        L += ["", f"Nulls: {sum(r['outcome'] == 'pass' for r in nulls)} / {len(nulls)} `none`; false alarms "
              f"{len(fa)} ({sum(r['outcome'] == 'false-alarm-named' for r in nulls)} named); "
              f"refused/crashed {sum(r['outcome'] in ('refused', 'crash', 'timeout', 'no-json') for r in nulls)}.",
              f"Hidden effects: {sum(r['outcome'] == 'pass' for r in eff)} / {len(eff)} right; "
              + ", ".join(f"{k} {sum(r['outcome'] == k for r in eff)}" for k in
                          ("abstained", "silent-fit-ok", "silent-poor-fit", "wrong-name", "refused", "crash", "timeout")) + "."]
        by = {}
        for r in eff:
            by.setdefault(r["id"].split("/", 1)[1].split("-b")[0], []).append(r["outcome"])
        L.append("Per effect (right / sets; outcomes): " + "; ".join(
            f"{k} {v.count('pass')}/{len(v)} ({', '.join(sorted(set(v)))})" for k, v in by.items()) + ".")
        cat = [r for r in eff if r["group"] == "catalogue"]
        ooc = [r for r in eff if r["group"] == "out-of-catalogue"]
        L.append(f"Catalogued: {sum(r['outcome'] == 'pass' for r in cat)} / {len(cat)}; out-of-catalogue "
                 f"(`unexplained` expected): {sum(r['outcome'] == 'pass' for r in ooc)} / {len(ooc)}; "
                 f"confident wrong names: {sum(r['outcome'] in ('wrong-name', 'false-alarm-named') for r in dgs)}.")
        above = []
        for r in dgs:
            fl = _num(r.get("noise_floor"))
            b = r.get("baseline_nrmse")
            if r.get("cause") == "none" and fl and b is not None and b > 2 * fl:
                above.append(f"{r['id']} (baseline {b:.3g} = {b / fl:.1f}x its noise_floor {fl:.3g})")
        L.append("`none` while the baseline is above twice the station's own noise_floor (issue 10: "
                 "`none` only within the floor): " + ("; ".join(above) or "none") + ".")
        miss = sorted({k for r in dgs for k in r.get("contract_missing", [])})
        L.append(f"JSON contract (issue 10) keys missing: {', '.join(miss) or 'none'}.")
        fol = [f"{r['id']}: {n}" for r in dgs for n in r["notes"] if "follows" in n]
        if fol:
            L.append("'follows' above the poor-fit line: " + "; ".join(fol))
        L.append("")
    bad = [(r["id"], c) for r in results for c in r["commands"] if status_of(c) in ("crash", "timeout", "no-json")]
    refused = [(r["id"], c) for r in results for c in r["commands"] if status_of(c) == "refused"]
    codes = {}
    for r in results:
        for c in r["commands"]:
            codes[str(c["rc"])] = codes.get(str(c["rc"]), 0) + 1
    L += ["## Exit codes, refusals, crashes", "", f"Exit codes over {sum(codes.values())} commands: "
          + ", ".join(f"{k}: {v}" for k, v in sorted(codes.items())), ""]
    for i, c in refused:
        L.append(f"- refused ({i}): `{c['cmd']}` -> {' | '.join(c['stderr_tail'])[:300]}")
    for i, c in bad:
        L.append(f"- **{status_of(c)}** ({i}): `{c['cmd']}` -> rc {c['rc']}; {' | '.join(c['stderr_tail'])[:300]}")
    if not bad:
        L.append("No tracebacks, crashes or timeouts.")
    notes = sorted({n for r in results for n in r["notes"] if "flag" in n})
    if notes:
        L += ["", "Flag differences: " + "; ".join(notes)]
    return "\n".join(L) + "\n"


def _symptoms(v):
    """Names of the reported symptoms, short."""
    if not v:
        return "-"
    if isinstance(v, dict):
        return ", ".join(list(v)[:4])[:80]
    if isinstance(v, list):
        names = [x.get("name") or x.get("kind") or x.get("symptom") or json.dumps(x, default=str)[:30]
                 if isinstance(x, dict) else str(x)[:40] for x in v]
        return ", ".join(str(n) for n in names[:4])[:100]
    return str(v)[:80]


def _yn(v):
    return "-" if v is None else ("y" if v else "n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, type=Path, help="directory written by generate.py")
    ap.add_argument("--station-cmd", default="station", help="how to run the CLI (split like a shell)")
    ap.add_argument("--cwd", default=None, help="working directory of the station commands")
    ap.add_argument("--repo", default="/work/main", help="git checkout the station runs from (its HEAD is recorded)")
    ap.add_argument("--jobs", type=int, default=2, help="cases run at once")
    ap.add_argument("--quick", action="store_true",
                    help="only the cases marked quick, and no held-out validation of the default-library model")
    ap.add_argument("--only", default=None, help="regex on case ids")
    ap.add_argument("--timeout-identify", type=float, default=240.0, help="[s] per identify/validate command")
    ap.add_argument("--timeout-diagnose", type=float, default=600.0, help="[s] per diagnose command")
    ap.add_argument("--json-out", type=Path, default=None, help="write every result here")
    ap.add_argument("--md-out", type=Path, default=None, help="write the scorecard (Markdown) here")
    ap.add_argument("--render", type=Path, default=None,
                    help="only print the scorecard of the results in this .jsonl (a run that was cut short)")
    args = ap.parse_args(argv)
    manifest = json.loads((args.data / "manifest.json").read_text())
    if args.render:
        results = [json.loads(line) for line in args.render.read_text().splitlines() if line.strip()]
        order = [c["id"] for c in manifest["cases"]]
        results.sort(key=lambda r: order.index(r["id"]) if r["id"] in order else len(order))
        by_id = {c["id"]: c for c in manifest["cases"]}
        for r in results:
            if r["kind"] == "diagnose" and "cause" in r and r["id"] in by_id:
                r["outcome"] = _outcome(by_id[r["id"]], r["cause"], r.get("baseline_nrmse"))
        meta = {"when": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()) + f" (partial: {len(results)} results of {args.render})",
                "station_cmd": args.station_cmd, "cwd": args.cwd or os.getcwd(), "git": _git(args.repo),
                "data": str(args.data), "seed": manifest.get("seed"), "quick": args.quick, "jobs": args.jobs,
                "wall_s": float("nan"), "load": "?", "flags": {}}
        md = scorecard(results, meta)
        print(md)
        if args.md_out:
            args.md_out.write_text(md)
        return 0
    cases = [c for c in manifest["cases"] if (c.get("quick") or not args.quick)
             and (args.only is None or re.search(args.only, c["id"]))]
    # --quick: the default library's model is judged in-sample and for spurious terms only
    station = shlex.split(args.station_cmd)
    cwd = args.cwd or os.getcwd()
    flags = {s: flags_of(station, s) for s in ("identify", "diagnose", "validate")}
    timeouts = {"identify": args.timeout_identify, "diagnose": args.timeout_diagnose}
    work = str(args.data / "_score-work")  # models written here stay for the repro commands
    os.makedirs(work, exist_ok=True)
    load = open("/proc/loadavg").read().split()[:3] if Path("/proc/loadavg").exists() else "?"
    git0 = _git(args.repo)
    t0 = time.time()
    lock = threading.Lock()
    results = []
    # diagnosis sets first: they are the long ones
    order = sorted(cases, key=lambda c: c["kind"] != "diagnose")

    def one(case):
        try:
            if case["kind"] == "identify":
                r = judge_identify(case, args.data, station, flags, timeouts, cwd if args.cwd else work,
                                   skip_default_validate=args.quick)
            else:
                r = judge_diagnose(case, args.data, station, flags, timeouts, cwd if args.cwd else work)
        except Exception as exc:  # the judge itself must not hide a case
            r = {"id": case["id"], "group": case["group"], "kind": case["kind"], "commands": [],
                 "notes": [f"scorer error: {exc!r}"], "expected": case.get("expected", []),
                 "outcome": "scorer-error"}
        with lock:
            results.append(r)
            if args.json_out:  # incremental: a later failure loses nothing
                with open(str(args.json_out) + "l", "a") as fh:
                    fh.write(json.dumps({k: v for k, v in r.items()}, default=str) + "\n")
            print(f"[{time.time() - t0:6.0f} s] {r['id']}: {r.get('outcome') or _id_summary(r)}", file=sys.stderr, flush=True)
        return r

    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as ex:
        list(ex.map(one, order))
    results.sort(key=lambda r: [c["id"] for c in manifest["cases"]].index(r["id"]))
    git1 = _git(args.repo)
    git = git0 if git0 == git1 else f"{git0} -> {git1} (changed during the run)"
    meta = {"when": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "station_cmd": args.station_cmd,
            "cwd": cwd, "git": git, "data": str(args.data), "seed": manifest.get("seed"), "quick": args.quick,
            "jobs": args.jobs, "wall_s": time.time() - t0, "load": " ".join(load),
            "flags": {k: set(v) for k, v in flags.items()}}
    if args.json_out:
        slim = [{**r, "commands": [{k: v for k, v in c.items() if k != "json"} for c in r["commands"]]}
                for r in results]
        args.json_out.write_text(json.dumps({"meta": {**meta, "flags": {k: sorted(v) for k, v in meta["flags"].items()}},
                                             "results": slim}, indent=1, default=str))
    md = scorecard(results, meta)
    print(md)
    if args.md_out:
        args.md_out.write_text(md)
    return 0


def _git(repo):
    try:
        return subprocess.run(["git", "-C", repo, "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True).stdout.strip() or "?"
    except OSError:
        return "?"


def _id_summary(r):
    t = r.get("true-structure", {})
    return f"k1 {t.get('coef_err_pct', {}).get('x', float('nan')):+.2f} %, held-out {t.get('heldout_nrmse')}"


if __name__ == "__main__":
    sys.exit(main())
