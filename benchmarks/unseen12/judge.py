"""Run the station on one case and judge what it says (README.md, "The judgement").

The ``Runner`` (a subprocess per command in the data folder, CPU time read from /proc, a wall-clock backstop)
and the identification, multi-DOF and bad-input scorers are unseen11's, copied so the set stays self-contained;
the twelfth set takes each command's CPU limit from its case (``limit_cpu_s`` in the manifest), judges one-DOF
records from other DAQs by the identification rule (``score_record``: a refusal passes only where the case
lists the words it must name; a swapped force / response pair must be noticed), and adds multi-channel HDF5
sessions (``via_h5``: import the CSVs, then diagnose and validate the session's captures) and the grounded
softening spring to the multi-DOF scorer.
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
CAMPAIGN_WALL = 900  # the campaign of 30 captures (one worker)
MDOF_WALL = 600  # a multi-DOF diagnose (2-3 channels, folds and polish: 25-90 s CPU)
NONE_FLOOR = 0.15  # baseline held-out nrmse above which `none` on a hidden effect is a failure
HELD_MAX = 0.10  # identification: held-out nrmse on another blow (or 2x what the record's noise alone gives)
CI_SLACK = 1.5  # one record's 2-4 coefficients: outside 1.5 x ci95 (~2.9 sigma) fails; the 95 % coverage is
# pooled over the card (a calibrated station misses one of 3 plain 95 % intervals in 14 % of records)
BINOM_P = 0.01  # a campaign fails its ci95 when so many misses are that unlikely at 95 % coverage
MDOF_MAX = 0.05  # multi-DOF: held-out nrmse per channel (or NOISE_X x what the channel's noise alone gives)
NOISE_X = 2.0
TREND_R = 0.7  # campaign: correlation of the k1 estimates with the per-record truth, when the truth's swing is
# resolvable (larger than 2 x the median ci95)
CATALOGUE = {"coulomb_friction", "quadratic_damping", "cubic_damping", "clearance", "smooth_stiffening",
             "asymmetric_stiffness", "second_mode", "hysteresis", "amplitude_damping", "sensor_highpass"}


class Runner:
    """Runs ``station ...`` in the data folder: exit code, wall and CPU time (the process and the
    workers it waited for, from wait4), stdout kept in ``out/``. A command is killed (``rc`` is
    ``"timeout"``) once its processes (its session, read from /proc every second) have used ``timeout * scale``
    seconds of CPU, or after ``wall_factor`` times that in wall time: on a shared machine the CPU limit is the
    fair one (the station's cost), the wall limit a backstop against a hang."""

    def __init__(self, station_cmd, data, timeout_scale=1.0, wall_factor=4.0):
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
        done = threading.Event()

        def kill(why):
            killed.append(why)
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except OSError:
                pass

        def watch():
            cpu_max = 0.0
            while not done.wait(1.0):
                cpu_max = max(cpu_max, _session_cpu(p.pid))
                if cpu_max > timeout * self.scale:
                    kill("cpu")
                    return
                if time.time() - t0 > timeout * self.scale * self.wall_factor:
                    kill("wall")
                    return

        watcher = threading.Thread(target=watch, daemon=True)
        watcher.start()
        _, status, ru = os.wait4(p.pid, 0)
        done.set()
        p.returncode = os.waitstatus_to_exitcode(status)
        if killed:  # forked workers may hold the pipes open
            kill(killed[0])
        for th in readers:
            th.join(30)
        out, err = bufs.get("out", ""), bufs.get("err", "")
        rc = "timeout" if killed else p.returncode
        rec = {"cmd": "station " + " ".join(shlex.quote(a) for a in argv), "rc": rc,
               "wall_s": round(time.time() - t0, 1), "cpu_s": round(ru.ru_utime + ru.ru_stime, 1),
               "limit_cpu_s": timeout * self.scale, "limit_wall_s": timeout * self.scale * self.wall_factor,
               "killed_by": killed[0] if killed else None, "stderr_tail": err.strip().splitlines()[-3:]}
        with self.lock:
            self.count += 1
            rec["stdout_file"] = os.path.join("out", f"{self.count:03d}-{argv[0]}.txt")
        os.makedirs(os.path.join(self.data, "out"), exist_ok=True)
        with open(os.path.join(self.data, rec["stdout_file"]), "w") as fh:
            fh.write(rec["cmd"] + "\n" + out + "\n--- stderr ---\n" + err)
        return rec, out, err


_TICK = os.sysconf("SC_CLK_TCK")


def _session_cpu(sid):
    """CPU seconds (user + system, and of the children they waited for) of the live processes of session
    ``sid``."""
    total = 0
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat") as fh:
                rest = fh.read().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(rest[3]) == sid:
            total += sum(int(x) for x in rest[11:15])
    return total / _TICK


def parse_json(out):
    try:
        return json.loads(out[out.index("{"):out.rindex("}") + 1])
    except ValueError:
        return None


def named(text, patterns):
    """Whether ``text`` (lower-cased) matches one of the regular expressions (a refusal or warning that
    names the case's defect). File names are taken out first: the case ids in them must not count."""
    text = re.sub(r"\S+\.(csv|tsv|txt|uff|unv|mat|h5|hdf5|json|lvm)\b(:\d+)?", " ", text.lower())
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
    """Whether the named mechanism's model halves the baseline's held-out nrmse (a name on an effect outside the
    catalogue)."""
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
    """``diagnose CAPTURES --mass m --json``; the rule by the id's first word (README.md, "The judgement")."""
    res = {"id": case["id"], "kind": "diagnose", "commands": []}
    mass = ["--mass", repr(case["given_mass"])] if case.get("given_mass") is not None else []
    rec, out, err = run(["diagnose", *case["files"], *mass, *case.get("args", []), "--json"], CASE_WALL)
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
    rule = case["id"].split("-")[0]
    expect = case["expect"]

    def none_rule():
        held = judged if judged is not None else (base or 0)
        far = held > NONE_FLOOR or (floor and held > 5 * floor)
        return "NONE-ABOVE-FLOOR" if far else "none-weak"

    if rule == "null":
        v = ("correct" if cause == "none" else
             "FALSE-ALARM-UNEXPLAINED" if cause == "unexplained" else "FALSE-ALARM-NAMED")
        if v == "correct" and rec["rc"] == 1:
            v = "FLAGGED-ON-NULL"
    elif cause in expect:
        v = "correct"
    elif rule == "cat" and cause == "unexplained":
        v = "abstained"
    elif cause == "none" and case["id"] == "chain-massgrams":
        v = "NONE-WITH-MASS-OFF"  # the contract: an impulse/mass finding turns `none` into `unexplained`
    elif cause == "none":
        v = none_rule()
    elif rule == "hid" and _halves(d, cause):
        v = "named-halves"  # outside the catalogue: a name whose model halves the baseline's error
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
            if est is None and ci is None:  # a given term the station's selection dropped: zero, no interval
                est, ci = 0.0, 0.0
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
    argv = ["identify", f["fit"], "--mass", repr(case.get("given_mass") or tr["mass"]), "--damping",
            ",".join(tr["damping"]),
            "--stiffness", ",".join(tr["stiffness"]), *case.get("args", []), "--json"]
    limit = case.get("limit_cpu_s", CASE_WALL)
    rec, out, err = run(argv, limit)
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] in (0, 1) else None
    if d is None:
        res["verdict"] = _failed(rec, err, case)
        res["stderr"] = _lines(err)
        return res
    if rec["rc"] == 1:
        flagged = d.get("unstable") or (d.get("validation") or {}).get("diverged")
        res["verdict"] = "flagged-unstable" if flagged else "EXIT-1-UNFLAGGED"
        if flagged and case.get("must_flag"):  # the defect itself must be named, not only the model's growth
            said = " ".join([err] + [str(w) for w in d.get("warnings") or []])
            res["verdict"] = "flagged-named" if named(said, case.get("warn_words")) else "FLAGGED-UNNAMED"
        res["stderr"] = _lines(err)
        return res
    errs, cover, outside, missing = judge_coefs(d, tr, CI_SLACK)
    model_path = f"score-{case.get('label', case['id'])}-model.json"
    with open(os.path.join(run.data, model_path), "w") as fh:
        json.dump(d["model"], fh)
    rec, out, err = run(["validate", model_path, f["held"], *case.get("args", []), "--json"], limit)
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


