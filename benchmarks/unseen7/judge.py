"""Run the station on one case and judge what it says (README.md, "The judgement").

The ``Runner`` (a subprocess per command in the data folder, CPU time from wait4, a wall-clock kill)
is unseen5's, kept as it is so that the cards time commands the same way; the scorers are unseen6's with
the seventh set's additions (setup commands, word-matched warnings and refusals, per-record campaign truth
and its trend, tolerant bad inputs).
"""

from __future__ import annotations

import csv
import hashlib
import json
import os
import re
import shlex
import signal
import subprocess
import threading
import time

import numpy as np

CASE_WALL = 300  # s of wall time per case command (the brief's per-case timeout), x --timeout-scale
NONE_FLOOR = 0.15  # baseline held-out nrmse above which `none` on a hidden effect is a failure
HELD_MAX = 0.10  # identification: held-out nrmse on another blow (or 2x what the record's noise alone gives)
CI_SLACK = 1.5  # one record's 2-4 coefficients: outside 1.5 x ci95 (~2.9 sigma) fails; the 95 % coverage is
# pooled over the card (a calibrated station misses one of 3 plain 95 % intervals in 14 % of records)
BINOM_P = 0.01  # a campaign fails its ci95 when so many misses are that unlikely at 95 % coverage
MDOF_MAX = 0.05  # multi-DOF: held-out nrmse per channel
CATALOGUE = {"coulomb_friction", "quadratic_damping", "cubic_damping", "clearance", "smooth_stiffening",
             "asymmetric_stiffness", "second_mode", "hysteresis", "amplitude_damping", "sensor_highpass"}


class Runner:
    """Runs ``station ...`` in the data folder: exit code, wall and CPU time (the process and the
    workers it waited for, from wait4), stdout kept in ``out/``. A command still running after
    ``timeout * scale`` seconds of wall time is killed (``rc`` is ``"timeout"``)."""

    def __init__(self, station_cmd, data, timeout_scale=1.0, wall_factor=3.0):
        self.cmd = shlex.split(station_cmd)
        self.data = data
        self.scale = timeout_scale
        self.wall_factor = wall_factor
        self.lock = threading.Lock()
        self.count = 0

    def __call__(self, argv, timeout=300):
        argv = [str(a) for a in argv]
        t0 = time.time()
        p = subprocess.Popen(self.cmd + argv, cwd=self.data, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             stdin=subprocess.DEVNULL, start_new_session=True)
        bufs = {}

        def read(key, fh):
            bufs[key] = fh.read().decode(errors="replace")

        readers = [threading.Thread(target=read, args=(k, f)) for k, f in (("out", p.stdout), ("err", p.stderr))]
        for th in readers:
            th.start()
        killed = []

        def kill():
            killed.append(True)
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except OSError:
                pass

        timer = threading.Timer(timeout * self.scale, kill)
        timer.start()
        _, status, ru = os.wait4(p.pid, 0)
        timer.cancel()
        p.returncode = os.waitstatus_to_exitcode(status)
        if killed:  # forked workers may hold the pipes open
            kill()
        for th in readers:
            th.join(30)
        out, err = bufs.get("out", ""), bufs.get("err", "")
        rc = "timeout" if killed else p.returncode
        rec = {"cmd": "station " + " ".join(shlex.quote(a) for a in argv), "rc": rc,
               "wall_s": round(time.time() - t0, 1), "cpu_s": round(ru.ru_utime + ru.ru_stime, 1),
               "limit_wall_s": timeout * self.scale, "stderr_tail": err.strip().splitlines()[-3:]}
        with self.lock:
            self.count += 1
            rec["stdout_file"] = os.path.join("out", f"{self.count:03d}-{argv[0]}.txt")
        os.makedirs(os.path.join(self.data, "out"), exist_ok=True)
        with open(os.path.join(self.data, rec["stdout_file"]), "w") as fh:
            fh.write(rec["cmd"] + "\n" + out + "\n--- stderr ---\n" + err)
        return rec, out, err




def parse_json(out):
    try:
        return json.loads(out[out.index("{"):out.rindex("}") + 1])
    except ValueError:
        return None


