"""Run the station on one case and judge what it says (README.md, "The judgement").

The ``Runner`` (a subprocess per command in the data folder, CPU time from wait4, a wall-clock kill)
is unseen5's, kept as it is so that the cards time commands the same way; the scorers are unseen6's with
the eighth set's additions (setup commands, word-matched warnings and refusals, per-record campaign truth
and its trend, tolerant bad inputs).
"""

from __future__ import annotations

import json
import os
import re
import shlex
import signal
import subprocess
import threading
import time


CASE_WALL = 300  # s of wall time per case command (the brief's per-case timeout), x --timeout-scale
NONE_FLOOR = 0.15  # baseline held-out nrmse above which `none` on a hidden effect is a failure
MDOF_MAX = 0.05  # multi-DOF: held-out nrmse per channel (or NOISE_X x what the channel's noise alone gives)
NOISE_X = 2.0
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


def _halves(d, cause):
    """Whether the named mechanism's model halves the baseline's held-out nrmse (the README's rule for a
    name on an effect outside the catalogue)."""
    base = (d.get("judged_baseline") or d.get("baseline") or {}).get("nrmse")
    ext = (d.get("extended") or {}).get("nrmse")
    for c in d.get("candidates") or []:
        if isinstance(c, dict) and c.get("name") == cause and c.get("nrmse") is not None:
            ext = c["nrmse"]
    try:
        return float(ext) <= 0.5 * float(base)
    except (TypeError, ValueError):
        return False


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
        elif case["id"].startswith("hid-") and _halves(d, cause):
            v = "named-halves"  # outside the catalogue: a name whose model halves the baseline's error
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


# ----------------------------------------------------------------------------- multi-DOF
def score_mdof(case, run):
    """Diagnose three captures (no mass, the driving point named), save the model, validate it on the fourth.
    Coupling: present -> `modal_coupling` correct, `unexplained` abstained, `none` NONE-ON-COUPLING; absent ->
    `none` correct, `modal_coupling` FALSE-COUPLING, `unexplained` FALSE-ALARM. Every channel's held-out nrmse
    <= max(MDOF_MAX, NOISE_X x the nrmse that channel's white noise alone gives in the held record)."""
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
        res["stderr"] = _lines(err)
        return res
    cause = res["cause"] = d.get("cause")
    nf = d.get("noise_floor")
    res["noise_floor"] = max(nf.values()) if isinstance(nf, dict) and nf else _floor(d)
    flags = []
    if case["coupling"]:
        # `none` is honest when the coupling moves no channel of the held blow by more than NOISE_X x that
        # channel's noise nrmse (the generator's clean records with and without the nonlinear term)
        eff = case.get("coupling_effect_nrmse") or {}
        noise0 = (case.get("noise_nrmse") or [{}])[-1]
        weak = bool(eff) and all(x <= NOISE_X * float(noise0.get(c, 0.0)) for c, x in eff.items())
        other = ("none-weak" if weak else "NONE-ON-COUPLING") if cause == "none" else "WRONG-CAUSE"
        res["coupling_verdict"] = {"modal_coupling": "correct", "unexplained": "abstained"}.get(cause, other)
    else:
        res["coupling_verdict"] = {"none": "correct", "modal_coupling": "FALSE-COUPLING"}.get(cause, "FALSE-ALARM")
    if res["coupling_verdict"] not in ("correct", "abstained", "none-weak"):
        flags.append(res["coupling_verdict"])
    rec, out, err = run(["validate", model_path, f["held"], "--json"], CASE_WALL)
    res["commands"].append(rec)
    v = parse_json(out) if rec["rc"] in (0, 1) else None
    ch = {k: float(x) for k, x in (v or {}).get("channel_nrmse", {}).items()} if v else {}
    res["held_nrmse"] = ch or {"(none)": float("inf")}
    noise = (case.get("noise_nrmse") or [{}])[-1]
    limits = {c: max(MDOF_MAX, NOISE_X * float(noise.get(c, 0.0))) for c in case["columns"]}
    res["held_limit"] = limits
    if rec["rc"] == "timeout":
        flags.append("TIMEOUT")
    elif not ch or len(ch) != len(case["columns"]):
        flags.append("NRMSE(channels)")
    else:
        over = [c for c, x in ch.items() if x > limits.get(c, MDOF_MAX)]
        if over:
            flags.append("NRMSE")
    res["verdict"] = ("ok" if res["coupling_verdict"] == "correct" else res["coupling_verdict"]) if not flags \
        else "+".join(flags)
    return res