# ----------------------------------------------------------------------------- workflow: import, then replay
def score_workflow(case, run):
    """``import CSVs --out S.h5 --mass m --sensor-highpass HZ --json`` then ``replay S.h5 --damping TRUE
    --stiffness TRUE --json``: import exits 0; the replayed identification as ``identify``'s rule (coefficients
    within 1.5 x ci95 and the mean held-out nrmse <= max(0.10, 2 x noise), else a warning; exit 1 flagged)."""
    tr = case["truth"]
    res = {"id": case["id"], "kind": "workflow", "commands": []}
    h5 = f"score-{case.get('label', case['id'])}.h5"
    if os.path.exists(os.path.join(run.data, h5)):
        os.remove(os.path.join(run.data, h5))
    rec, out, err = run(["import", *case["files"], "--out", h5, "--mass", repr(case["given_mass"]),
                         "--sensor-highpass", repr(case["highpass_hz"]), "--json"], CASE_WALL)
    res["commands"].append(rec)
    if rec["rc"] != 0:
        res["verdict"] = "IMPORT-" + _failed(rec, err, case)
        res["stderr"] = _lines(err)
        return res
    rec, out, err = run(["replay", h5, "--damping", ",".join(tr["damping"]), "--stiffness",
                         ",".join(tr["stiffness"]), "--json"], CASE_WALL)
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] in (0, 1) else None
    if d is None:
        res["verdict"] = "REPLAY-" + _failed(rec, err, case)
        res["stderr"] = _lines(err)
        return res
    if rec["rc"] == 1:
        res["verdict"] = "flagged-unstable" if d.get("unstable") else "EXIT-1-UNFLAGGED"
        return res
    ident = d.get("identified") or {}
    errs, cover, outside, missing = judge_coefs(ident, tr, CI_SLACK)
    held = (d.get("validation") or {}).get("nrmse")
    held = float(held) if held is not None else float("inf")
    noise = max(m["session"].get("noise_nrmse") or 0.0 for m in case["meta"]["captures"])
    held_max = max(HELD_MAX, 2 * noise)
    warns = list(ident.get("warnings") or []) + list((ident.get("validation") or {}).get("warnings") or [])
    res.update(coef_err=errs, covered=cover, outside=outside, held_nrmse=held, held_max=held_max,
               warnings=[str(w)[:160] for w in warns][:4])
    bad = outside + ([f"held-out nrmse {held:.3g}"] if held > held_max else [])
    if missing:
        res["verdict"] = "CONTRACT(ci95)"
    elif not bad:
        res["verdict"] = "ok"
    elif warns:
        res["verdict"] = "warned"
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
    rec, out, err = run(argv, CAMPAIGN_WALL)
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
    flags, cover, nrmses, k1, warned_rows = [], [], [], [], []
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
        warned_rows.append(bool((r.get("warnings") or "").strip()) or r.get("diverged") in ("True", "true", "1"))
        k1.append((d["stiffness"].get("x"), tr["stiffness"]["x"], d["ci95"]["stiffness"].get("x") or 0.0))
    if case.get("truths") and len(k1) == len(truths) and all(e is not None for e, _, _ in k1):
        # the truth follows the hall's temperature (down and back up): the estimates must follow it (correlation
        # >= TREND_R) when its swing is resolvable, larger than twice the median ci95
        est = np.array([e for e, _, _ in k1], float)
        true = np.array([t for _, t, _ in k1], float)
        ci = np.array([c for _, _, c in k1], float)
        swing = true.max() - true.min()
        r = float(np.corrcoef(est, true)[0, 1]) if np.std(est) > 0 else 0.0
        res["trend"] = f"r {r:.2f} (swing {100 * swing / true.max():.2f} %, median ci95 {100 * np.median(ci / est):.2g} %)"
        if swing > 2 * np.median(ci) and r < TREND_R:
            flags.append("TREND")
    broken = by.get(case["broken"]) or by.get(os.path.basename(case["broken"]))
    if broken is None or broken.get("status") != "error" or "\n" in (broken.get("error") or "\n"):
        flags.append("BROKEN-ROW")
    miss = sum(not c for c in cover)
    if cover and miss and binom_sf(miss - 1, len(cover), 0.05) < BINOM_P:
        flags.append("CI95")
    noise = max([m["captures"][0]["session"].get("noise_nrmse") or 0.0 for m in case.get("meta", [])] or [0.0])
    # as for `identify`: a row above the limit passes when the row itself warns (the station says the fit is
    # poor); silent rows above it fail
    silent = [x for x, w in zip(nrmses, warned_rows) if x > max(HELD_MAX, 2 * noise) and not w]
    res["rows_over_limit"] = [sum(x > max(HELD_MAX, 2 * noise) for x in nrmses), len(silent)]
    if silent:
        flags.append("NRMSE-SILENT")
    res.update(rows=len(rows), covered=cover, nrmse=nrmses, files_in_table=sorted(by)[:20])
    res["verdict"] = "ok" if not flags else "+".join(flags)
    return res