def named(text, patterns):
    """Whether ``text`` (lower-cased) matches one of the regular expressions (a refusal or warning that
    names the case's defect). File names are taken out first: the case ids in them must not count."""
    text = re.sub(r"\S+\.(csv|tsv|txt|uff|unv|mat|h5|hdf5|json)\b(:\d+)?", " ", text.lower())
    return any(re.search(p, text) for p in patterns or [])


def _failed(rec, err, case=None):
    """The verdict of a command that gave no result. A refusal in one line (exit 2) that matches one of
    the case's ``refusal_ok`` patterns (the defect detected and named) is an honest answer."""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    words = (case or {}).get("refusal_ok") or []
    words = [words] if isinstance(words, str) else words
    if (rec["rc"] == 2 and len(lines) == 1 and named(lines[0], words)
            and "Traceback" not in err):
        return "refused-detected"
    if rec["rc"] == "timeout":
        return "TIMEOUT"
    if "Traceback (most recent call last)" in err:
        return "CRASH"
    return "REFUSED" if rec["rc"] == 2 else f"EXIT-{rec['rc']}"


def _contract(d):
    """Keys issue 10 promises in `station diagnose --json` that are missing."""
    miss = [k for k in ("cause", "noise_floor", "candidates", "symptoms", "baseline", "extended") if k not in d]
    if not isinstance(d.get("baseline"), dict) or "nrmse" not in d["baseline"]:
        miss.append("baseline.nrmse")
    return miss


def _floor(d):
    f = d.get("noise_floor")
    return f.get("nrmse") if isinstance(f, dict) else f


# ----------------------------------------------------------------------------- diagnosis (nulls, effects)
def _lines(err):
    return [ln for ln in err.splitlines() if ln.strip()][-3:]


def score_diag(case, run):
    res = {"id": case["id"], "kind": "diagnose", "commands": []}
    for path in case.get("cleanup", []):  # a second scoring of the same data starts afresh
        if os.path.exists(os.path.join(run.data, path)):
            os.remove(os.path.join(run.data, path))
    for argv in case.get("setup", []):
        rec, out, err = run(argv, CASE_WALL)
        res["commands"].append(rec)
        if rec["rc"] != 0:
            res["verdict"] = "SETUP-" + _failed(rec, err)
            res["stderr"] = _lines(err)
            return res
    mass = ["--mass", repr(case["given_mass"])] if case.get("given_mass") is not None else []
    rec, out, err = run(["diagnose", *case["files"], *mass, "--json"], CASE_WALL)
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] in (0, 1) else None
    if d is None:
        res["verdict"] = _failed(rec, err, case)
        res["stderr"] = _lines(err)
        return res
    cause = d.get("cause")
    base = (d.get("baseline") or {}).get("nrmse")
    judged = (d.get("judged_baseline") or {}).get("nrmse")
    floor = _floor(d)
    res.update(cause=cause, baseline_nrmse=base, noise_floor=floor, exit=rec["rc"],
               extended_nrmse=(d.get("extended") or {}).get("nrmse"),
               candidates=[(c.get("name"), c.get("nrmse")) for c in d.get("candidates") or []
                           if isinstance(c, dict)][:3])
    if case["hidden"] is None:
        v = ("correct" if cause == "none" else
             "FALSE-ALARM-UNEXPLAINED" if cause == "unexplained" else "FALSE-ALARM-NAMED")
        if v == "correct" and rec["rc"] == 1:
            v = "FLAGGED-ON-NULL"
    else:
        expect = case["expect"]
        if cause in expect:
            v = "correct"
        elif cause == "unexplained":
            v = "abstained"  # only reached for catalogued effects
        elif cause == "none":
            held = judged if judged is not None else (base or 0)
            far = held > NONE_FLOOR or (floor and held > 5 * floor)
            v = "NONE-ABOVE-FLOOR" if far else "none-weak"
        else:
            v = "WRONG-NAMED"
    miss = _contract(d)
    if miss:
        v += "+CONTRACT(" + ",".join(miss) + ")"
    res["verdict"] = v
    return res


