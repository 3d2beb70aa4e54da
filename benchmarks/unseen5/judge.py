"""Run the station on one case and judge what it says (README.md, "The judgement")."""

from __future__ import annotations

import hashlib
import json
import os
import shlex
import signal
import subprocess
import threading
import time

import numpy as np

DIAG_TIMEOUT = 300  # s per single-DOF diagnose (score.py: 600 without --quick)
MDOF_TIMEOUT = 300  # s per multi-DOF command, the time limit judged
NONE_FLOOR = 0.15  # baseline held-out nrmse above which `none` on a hidden effect is a failure
HELD_MAX = 0.10  # identification: held-out nrmse of the model on another blow
CATALOGUE = {"coulomb_friction", "quadratic_damping", "cubic_damping", "clearance", "smooth_stiffening",
             "asymmetric_stiffness", "second_mode", "hysteresis", "amplitude_damping", "sensor_highpass"}


class Runner:
    """Runs ``station ...`` in the data folder: exit code, wall and CPU time (the process and the
    workers it waited for, from wait4), stdout kept in ``out/``.

    The time limit is judged on CPU time (the same on a busy machine as on a quiet one):
    ``over_limit`` when the command used more CPU than ``limit * scale``. The wall clock only kills a
    command that runs past ``limit * scale * wall_factor`` (then ``rc`` is ``"timeout"``)."""

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

        timer = threading.Timer(timeout * self.scale * self.wall_factor, kill)
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
               "limit_cpu_s": timeout * self.scale, "stderr_tail": err.strip().splitlines()[-3:]}
        rec["over_limit"] = rec["cpu_s"] > rec["limit_cpu_s"]
        with self.lock:
            self.count += 1
            rec["stdout_file"] = os.path.join("out", f"{self.count:03d}-{argv[0]}.txt")
        os.makedirs(os.path.join(self.data, "out"), exist_ok=True)
        with open(os.path.join(self.data, rec["stdout_file"]), "w") as fh:
            fh.write(rec["cmd"] + "\n" + out + "\n--- stderr ---\n" + err)
        return rec, out, err


def slow(res):
    """Append SLOW to a verdict when a command used more CPU than its limit (a failure)."""
    if any(c.get("over_limit") for c in res.get("commands", [])) and "TIMEOUT" not in res["verdict"]:
        res["verdict"] = ("" if res["verdict"] in ("ok", "correct") else res["verdict"] + "+") + "SLOW"
    return res


def parse_json(out):
    try:
        return json.loads(out[out.index("{"):out.rindex("}") + 1])
    except ValueError:
        return None


def _failed(rec, err):
    if rec["rc"] == "timeout":
        return "TIMEOUT"
    if "Traceback (most recent call last)" in err:
        return "CRASH"
    return "REFUSED" if rec["rc"] == 2 else f"EXIT-{rec['rc']}"


# ----------------------------------------------------------------------------- (a) diagnosis
def _contract(d):
    """Keys issue 10 promises in `station diagnose --json` that are missing."""
    miss = [k for k in ("cause", "noise_floor", "candidates", "symptoms", "baseline", "extended") if k not in d]
    if "baseline" in d and not isinstance(d["baseline"], dict) or isinstance(d.get("baseline"), dict) \
            and "nrmse" not in d["baseline"]:
        miss.append("baseline.nrmse")
    return miss


def score_diag(case, run):
    res = {"id": case["id"], "kind": "diagnose", "commands": []}
    argv = ["diagnose", *case["files"], "--mass", repr(case["given_mass"]), "--json"]
    rec, out, err = run(argv, DIAG_TIMEOUT)
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] in (0, 1) else None
    if d is None:
        res["verdict"] = _failed(rec, err)
        return res
    cause = d.get("cause")
    base = (d.get("baseline") or {}).get("nrmse")
    judged = (d.get("judged_baseline") or {}).get("nrmse")
    floor = d.get("noise_floor")
    floor_n = floor.get("nrmse") if isinstance(floor, dict) else floor
    syms = sorted({s.get("kind") for s in d.get("symptoms") or [] if isinstance(s, dict)} - {None})
    res.update(cause=cause, baseline_nrmse=base, judged_baseline_nrmse=judged, noise_floor=floor_n,
               extended_nrmse=(d.get("extended") or {}).get("nrmse"), symptoms=syms, exit=rec["rc"],
               verdict_text=str(d.get("verdict", ""))[:300],
               candidates=[(c.get("name"), c.get("nrmse")) for c in d.get("candidates") or []
                           if isinstance(c, dict)][:4])
    miss = _contract(d)
    null = case["hidden"] is None
    if null:
        v = ("correct" if cause == "none" else
             "FALSE-ALARM-UNEXPLAINED" if cause == "unexplained" else "FALSE-ALARM-NAMED")
        if v == "correct" and rec["rc"] == 1:
            v = "FLAGGED-ON-NULL"  # the baseline of a clean, stable system called unstable
    else:
        expect = case["expect"]
        catalogued = expect != ["unexplained"]
        res["catalogued"] = catalogued
        if cause in expect:
            v = "correct"
        elif cause in case.get("near", []):
            v = "near"
        elif cause == "unexplained":
            v = "abstained"  # reached for catalogued effects only
        elif cause == "none":
            held = judged if judged is not None else (base or 0)
            far = held > NONE_FLOOR or (floor_n and held > 5 * floor_n)
            v = "NONE-ABOVE-FLOOR" if far else "none-weak"
        else:
            v = "WRONG-NAMED"
    if miss:
        v += "+CONTRACT(" + ",".join(miss) + ")"
    res["verdict"] = v
    return res