# ----------------------------------------------------------------------------- growing model
def score_grow(case, run):
    """``identify FILE --mass m --json`` (default libraries) on a self-excited record: the true model grows from
    small amplitudes, so the result must be flagged (exit 1 and `unstable`, a diverged validation or a warning)
    or refused in one line naming it; exit 0 is `GROWING-EXIT-0`."""
    res = {"id": case["id"], "kind": "grow", "commands": []}
    rec, out, err = run(["identify", case["files"][0], "--mass", repr(case["given_mass"]), "--json"], CASE_WALL)
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] in (0, 1) else None
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if d is None:
        case = dict(case, refusal_ok=[r"grow", r"unstable", r"self.excit", r"negative", r"decay", r"limit cycle"])
        res["verdict"] = _failed(rec, err, case)
        res["stderr"] = _lines(err)
        return res
    b1 = (d.get("damping") or {}).get("v")
    res.update(exit=rec["rc"], unstable=bool(d.get("unstable")), b1=b1,
               warnings=[str(w)[:160] for w in d.get("warnings") or []][:3])
    flagged = bool(d.get("unstable") or (d.get("validation") or {}).get("diverged") or d.get("warnings"))
    if rec["rc"] == 0:
        res["verdict"] = "GROWING-EXIT-0"
    elif rec["rc"] == 1 and flagged and len(lines) == 1:
        res["verdict"] = "ok"
    else:
        res["verdict"] = f"EXIT-{rec['rc']}-" + ("STDERR-LINES" if flagged else "UNFLAGGED")
    return res