# ----------------------------------------------------------------------------- identification
def binom_sf(k, n, p):
    """P(X > k) for X ~ Binomial(n, p)."""
    from math import comb
    return 1.0 - sum(comb(n, i) * p ** i * (1 - p) ** (n - i) for i in range(k + 1))


def judge_coefs(d, truth, slack=1.0):
    """Relative errors, ci95 coverage (list of bool: the true value inside estimate +- ci95) and what is
    outside ``slack`` x ci95, for a result with ci95."""
    errs, cover, outside, missing = {}, [], [], False
    for group in ("damping", "stiffness"):
        for term, true in truth[group].items():
            est = (d.get(group) or {}).get(term)
            ci = ((d.get("ci95") or {}).get(group) or {}).get(term)
            missing |= ci is None
            e = (est - true) / abs(true) if est is not None else float("nan")
            errs[term] = e
            ok = ci is not None and est is not None and abs(est - true) <= float(ci)
            cover.append(bool(ok))
            if not (ci is not None and est is not None and abs(est - true) <= slack * float(ci)):
                z = abs(est - true) / float(ci) if ci and est is not None else float("inf")
                outside.append(f"{term} {100 * e:+.2f} % ({z:.1f} x ci95)")
    return errs, cover, outside, missing


def score_ident(case, run):
    tr, f = case["truth"], case["files"]
    res = {"id": case["id"], "kind": "ident", "commands": []}
    argv = ["identify", f["fit"], "--mass", repr(tr["mass"]), "--damping", ",".join(tr["damping"]),
            "--stiffness", ",".join(tr["stiffness"]), "--json"]
    rec, out, err = run(argv, CASE_WALL)
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] in (0, 1) else None
    if d is None:
        res["verdict"] = _failed(rec, err, case)
        res["stderr"] = _lines(err)
        return res
    if rec["rc"] == 1:
        flagged = d.get("unstable") or (d.get("validation") or {}).get("diverged")
        res["verdict"] = "flagged-unstable" if flagged else "EXIT-1-UNFLAGGED"
        return res
    errs, cover, outside, missing = judge_coefs(d, tr, CI_SLACK)
    model_path = f"score-{case.get('label', case['id'])}-model.json"
    with open(os.path.join(run.data, model_path), "w") as fh:
        json.dump(d["model"], fh)
    rec, out, err = run(["validate", model_path, f["held"], "--json"], CASE_WALL)
    res["commands"].append(rec)
    v = parse_json(out) if rec["rc"] in (0, 1) else None
    held = float(v["nrmse"]) if v and v.get("nrmse") is not None else float("inf")
    warns = (list(d.get("warnings") or []) + list((d.get("validation") or {}).get("warnings") or [])
             + list((v or {}).get("warnings") or []))
    held_max = max(HELD_MAX, 2 * (case["meta"]["captures"][1]["session"].get("noise_nrmse") or 0.0))
    words = case.get("warn_words")
    warned_any = bool(warns or (d.get("validation") or {}).get("diverged") or (v or {}).get("diverged"))
    # a chain or file defect: the warning must name it (one of the case's patterns); a generic one ("poor
    # fit ... or a measurement problem") is WARNED-UNNAMED, a failure reported apart from the silent ones
    warned = any(named(str(w), words) for w in warns) if words else warned_any
    res.update(coef_err=errs, covered=cover, outside=outside, held_nrmse=held, warned=warned,
               warnings=[str(w)[:160] for w in warns][:4])
    bad = outside + ([f"held-out nrmse {held:.3g}"] if held > held_max else [])
    res["held_max"] = held_max
    if missing:
        res["verdict"] = "CONTRACT(ci95)"
    elif not bad:
        res["verdict"] = "ok"
    elif warned:
        res["verdict"] = "warned"
    elif warned_any:
        res["verdict"] = "WARNED-UNNAMED"
    else:
        res["verdict"] = "OUTSIDE-CI95-SILENT" if outside else "POOR-SILENT"
    return res