# ----------------------------------------------------------------------------- (b) identification
def _powers(term):
    """(p, q) of a term x^p v^q written like x, x^3, v, v^3, x^2*v."""
    p = q = 0
    for f in term.split("*"):
        base, _, exp = f.partition("^")
        n = int(exp) if exp else 1
        if base == "x":
            p += n
        elif base == "v":
            q += n
    return p, q


def score_ident(case, run):
    tr, f = case["truth"], case["files"]
    res = {"id": case["id"], "kind": "ident", "commands": []}
    argv = ["identify", f["fit"], "--mass", repr(tr["mass"]), "--damping", ",".join(tr["damping"]),
            "--stiffness", ",".join(tr["stiffness"]), "--json"]
    rec, out, err = run(argv, 300)
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] in (0, 1) else None
    if d is None:
        res["verdict"] = _failed(rec, err)
        return res
    if rec["rc"] == 1:
        flagged = d.get("unstable") or (d.get("validation") or {}).get("diverged")
        res["verdict"] = "flagged-unstable" if flagged else "EXIT-1-UNFLAGGED"
        return res
    ppm = max(abs(x) for x in case["ppm"]) + 1.0
    g = float(case.get("fit_gain", 1.0))
    errs, cover, outside, cover_nominal = {}, [], [], []
    missing_ci = False
    for group in ("damping", "stiffness"):
        for term, true in tr[group].items():
            est = (d.get(group) or {}).get(term)
            ci = ((d.get("ci95") or {}).get(group) or {}).get(term)
            if ci is None:
                missing_ci = True
            # what the data imply: an accelerometer gain g scales x and v, so with the mass given the
            # free decay fixes coef * g^(1 - p - q) for the term x^p v^q (x: unchanged, x^3: g^-2)
            p, q = _powers(term)
            eff = true * g ** (1 - p - q)
            e = (est - true) / abs(true) if est is not None else float("nan")
            errs[term] = e
            slack = 3e-6 * ppm * abs(eff)  # the clock's bias on the stamped rate
            inside = ci is not None and est is not None and abs(est - eff) <= float(ci) + slack
            cover.append(bool(inside))
            cover_nominal.append(bool(ci is not None and est is not None
                                      and abs(est - true) <= float(ci) + slack))
            if not inside:
                z = abs(est - eff) / float(ci) if ci else float("inf")
                outside.append(f"{term} {100 * e:+.2f} % ({z:.1f} x ci95 from the gain-scaled truth)"
                               if est is not None else f"{term} missing")
    model_path = f"score-{case['id']}-model.json"
    with open(os.path.join(run.data, model_path), "w") as fh:
        json.dump(d["model"], fh)
    rec, out, err = run(["validate", model_path, f["held"], "--json"], 300)
    res["commands"].append(rec)
    v = parse_json(out) if rec["rc"] in (0, 1) else None
    held = float(v["nrmse"]) if v and v.get("nrmse") is not None else float("inf")
    warns = list(d.get("warnings") or []) + list((d.get("validation") or {}).get("warnings") or [])
    warned = bool(warns or (d.get("validation") or {}).get("diverged") or (v or {}).get("diverged"))
    res.update(coef_err=errs, covered=cover, covered_nominal=cover_nominal, fit_gain=g, outside=outside, held_nrmse=held, warned=warned,
               warnings=[str(w)[:160] for w in warns][:4], fit_nrmse=(d.get("validation") or {}).get("nrmse"))
    bad = list(outside)
    if held > HELD_MAX:
        bad.append(f"held-out nrmse {held:.3g}")
    res["problems"] = bad
    if missing_ci:
        res["verdict"] = "CONTRACT(ci95)"
    elif not bad:
        res["verdict"] = "ok"
    elif warned:
        res["verdict"] = "warned"
    else:
        res["verdict"] = "OUTSIDE-CI95-SILENT" if outside else "POOR-SILENT"
    return res