# ----------------------------------------------------------------------------- multi-DOF
def score_mdof(case, run):
    """Diagnose three captures (no mass, the driving point named), save the model, validate it on the fourth
    (README.md, "The judgement")."""
    f = case["files"]
    res = {"id": case["id"], "kind": "mdof", "commands": []}
    model_path = f"score-{case.get('label', case['id'])}-model.json"
    if os.path.exists(os.path.join(run.data, model_path)):
        os.remove(os.path.join(run.data, model_path))
    limit = case.get("limit_cpu_s", MDOF_WALL)
    train, held_file = f["train"], f["held"]
    if case.get("via_h5"):  # a multi-channel HDF5 session: import the four CSVs (no mass), then its captures
        h5 = f"score-{case.get('label', case['id'])}.h5"
        if os.path.exists(os.path.join(run.data, h5)):
            os.remove(os.path.join(run.data, h5))
        rec, out, err = run(["import", *case["all_files"], "--out", h5, "--json"], CASE_WALL)
        res["commands"].append(rec)
        if rec["rc"] != 0:
            res["verdict"] = "IMPORT-" + _failed(rec, err)
            res["stderr"] = _lines(err)
            return res
        train, held_file = [f"{h5}:{i}" for i in range(len(f["train"]))], f"{h5}:{len(f['train'])}"
    argv = ["diagnose", *train, "--save-model", model_path, "--json", "--driving-point", case["driving_point"]]
    rec, out, err = run(argv, limit)
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] in (0, 1) else None
    if d is None or not os.path.exists(os.path.join(run.data, model_path)):
        res["verdict"] = _failed(rec, err, case) if d is None else "NO-MODEL"
        res["stderr"] = _lines(err)
        return res
    cause = res["cause"] = d.get("cause")
    nf = d.get("noise_floor")
    res["noise_floor"] = max(nf.values()) if isinstance(nf, dict) and nf and all(
        isinstance(x, (int, float)) for x in nf.values()) else _floor(d)
    flags = []
    coupling = case.get("coupling")
    complex_modes = bool(case.get("gyro")) or "dampmode" in case["id"]
    if coupling in ("ground", "ground-soft"):  # no coupling term in physical coordinates: `none` on a model that predicts
        res["coupling_verdict"] = {"none": "correct", "unexplained": "abstained",
                                   "modal_coupling": "FALSE-COUPLING"}.get(cause, "WRONG-CAUSE")
    elif coupling:
        # `none` is honest when the nonlinear terms move no channel of the held blow by more than NOISE_X x that
        # channel's noise nrmse (the generator's clean records with and without them)
        eff = case.get("coupling_effect_nrmse") or {}
        noise0 = (case.get("noise_nrmse") or [{}])[-1]
        weak = bool(eff) and all(x <= NOISE_X * float(noise0.get(c, 0.0)) for c, x in eff.items())
        other = ("none-weak" if weak else "NONE-ON-COUPLING") if cause == "none" else "WRONG-CAUSE"
        res["coupling_verdict"] = {"modal_coupling": "correct", "unexplained": "abstained"}.get(cause, other)
    elif complex_modes:  # linear, but its modes are complex (documented as not done): abstaining is honest
        res["coupling_verdict"] = {"none": "correct", "unexplained": "abstained",
                                   "modal_coupling": "FALSE-COUPLING"}.get(cause, "WRONG-CAUSE")
    else:
        res["coupling_verdict"] = {"none": "correct", "modal_coupling": "FALSE-COUPLING"}.get(cause, "FALSE-ALARM")
    if res["coupling_verdict"] not in ("correct", "abstained", "none-weak"):
        flags.append(res["coupling_verdict"])
    rec, out, err = run(["validate", model_path, held_file, "--json"], CASE_WALL)
    res["commands"].append(rec)
    v = parse_json(out) if rec["rc"] in (0, 1) else None
    ch = {k: float(x) for k, x in (v or {}).get("channel_nrmse", {}).items()} if v else {}
    res["held_nrmse"] = ch or {"(none)": float("inf")}
    noise = (case.get("noise_nrmse") or [{}])[-1]
    limits = {c: max(MDOF_MAX, NOISE_X * float(noise.get(c, 0.0))) for c in case["columns"]}
    res["held_limit"] = limits
    # a model the station stands behind (`none`, a name) must predict the held blow; under `unexplained` it
    # says itself that it does not
    if cause != "unexplained":
        if rec["rc"] == "timeout":
            flags.append("TIMEOUT")
        elif not ch or len(ch) != len(case["columns"]):
            flags.append("NRMSE(channels)")
        elif any(x > limits.get(c, MDOF_MAX) for c, x in ch.items()):
            flags.append("NRMSE")
    res["verdict"] = ("ok" if res["coupling_verdict"] == "correct" else res["coupling_verdict"]) if not flags \
        else "+".join(flags)
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
    if rec["rc"] == 0 and case.get("check_mass") is not None:  # a tolerated input: the value must be right
        d = parse_json(out)
        got = (d or {}).get("mass")
        try:
            ok = abs(float(got) / case["check_mass"] - 1) < 1e-6
        except (TypeError, ValueError):
            ok = False
        res["mass"] = got
        v = "ok-tolerant" if ok else "WRONG-VALUE"
    elif case.get("expect_rc") is not None:  # a good input that must work
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