# ----------------------------------------------------------------------------- campaign
def score_campaign(case, run):
    tr = case["truth"]
    res = {"id": case["id"], "kind": "campaign", "commands": []}
    outdir = f"score-{case.get('label', case['id'])}-out"
    if os.path.isdir(os.path.join(run.data, outdir)):
        import shutil
        shutil.rmtree(os.path.join(run.data, outdir))
    argv = ["campaign", case["folder"], "--out", outdir, "--mass", repr(tr["mass"]), "--damping",
            ",".join(tr["damping"]), "--stiffness", ",".join(tr["stiffness"]), "--workers", "1", "--json"]
    rec, out, err = run(argv, CASE_WALL)
    res["commands"].append(rec)
    table = os.path.join(run.data, outdir, "results.csv")
    if rec["rc"] != 0 or not os.path.exists(table):
        res["verdict"] = _failed(rec, err) if rec["rc"] != 0 else "NO-TABLE"
        return res
    with open(table, newline="") as fh:
        rows = list(csv.DictReader(fh))
    by = {}
    for r in rows:  # rows name their file relative to the source or absolute: match on the path's tail
        f = r["file"]
        head, _, tail = f.rpartition(":")
        parts = os.path.normpath(head if head and tail.isdigit() else f).split(os.sep)
        by[os.path.join(*parts[-2:])] = r
        by.setdefault(parts[-1], r)
    flags, cover, nrmses, k1 = [], [], [], []
    truths = case.get("truths") or [tr] * len(case["files"])
    for name, tr in zip(case["files"], truths):
        r = by.get(name) or by.get(os.path.basename(name))
        if r is None or r.get("status") != "ok":
            flags.append(f"ROW({name})")
            continue
        d = {"damping": {}, "stiffness": {}, "ci95": {"damping": {}, "stiffness": {}}}
        for g, p in (("damping", "b"), ("stiffness", "k")):
            for term in tr[g]:
                val, ci = r.get(f"{p}[{term}]"), r.get(f"{p}[{term}]_ci95")
                if val not in (None, ""):
                    d[g][term] = float(val)
                if ci not in (None, ""):
                    d["ci95"][g][term] = float(ci)
        _, cv, _, _ = judge_coefs(d, tr)
        cover += cv
        nrmses.append(float(r.get("nrmse") or "inf"))
        k1.append((d["stiffness"].get("x"), tr["stiffness"]["x"], d["ci95"]["stiffness"].get("x") or 0.0))
    if case.get("truths") and len(k1) == len(truths) and all(e is not None for e, _, _ in k1):
        # the drift across the campaign: no record's estimate may rise above the one before by more than
        # their combined ci95 (the true stiffness only falls), and the total change is measured within
        # 25 % of the true change or the first and last records' combined ci95, whichever is larger
        est = [e for e, _, _ in k1]
        ci = [c for _, _, c in k1]
        true_change = k1[-1][1] / k1[0][1] - 1
        est_change = est[-1] / est[0] - 1
        rises = [i for i in range(len(est) - 1) if est[i + 1] - est[i] > float(np.hypot(ci[i], ci[i + 1]))]
        tol = max(0.25 * abs(true_change), float(np.hypot(ci[0] / est[0], ci[-1] / est[-1])))
        res["trend"] = (f"{100 * est_change:+.2f} % (tolerance {100 * tol:.2f} %"
                        + (f", rises after records {rises})" if rises else ")"))
        res["trend_true"] = true_change
        if rises or abs(est_change - true_change) > tol:
            flags.append("TREND")
    broken = by.get(case["broken"]) or by.get(os.path.basename(case["broken"]))
    if broken is None or broken.get("status") != "error" or "\n" in (broken.get("error") or "\n"):
        flags.append("BROKEN-ROW")
    miss = sum(not c for c in cover)
    if cover and miss and binom_sf(miss - 1, len(cover), 0.05) < BINOM_P:
        flags.append("CI95")
    noise = max([m["captures"][0]["session"].get("noise_nrmse") or 0.0 for m in case.get("meta", [])] or [0.0])
    if nrmses and max(nrmses) > max(HELD_MAX, 2 * noise):
        flags.append("NRMSE")
    res.update(rows=len(rows), covered=cover, nrmse=nrmses, files_in_table=sorted(by)[:20])
    res["verdict"] = "ok" if not flags else "+".join(flags)
    return res


