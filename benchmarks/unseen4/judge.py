"""Run the station on one case and judge what it says (see README.md, "The judgement")."""

from __future__ import annotations

import hashlib
import json
import os
import shlex
import subprocess
import threading
import time

import numpy as np

DIAG_TIMEOUT = 300  # s per diagnose command (score.py: 1200 without --quick)
NONE_FLOOR = 0.15  # baseline held-out nrmse above which `none` on a hidden effect is a failure
TOL = {"x": 0.02, "stiff": 0.08, "damp": 0.15}


class Runner:
    """Runs ``station ...`` in the data folder; keeps every command, exit code and wall time."""

    def __init__(self, station_cmd, data, timeout_scale=1.0):
        self.cmd = shlex.split(station_cmd)
        self.data = data
        self.scale = timeout_scale
        self.lock = threading.Lock()
        self.count = 0

    def __call__(self, argv, timeout=300):
        argv = [str(a) for a in argv]
        t0 = time.time()
        try:
            p = subprocess.run(self.cmd + argv, cwd=self.data, capture_output=True, text=True,
                               timeout=timeout * self.scale, stdin=subprocess.DEVNULL)
            rc, out, err = p.returncode, p.stdout, p.stderr
        except subprocess.TimeoutExpired as e:
            rc, out, err = "timeout", _s(e.stdout), _s(e.stderr)
        rec = {"cmd": "station " + " ".join(shlex.quote(a) for a in argv), "rc": rc,
               "wall_s": round(time.time() - t0, 1), "stderr_tail": err.strip().splitlines()[-3:]}
        with self.lock:
            self.count += 1
            rec["stdout_file"] = os.path.join("out", f"{self.count:03d}-{argv[0]}.txt")
        os.makedirs(os.path.join(self.data, "out"), exist_ok=True)
        with open(os.path.join(self.data, rec["stdout_file"]), "w") as fh:
            fh.write(rec["cmd"] + "\n" + out + "\n--- stderr ---\n" + err)
        return rec, out, err


def _s(b):
    return b.decode(errors="replace") if isinstance(b, bytes) else (b or "")


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
    return "REFUSED"


# ----------------------------------------------------------------------------- (b) identification
def _scored(term, coef, tr):
    """Is the true term large enough to score (force at the reference amplitude)?"""
    A = tr["A"]
    V = 2 * np.pi * tr["fn"] * A
    k1, c1 = tr["stiffness"]["x"], tr["damping"]["v"]
    p = {"x": (1, 0), "x^2": (2, 0), "x^3": (3, 0), "v": (0, 1), "x^2*v": (2, 1), "v^3": (0, 3)}[term]
    force = abs(coef) * A ** p[0] * V ** p[1]
    return force >= (0.10 * c1 * V if p[1] else 0.05 * k1 * A)


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
    if rec["rc"] == 1:  # main exits 1 (one stderr line) when the model is unstable: flagged, not silent
        res["verdict"] = "flagged-unstable" if d.get("unstable") or (d.get("validation") or {}).get(
            "diverged") else _failed(rec, err)
        return res
    ppm = max(abs(f["fit_ppm"]), 1.0)
    errs, cover, bad = {}, [], []
    for group in ("damping", "stiffness"):
        for term, true in tr[group].items():
            est = d.get(group, {}).get(term)
            ci = (d.get("ci95", {}).get(group) or {}).get(term)
            e = (est - true) / abs(true) if est is not None else -1.0
            errs[term] = e
            inside = ci is not None and est is not None and abs(est - true) <= ci + 3e-6 * ppm * abs(true)
            cover.append(bool(inside))
            tol = TOL["x"] if term == "x" else TOL["damp"] if group == "damping" else TOL["stiff"]
            if _scored(term, true, tr) and abs(e) > tol:
                bad.append(f"{term} {100 * e:+.1f} %")
    model_path = f"score-{case['id']}-model.json"
    with open(os.path.join(run.data, model_path), "w") as fh:
        json.dump(d["model"], fh)
    rec, out, err = run(["validate", model_path, f["held"], "--json"], 300)
    res["commands"].append(rec)
    v = parse_json(out) if rec["rc"] in (0, 1) else None
    held = float(v["nrmse"]) if v and v.get("nrmse") is not None else float("inf")
    warned = bool(d.get("warnings") or (d.get("validation") or {}).get("warnings")
                  or (d.get("validation") or {}).get("diverged") or (v or {}).get("diverged"))
    if held > 0.1:
        bad.append(f"held-out nrmse {held:.3g}")
    res.update(coef_err=errs, covered=cover, held_nrmse=held, warned=warned, problems=bad,
               fit_nrmse=(d.get("validation") or {}).get("nrmse"))
    res["verdict"] = "ok" if not bad else ("poor-warned" if warned else "POOR-SILENT")
    return res