# ----------------------------------------------------------------------------- consistency (eleventh set)
REL_SAME = 1e-6  # the same records, the same pipeline: the numbers agree to rounding (docs/diagnosis.md:
# "the same, bit for bit, as station identify / report / replay / demo give for the same captures")
FORMAT_CI = 0.1  # the same record in another layout (units converted, 9 printed digits): within 0.1 x ci95
REL_NRMSE = 1e-3  # validate simulates the same model on the same record: its nrmse as identify's held-out one


def _coefs(d):
    """{term: value} of an identification result (top level, or under ``identified`` / ``model``)."""
    for src in (d, d.get("identified") or {}, d.get("model") or {}):
        if isinstance(src, dict) and isinstance(src.get("stiffness"), dict):
            return {**{f"b[{k}]": float(v) for k, v in (src.get("damping") or {}).items()},
                    **{f"k[{k}]": float(v) for k, v in src["stiffness"].items()}}
    return {}


def _same(a, b, rel=REL_SAME):
    """Terms that differ between two coefficient sets (or are in one only)."""
    bad = []
    for k in sorted(set(a) | set(b)):
        if k not in a or k not in b:
            bad.append(f"{k} in one only")
        elif abs(a[k] - b[k]) > rel * max(abs(a[k]), abs(b[k])) + 1e-300:
            bad.append(f"{k} {a[k]:.6g} vs {b[k]:.6g}")
    return bad