# ----------------------------------------------------------------------------- multi-DOF
def score_mdof(case, run):
    f = case["files"]
    res = {"id": case["id"], "kind": "mdof", "commands": []}
    model_path = f"score-{case.get('label', case['id'])}-model.json"
    if os.path.exists(os.path.join(run.data, model_path)):
        os.remove(os.path.join(run.data, model_path))
    argv = ["diagnose", *f["train"], "--save-model", model_path, "--json", "--driving-point", case["driving_point"]]
    rec, out, err = run(argv, CASE_WALL)
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] in (0, 1) else None
    if d is None or not os.path.exists(os.path.join(run.data, model_path)):
        res["verdict"] = _failed(rec, err) if d is None else "NO-MODEL"
        return res
    res["cause"] = d.get("cause")
    flags = [] if res["cause"] == "modal_coupling" else ["NO-COUPLING"]
    rec, out, err = run(["validate", model_path, f["held"], "--json"], CASE_WALL)
    res["commands"].append(rec)
    v = parse_json(out) if rec["rc"] in (0, 1) else None
    ch = {k: float(x) for k, x in (v or {}).get("channel_nrmse", {}).items()} if v else {}
    res["held_nrmse"] = ch or {"(none)": float("inf")}
    if rec["rc"] == "timeout":
        flags.append("TIMEOUT")
    elif not ch or max(ch.values()) > MDOF_MAX or len(ch) != len(case["columns"]):
        flags.append("NRMSE")
    res["verdict"] = "ok" if not flags else "+".join(flags)
    return res


# ----------------------------------------------------------------------------- bad inputs
def _digest(path):
    try:
        with open(path, "rb") as fh:
            return hashlib.sha256(fh.read()).hexdigest()
    except OSError:
        return None


def score_robust(case, run):
    for argv in case.get("setup", []):
        for path in (argv[argv.index("--out") + 1],) if "--out" in argv else ():
            if os.path.exists(os.path.join(run.data, path)):
                os.remove(os.path.join(run.data, path))
        rec, out, err = run(argv, 120)
        if rec["rc"] != 0:
            return {"id": "bad-" + case["id"], "kind": "robust", "commands": [rec], "stderr": _lines(err),
                    "verdict": "SETUP-" + _failed(rec, err)}
    if case.get("truncate"):
        src, dst, frac = case["truncate"]
        with open(os.path.join(run.data, src), "rb") as fh:
            blob = fh.read()
        with open(os.path.join(run.data, dst), "wb") as fh:
            fh.write(blob[: int(len(blob) * frac)])
    prot = {p: _digest(os.path.join(run.data, p)) for p in case["protect"]}
    rec, out, err = run(case["argv"], 120)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    res = {"id": "bad-" + case["id"], "kind": "robust", "commands": [rec], "stderr": lines[:3]}
    changed = [p for p, h in prot.items() if _digest(os.path.join(run.data, p)) != h]
    if case.get("expect_rc") is not None:  # a good input that must work
        v = ("ok" if rec["rc"] == case["expect_rc"] else "CRASH" if "Traceback" in err else
             f"FAILED-ON-GOOD-INPUT(exit {rec['rc']})")
    elif rec["rc"] == "timeout":
        v = "TIMEOUT"
    elif "Traceback" in err:
        v = "CRASH"
    elif rec["rc"] == 0:
        v = "ok-tolerant" if case.get("tolerant") else "ACCEPTED-BAD-INPUT"
    elif rec["rc"] != 2:
        v = f"EXIT-{rec['rc']}"
    elif len(lines) != 1:
        v = f"STDERR-{len(lines)}-LINES"
    else:
        v = "ok"
    if changed:
        v = "CLOBBERED" if v == "ok" else v + "+CLOBBERED"
    res["verdict"] = v
    return res