# ----------------------------------------------------------------------------- (a) diagnosis
def score_diag(case, run):
    res = {"id": case["id"], "kind": "diagnose", "commands": []}
    argv = ["diagnose", *case["files"], "--mass", repr(case["given_mass"]), "--json"]
    rec, out, err = run(argv, DIAG_TIMEOUT)
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] == 0 else None
    if d is None:
        res["verdict"] = _failed(rec, err)
        return res
    cause = d.get("cause")
    base = (d.get("baseline") or {}).get("nrmse")
    judged = (d.get("judged_baseline") or {}).get("nrmse")  # the one the verdict text quotes
    floor = d.get("noise_floor")
    floor_n = floor.get("nrmse") if isinstance(floor, dict) else floor
    syms = {s.get("kind"): s.get("values") or {} for s in d.get("symptoms") or [] if isinstance(s, dict)}
    kinds = sorted(syms)
    imp = syms.get("impulse_mass", {}).get("mismatch_pct")
    res.update(cause=cause, baseline_nrmse=base, judged_baseline_nrmse=judged, noise_floor=floor_n,
               extended_nrmse=(d.get("extended") or {}).get("nrmse"), symptoms=kinds, impulse_mass_pct=imp,
               verdict_text=str(d.get("verdict", ""))[:300],
               candidates=[(c.get("name"), c.get("nrmse")) for c in d.get("candidates") or []
                           if isinstance(c, dict)][:4])
    if case["hidden"] is None:
        res["verdict"] = ("correct" if cause == "none" else
                          "FALSE-ALARM-UNEXPLAINED" if cause == "unexplained" else "FALSE-ALARM-NAMED")
        return res
    catalogued = case["expect"] != ["unexplained"]
    if cause in case["expect"]:
        res["verdict"] = "correct" if _symptom_ok(case, syms) else "NO-SYMPTOM"
    elif cause in case.get("near", []):
        res["verdict"] = "near"
    elif cause == "unexplained":
        res["verdict"] = "abstained"  # only reached for catalogued effects
    elif cause == "none":
        held = judged if judged is not None else (base or 0)
        far = held > NONE_FLOOR or (floor_n and held > 5 * floor_n)
        res["verdict"] = "NONE-ABOVE-FLOOR" if far else "none-weak"
    else:
        res["verdict"] = "WRONG-NAMED"
    res["catalogued"] = catalogued
    return res


def _symptom_ok(case, syms):
    """The needed symptom is there with the right number (impulse_mass: within 10 points of the truth).

    The JSON lists every symptom kind with its values, so presence alone says nothing."""
    sym = case.get("symptom")
    if not sym:
        return True
    if sym == "impulse_mass":
        got = syms.get("impulse_mass", {}).get("mismatch_pct")
        true = 100 * (case["truth"]["mass"] - case["given_mass"]) / case["given_mass"]
        return got is not None and abs(float(got) - true) <= 10
    return sym in syms


# ----------------------------------------------------------------------------- (c) multi-DOF
def model_frequencies(model):
    """Natural frequencies [Hz] of a saved multi-DOF model's linear part."""
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


def _channel_nrmse(v):
    recs = v.get("records") or [{}]
    r0 = recs[0]
    for key in ("channel_nrmse", "channels", "nrmse_per_channel", "per_channel"):
        val = r0.get(key) if isinstance(r0, dict) else None
        if val is None:
            val = v.get(key)
        if isinstance(val, dict):
            return {k: float(x["nrmse"] if isinstance(x, dict) else x) for k, x in val.items()}
        if isinstance(val, list) and val and not isinstance(val[0], str):
            return {str(i): float(x["nrmse"] if isinstance(x, dict) else x) for i, x in enumerate(val)}
    return {"mean": float(v.get("nrmse", float("inf")))}


def score_mdof(case, run, via="csv"):
    f = case["files"]
    res = {"id": case["id"] + ("-h5" if via == "h5" else ""), "kind": "mdof", "commands": []}
    train = list(f["train"])
    if via == "h5":
        h5 = f"score-{case['id']}.h5"
        if os.path.exists(os.path.join(run.data, h5)):
            os.remove(os.path.join(run.data, h5))
        rec, _, err = run(["import", *train, "--out", h5], 300)
        res["commands"].append(rec)
        if rec["rc"] != 0:
            res["verdict"] = _failed(rec, err)
            return res
        train = [f"{h5}:{k}" for k in range(len(train))]
    model_path = f"score-{res['id']}-model.json"
    argv = ["diagnose", *train, "--save-model", model_path, "--json"]
    if case["driving_point"]:
        argv += ["--driving-point", case["driving_point"]]
    if os.path.exists(os.path.join(run.data, model_path)):
        os.remove(os.path.join(run.data, model_path))
    rec, out, err = run(argv, DIAG_TIMEOUT)
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] == 0 else None
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
    rec, out, err = run(["validate", model_path, f["held"], "--json"], 300)
    res["commands"].append(rec)
    v = parse_json(out) if rec["rc"] == 0 else None
    ch = _channel_nrmse(v) if v else {"mean": float("inf")}
    res["held_nrmse"] = ch
    if max(ch.values()) > 0.05:
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


def score_robust(case, run):
    prot = {p: _digest(os.path.join(run.data, p)) for p in case["protect"]}
    rec, out, err = run(case["argv"], 120)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    res = {"id": "bad-" + case["id"], "kind": "robust", "commands": [rec], "stderr": lines[:3]}
    changed = [p for p, h in prot.items() if _digest(os.path.join(run.data, p)) != h]
    if rec["rc"] == "timeout":
        v = "TIMEOUT"
    elif "Traceback" in err:
        v = "CRASH"
    elif rec["rc"] == 0:
        v = "ACCEPTED-BAD-INPUT"
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
    rec, _, err = run(["import", "robust-good.csv", "--out", "robust-good.h5", "--mass", mass], 120)
    return rec