def _ident_truth(d, case):
    """The identification rule on a result: coefficients within 1.5 x ci95 of the truth, the held-out nrmse."""
    errs, cover, outside, missing = judge_coefs(d, case["truth"], CI_SLACK)
    held = (d.get("held_out") or d.get("validation") or {}).get("nrmse")
    noise = max(m["session"].get("noise_nrmse") or 0.0 for m in case["meta"]["captures"])
    held = float(held) if held is not None else float("inf")
    return errs, cover, outside + ([f"held-out nrmse {held:.3g}"] if held > max(HELD_MAX, 2 * noise) else []), \
        missing, held


def score_consistency(case, run):
    """``x-cross``: identify CAPTURES (true terms) vs diagnose CAPTURES (the same baseline terms): the baseline
    model and its held-out nrmse are identify's; validate MODEL on each record identify did not fit gives its
    held-out nrmse; diagnose's cause is `none` (the baseline holds the true terms); identify's coefficients
    within 1.5 x ci95 of the truth. ``x-h5``: import CAPTURES into an HDF5 session, identify it and report it:
    the same model as identify on the CSVs; the truth as above."""
    tr = case["truth"]
    lab = case.get("label", case["id"])
    res = {"id": case["id"], "kind": "consistency", "commands": []}
    terms = ["--damping", ",".join(tr["damping"]), "--stiffness", ",".join(tr["stiffness"])]
    mass = ["--mass", repr(case["given_mass"])]
    flags = []

    def step(argv, name, ok_rc=(0,), timeout=CASE_WALL):
        rec, out, err = run(argv, timeout)
        res["commands"].append(rec)
        d = parse_json(out) if rec["rc"] in (0, 1) else None
        if rec["rc"] not in ok_rc or d is None:
            flags.append(f"{name}-" + _failed(rec, err))
            res.setdefault("stderr", _lines(err))
            return None
        return d

    ident = step(["identify", *case["files"], *mass, *terms, "--json"], "IDENTIFY")
    if ident is None:
        res["verdict"] = "+".join(flags)
        return res
    errs, cover, outside, missing, held = _ident_truth(ident, case)
    res.update(coef_err=errs, covered=cover, outside=outside, held_nrmse=held,
               warnings=[str(w)[:160] for w in ident.get("warnings") or []][:3])
    if missing:
        flags.append("CONTRACT(ci95)")
    elif outside and not ident.get("warnings"):
        flags.append("TRUTH-SILENT")
    a = _coefs(ident)
    diffs = {}
    if case["id"] == "x-cross":
        dg = step(["diagnose", *case["files"], *mass, *terms, "--json"], "DIAGNOSE", ok_rc=(0, 1),
                  timeout=CASE_WALL)
        if dg is not None:
            base = dg.get("baseline") or {}
            diffs["diagnose baseline"] = _same(a, _coefs(base))
            bn, hn = base.get("nrmse"), held
            if bn is None or abs(float(bn) - hn) > REL_NRMSE * hn:
                diffs["diagnose baseline nrmse"] = [f"{bn} vs identify {hn:.6g}"]
            res["cause"] = dg.get("cause")
            if dg.get("cause") != "none":
                flags.append("CAUSE")
        model_path = f"score-{lab}-model.json"
        with open(os.path.join(run.data, model_path), "w") as fh:
            json.dump(ident["model"], fh)
        per = {os.path.basename(str(r.get("source"))): r.get("nrmse")
               for r in (ident.get("held_out") or {}).get("records") or []}
        others = [f for f in case["files"] if f in per]
        if len(others) != len(case["files"]) - 1:
            flags.append("HELD-RECORDS")
        v = step(["validate", model_path, *others, "--json"], "VALIDATE", ok_rc=(0, 1)) if others else None
        if v is not None:
            got = {os.path.basename(str(r.get("source"))): r.get("nrmse") for r in v.get("records") or []}
            bad = [f"{f}: validate {got.get(f)} vs identify {per[f]:.6g}" for f in others
                   if got.get(f) is None or abs(float(got[f]) - float(per[f])) > REL_NRMSE * float(per[f])]
            if bad:
                diffs["validate nrmse"] = bad
    elif case["id"] == "x-formats":
        ci = {**{f"b[{k}]": v for k, v in ((ident.get("ci95") or {}).get("damping") or {}).items()},
              **{f"k[{k}]": v for k, v in ((ident.get("ci95") or {}).get("stiffness") or {}).items()}}
        for fmt, files in case["by_format"].items():
            if files == case["files"]:
                continue
            d2 = step(["identify", *files, *mass, *terms, "--json"], f"IDENTIFY-{fmt.upper()}")
            if d2 is None:
                continue
            b = _coefs(d2)
            bad = [f"{k} {a[k]:.6g} vs {b.get(k, float('nan')):.6g} (ci95 {ci.get(k, 0):.2g})" for k in a
                   if k not in b or abs(a[k] - b[k]) > FORMAT_CI * float(ci.get(k) or 0.0)]
            n2 = (d2.get("held_out") or {}).get("nrmse")
            if n2 is None or abs(float(n2) - held) > 10 * REL_NRMSE * held:
                bad.append(f"held-out nrmse {n2} vs {held:.6g}")
            diffs[f"identify on {fmt}"] = bad
    else:
        h5 = f"score-{lab}.h5"
        if os.path.exists(os.path.join(run.data, h5)):
            os.remove(os.path.join(run.data, h5))
        if step(["import", *case["files"], "--out", h5, *mass, "--json"], "IMPORT") is not None:
            d5 = step(["identify", h5, *terms, "--json"], "IDENTIFY-H5")
            if d5 is not None:
                diffs["identify on HDF5"] = _same(a, _coefs(d5))
                h5n = (d5.get("held_out") or {}).get("nrmse")
                if h5n is None or abs(float(h5n) - held) > REL_NRMSE * held:
                    diffs["HDF5 held-out nrmse"] = [f"{h5n} vs CSV {held:.6g}"]
            outdir = f"score-{lab}-report"
            ry = step(["replay", h5, *terms, "--json"], "REPLAY")
            if ry is not None:
                diffs["replay on HDF5"] = _same(a, _coefs(ry))
            rp = step(["report", h5, "--out", outdir, *terms, "--json"], "REPORT")
            if rp is not None:
                diffs["report on HDF5"] = _same(a, _coefs(rp))
                if not os.path.exists(os.path.join(run.data, outdir, "index.html")):
                    flags.append("NO-REPORT-HTML")
    diffs = {k: v for k, v in diffs.items() if v}
    res["disagree"] = diffs
    if diffs:
        flags.append("DISAGREE(" + ",".join(diffs) + ")")
    res["verdict"] = "+".join(flags) if flags else "ok"
    return res