# ----------------------------------------------------------------------------- (c) multi-DOF
def model_frequencies(model):
    """Natural frequencies [Hz] of a saved multi-DOF model's linear part (mass and x-terms)."""
    mass = np.asarray(model["mass"], float)
    n = mass.shape[0]
    M = np.diag(mass) if mass.ndim == 1 else mass
    K = np.zeros((n, n))
    stiff = model["stiffness"]
    for i in range(n):
        eq = stiff[i] if isinstance(stiff, list) else stiff[str(i)]
        for j in range(n):
            K[i, j] = float(eq.get(f"x{j + 1}", 0.0))
    w2 = np.linalg.eigvals(np.linalg.solve(M, K)).real
    return sorted(np.sqrt(np.abs(w2)) / (2 * np.pi))


def score_mdof(case, run):
    f = case["files"]
    res = {"id": case["id"], "kind": "mdof", "commands": []}
    model_path = f"score-{case['id']}-model.json"
    if os.path.exists(os.path.join(run.data, model_path)):
        os.remove(os.path.join(run.data, model_path))
    argv = ["diagnose", *f["train"], "--save-model", model_path, "--json", "--driving-point", case["driving_point"]]
    rec, out, err = run(argv, MDOF_TIMEOUT)
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] in (0, 1) else None
    if d is None or not os.path.exists(os.path.join(run.data, model_path)):
        res["verdict"] = _failed(rec, err) if d is None else "NO-MODEL"
        return res
    res["cause"] = d.get("cause")
    with open(os.path.join(run.data, model_path)) as fh:
        model = json.load(fh)
    flags = []
    try:
        fm = model_frequencies(model)
        ferr = [min(abs(g - t) / t for g in fm) for t in case["freqs_hz"]]
    except (KeyError, ValueError, TypeError, IndexError, np.linalg.LinAlgError) as e:
        fm, ferr = [], [float("inf")]
        res["freq_error"] = f"{type(e).__name__}: {e}"
    res.update(model_freqs_hz=fm, freq_err=ferr, coordinates=model.get("coordinates"))
    if max(ferr) > 0.03:
        flags.append("FREQ")
    rec, out, err = run(["validate", model_path, f["held"], "--json"], MDOF_TIMEOUT)
    res["commands"].append(rec)
    v = parse_json(out) if rec["rc"] in (0, 1) else None
    ch = {k: float(x) for k, x in (v or {}).get("channel_nrmse", {}).items()} if v else {}
    res["held_nrmse"] = ch or {"(none)": float("inf")}
    if rec["rc"] == "timeout":
        flags.append("TIMEOUT")
    elif not ch or max(ch.values()) > 0.05 or set(ch) != set(case["columns"]):
        flags.append("NRMSE")
    res["verdict"] = "ok" if not flags else "+".join(flags)
    return res


# ----------------------------------------------------------------------------- (d) bad inputs
def _digest(path):
    try:
        with open(path, "rb") as fh:
            return hashlib.sha256(fh.read()).hexdigest()
    except OSError:
        return None


def _links(case, data):
    for kind, target, name in case.get("links", []):
        path = os.path.join(data, name)
        if os.path.lexists(path):
            os.remove(path)
        if kind == "symlink":
            os.symlink(target, path)
        else:
            os.link(os.path.join(data, target), path)


def score_robust(case, run):
    _links(case, run.data)
    prot = {p: _digest(os.path.join(run.data, p)) for p in case["protect"]}
    rec, out, err = run(case["argv"], case.get("timeout", 120))
    lines = [ln for ln in err.splitlines() if ln.strip()]
    res = {"id": "bad-" + case["id"], "kind": "robust", "commands": [rec], "stderr": lines[:3]}
    changed = [p for p, h in prot.items() if _digest(os.path.join(run.data, p)) != h]
    if rec["rc"] == "timeout":
        v = "TIMEOUT"
    elif "Traceback" in err:
        v = "CRASH"
    elif rec["rc"] == 0:
        v = "ok" if case.get("tolerant") else "ACCEPTED-BAD-INPUT"
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


def setup_h5(run, mass):
    """robust-good.h5 from robust-good.csv through `station import` (an ordinary user step)."""
    path = os.path.join(run.data, "robust-good.h5")
    if os.path.exists(path):
        os.remove(path)
    rec, _, _ = run(["import", "robust-good.csv", "--out", "robust-good.h5", "--mass", mass], 120)
    return rec