def score_mdofreplay(case, run):
    """Import the four multi-channel CSVs into one HDF5 session (no mass), ``replay`` it: the multi-DOF path
    fits on every capture but the last and predicts every channel of the held-out last one within
    max(0.05, 2 x its noise) (unless it warns or abstains)."""
    lab = case.get("label", case["id"])
    res = {"id": case["id"], "kind": "mdofreplay", "commands": []}
    h5 = f"score-{lab}.h5"
    if os.path.exists(os.path.join(run.data, h5)):
        os.remove(os.path.join(run.data, h5))
    rec, out, err = run(["import", *case["all_files"], "--out", h5, "--json"], CASE_WALL)
    res["commands"].append(rec)
    if rec["rc"] != 0:
        res["verdict"] = "IMPORT-" + _failed(rec, err)
        res["stderr"] = _lines(err)
        return res
    rec, out, err = run(["replay", h5, "--json"], MDOF_WALL)
    res["commands"].append(rec)
    d = parse_json(out) if rec["rc"] in (0, 1) else None
    if d is None:
        res["verdict"] = "REPLAY-" + _failed(rec, err)
        res["stderr"] = _lines(err)
        return res
    held = [r for r in d.get("records") or [] if "held" in str(r.get("role", ""))]
    ch = {k: float(x) for k, x in (held[-1].get("channel_nrmse") or {}).items()} if held else {}
    res["held_nrmse"] = ch or {"(none)": float("inf")}
    noise = (case.get("noise_nrmse") or [{}])[-1]
    limits = {c: max(MDOF_MAX, NOISE_X * float(noise.get(c, 0.0))) for c in case["columns"]}
    res["held_limit"] = limits
    res["warnings"] = [str(w)[:160] for w in d.get("warnings") or []][:3]
    if rec["rc"] == 1:
        res["verdict"] = "flagged-unstable" if d.get("unstable") else "EXIT-1-UNFLAGGED"
    elif len(ch) != len(case["columns"]):
        res["verdict"] = "NRMSE(channels)"
    elif any(x > limits.get(c, MDOF_MAX) for c, x in ch.items()):
        res["verdict"] = "warned" if res["warnings"] else "NRMSE-SILENT"
    else:
        res["verdict"] = "ok"
    return res


# ----------------------------------------------------------------------------- one-DOF records (twelfth set)
def score_record(case, run):
    """A one-DOF record from another DAQ: ``score_ident``'s rule (coefficients within 1.5 x ci95 and held-out
    nrmse, else a warning naming the case's words; a one-line refusal only where the case lists the words it must
    name); a ``must_flag`` case (no right model exists) passes only on a refusal or warning that names it."""
    res = score_ident(case, run)
    res["kind"] = "record"
    if case.get("must_flag") and res["verdict"] == "ok":
        res["verdict"] = "ACCEPTED-SWAPPED"  # the truth cannot come out of swapped channels: a scorer check
    return res
