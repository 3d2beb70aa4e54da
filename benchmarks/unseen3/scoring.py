"""Runs the station on each kind of case (subprocesses) and judges the outputs (``judge.py``)."""

from __future__ import annotations

import hashlib
import json
import os
import shlex
import shutil
import subprocess
import time

import judge

TIMEOUT = {"identify": 240, "validate": 120, "diagnose": 600, "import": 120, "replay": 240,
           "report": 300, "robust": 120}


class Runner:
    """Runs ``station`` subcommands in the data folder and records each command."""

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

    def path(self, name):
        return os.path.join(self.data, name)


def _brief(r):
    return {k: r.get(k) for k in ("cmd", "rc", "wall_s")} | ({"stderr": r["stderr"][-400:]} if r["rc"] else {})


def _import(run, files, h5, mass=None, sessions=None):
    """``station import`` of ``files`` into a fresh ``h5`` (``--new-session`` where the session changes).
    Returns the last command's result, with every import command in ``all``."""
    if os.path.exists(run.path(h5)):
        os.remove(run.path(h5))
    sessions = sessions or [0] * len(files)
    done = []
    for s in sorted(set(sessions)):
        group = [f for f, g in zip(files, sessions) if g == s]
        argv = ["import", *group, "--out", h5, "--json"] + (["--mass", repr(mass)] if mass else [])
        done.append(run(argv + (["--new-session"] if s else []), "import"))
        if done[-1]["rc"] != 0:
            break
    return dict(done[-1], all=[_brief(r) for r in done])


# ---- (a) consistency ------------------------------------------------------------------------------

def score_consistency(case, run):
    """The same three blows through identify (CSV, reordered CSV, HDF5), replay, report, diagnose and
    validate: one model and one held-out error."""
    m, cid, files = repr(case["mass"]), case["id"], case["files"]
    ref = run(["identify", *files, "--mass", m, "--json"], "identify")
    rows = []
    if ref["rc"] != 0 or not ref.get("json"):
        return [{"id": f"{cid}/identify", "kind": "consistency", "verdict": judge.run_failure(ref),
                 "cmds": [_brief(ref)]}]
    rj = ref["json"]
    ref_c, ref_n = judge.coeffs_of(rj), (rj.get("held_out") or {}).get("nrmse")
    truth_err = {k: judge.rel((rj.get(k.split(':')[0] == 'd' and 'damping' or 'stiffness') or {}).get(k[2:]), v)
                 for k, v in {**{"d:" + a: b for a, b in case["truth"]["damping"].items()},
                              **{"s:" + a: b for a, b in case["truth"]["stiffness"].items()}}.items()}
    rows.append({"id": f"{cid}/identify-csv", "kind": "consistency", "verdict": "reference", "cmds": [_brief(ref)],
                 "heldout_nrmse": ref_n, "truth_err": truth_err, "refinement": (rj.get("pipeline") or {}).get("refinement")})
    h5 = f"_{cid}.h5"
    imp = _import(run, files, h5, case["mass"])
    others = [("identify-reordered", ["identify", *case["reordered"], "--mass", m, "--json"], "identify", None)]
    if imp["rc"] == 0:
        others += [("identify-h5", ["identify", h5, "--json"], "identify", None),
                   ("replay-h5", ["replay", h5, "--json"], "replay", None),
                   ("report-h5", ["report", h5, "--out", f"_rep-{cid}", "--json"], "report", None)]
    else:
        rows.append({"id": f"{cid}/import", "kind": "consistency", "verdict": judge.run_failure(imp),
                     "cmds": imp["all"]})
    others += [("diagnose-baseline", ["diagnose", *files, "--mass", m, "--json"], "diagnose", None)]
    for tag, argv, kind, _ in others:         # replay takes one FILE: it is run on the HDF5 session
        r = run(argv, kind)
        rows.append(_compare(cid, tag, r, ref_c, ref_n))
        if tag.endswith("-h5"):
            rows[-1]["cmds"] = imp["all"] + rows[-1]["cmds"]
    model = f"_model-{cid}.json"
    with open(run.path(model), "w") as fh:
        json.dump(rj.get("model"), fh)
    held = [x["source"] for x in (rj.get("held_out") or {}).get("records", [])]
    v = run(["validate", model, *held, "--json"], "validate")
    vn = (v.get("json") or {}).get("nrmse")
    d = judge.rel(vn, ref_n)
    rows.append({"id": f"{cid}/validate-model", "kind": "consistency", "cmds": [_brief(v)], "heldout_nrmse": vn,
                 "nrmse_diff": d, "verdict": judge.run_failure(v) if v["rc"] else
                 ("same" if d <= judge.SAME else "DIFFERENT-NRMSE")})
    return rows


def _compare(cid, tag, r, ref_c, ref_n):
    row = {"id": f"{cid}/{tag}", "kind": "consistency", "cmds": [_brief(r)]}
    j = r.get("json")
    if r["rc"] != 0 or not j:
        row["verdict"] = judge.run_failure(r)
        return row
    if tag.startswith("diagnose"):
        c, n = judge.coeffs_of((j.get("baseline") or {}).get("model")), (j.get("baseline") or {}).get("nrmse")
    elif tag.startswith(("replay", "report")):
        c, n = judge.coeffs_of(j.get("identified")), (j.get("validation") or {}).get("nrmse")
    else:
        c, n = judge.coeffs_of(j), (j.get("held_out") or {}).get("nrmse")
    row.update({"model_diff": judge.model_diff(c, ref_c), "nrmse_diff": judge.rel(n, ref_n), "heldout_nrmse": n})
    bad = [w for w, x in (("MODEL", row["model_diff"]), ("NRMSE", row["nrmse_diff"])) if x > judge.SAME]
    row["verdict"] = "same" if not bad else "DIFFERENT-" + "+".join(bad)
    return row


# ---- (b) several sensors ----------------------------------------------------------------------------

def score_mdof(case, run):
    rows = [_mdof_once(case, run, case["files"], "csv")]
    if case.get("via_h5"):
        h5 = f"_{case['id']}.h5"
        imp = _import(run, case["files"], h5)
        if imp["rc"] != 0:
            rows.append({"id": case["id"] + "@h5", "kind": "mdof", "verdict": judge.run_failure(imp),
                         "cmds": imp["all"]})
        else:
            row = _mdof_once(case, run, [h5], "h5")
            row["cmds"] = imp["all"] + row["cmds"]
            rows.append(row)
    return rows


def _mdof_once(case, run, inputs, via):
    tag = case["id"] + ("" if via == "csv" else "@h5")
    model = f"_model-{tag}.json"
    if os.path.exists(run.path(model)):
        os.remove(run.path(model))
    dp = ["--driving-point", case["driving_point"]] if case.get("driving_point") else []
    d = run(["diagnose", *inputs, *dp, "--save-model", model, "--json"], "diagnose")
    row = {"id": tag, "kind": "mdof", "system": case["system"], "cmds": [_brief(d)]}
    if d["rc"] != 0 or not d.get("json"):
        row["verdict"] = judge.run_failure(d)
        return row
    v = run(["validate", model, case["heldout"], "--json"], "validate")
    row["cmds"].append(_brief(v))
    try:
        with open(run.path(model)) as fh:
            saved = json.load(fh)
    except (OSError, ValueError):
        saved = None
    row.update(judge.mdof_scores(case, d["json"], saved, v.get("json")))
    if v["rc"] != 0:
        row["verdict"] = "VALIDATE-" + judge.run_failure(v)
    return row


# ---- (c) record quirks -------------------------------------------------------------------------------

def score_quirk(case, run, default_lib=True):
    lib = case["library"]
    t = run(["identify", *case["files"], "--mass", repr(case["mass"]), "--damping", ",".join(lib["damping"]),
             "--stiffness", ",".join(lib["stiffness"]), "--json"], "identify")
    row = {"id": case["id"], "kind": "quirk", "what": case["what"], "cmds": [_brief(t)],
           "samples_per_cycle": round(case["samples_per_cycle"], 1)}
    out = t.get("json")
    if t["rc"] != 0 or not out:
        row["verdict"] = judge.run_failure(t)
        return row
    rows = judge.coefficient_table(case, out)
    model = f"_model-{case['id']}-true.json"
    with open(run.path(model), "w") as fh:
        json.dump(out.get("model"), fh)
    v = run(["validate", model, case["heldout"], "--json"], "validate")
    row["cmds"].append(_brief(v))
    n = (v.get("json") or {}).get("nrmse")
    row.update({"coeffs": rows, "heldout_nrmse": n, "warnings": out.get("warnings"),
                "notes": (out.get("conditioning") or {}).get("notes"), "verdict": judge.quirk_verdict(rows, n, out)})
    if default_lib:
        dflt = run(["identify", *case["files"], "--mass", repr(case["mass"]), "--json"], "identify")
        row["cmds"].append(_brief(dflt))
        dj = dflt.get("json")
        if dflt["rc"] == 0 and dj:
            dm = f"_model-{case['id']}-default.json"
            with open(run.path(dm), "w") as fh:
                json.dump(dj.get("model"), fh)
            dv = run(["validate", dm, case["heldout"], "--json"], "validate")
            row["cmds"].append(_brief(dv))
            dn = (dv.get("json") or {}).get("nrmse")
            row["default_nrmse"] = dn
            poor = dn is None or dn > judge.POOR
            row["default_verdict"] = "ok" if not poor else ("poor-warned" if judge.warned(dj) else "POOR-SILENT")
        else:
            row["default_verdict"] = judge.run_failure(dflt)
    return row


# ---- (d) diagnosis -------------------------------------------------------------------------------------

def score_diagnose(case, run, via="csv"):
    if via == "csv":
        files = [c["file"] for c in case["captures"]]
        r = run(["diagnose", *files, "--mass", repr(case["mass"]), "--json"], "diagnose")
        cmds = [_brief(r)]
    else:
        h5 = f"_{case['id']}.h5"
        imp = _import(run, [c["file"] for c in case["captures"]], h5, case["mass"],
                      [c["session"] for c in case["captures"]])
        if imp["rc"] != 0:
            return {"id": case["id"] + "@h5", "kind": "diagnose", "verdict": judge.run_failure(imp),
                    "cmds": imp["all"], "hidden": case["hidden"]}
        r = run(["diagnose", h5, "--json"], "diagnose")
        cmds = [*imp["all"], _brief(r)]
    row = {"id": case["id"] + ("" if via == "csv" else "@h5"), "kind": "diagnose", "hidden": case["hidden"],
           "catalogued": case["catalogued"], "expect": case["expect"], "note": case["note"], "cmds": cmds}
    out = r.get("json")
    if r["rc"] != 0 or not out:
        row["verdict"] = judge.run_failure(r)
        return row
    base = (out.get("baseline") or {}).get("nrmse")
    judged = (out.get("judged_baseline") or {}).get("nrmse")
    row.update({"cause": out.get("cause"), "baseline": base, "judged_baseline": judged,
                "baseline_fold_nrmse": (out.get("baseline") or {}).get("fold_nrmse"),
                "floor": (out.get("noise_floor") or {}).get("nrmse"),
                "extended": (out.get("extended") or {}).get("nrmse"),
                "symptoms": [s.get("kind") for s in out.get("symptoms") or [] if isinstance(s, dict)],
                "symptom_needed": case.get("symptom"), "symptom_found": judge.symptom_found(case, out)})
    row["verdict"] = judge.diagnose_verdict(case, out, base if base is not None else judged)
    return row


# ---- (e) bad inputs -------------------------------------------------------------------------------------

def setup_h5(run, spec):
    """Make ``bad-trunc-<spec>.h5``: a good imported capture cut to a fraction (or minus N bytes)."""
    name = f"bad-trunc-{spec}.h5"
    if os.path.exists(run.path(name)):
        return None
    good = "_bad-good.h5"
    if not os.path.exists(run.path(good)):
        r = _import(run, ["bad-good.csv"], good, 0.7)
        if r["rc"] != 0:
            return r
    size = os.path.getsize(run.path(good))
    cut = int(size * float(spec)) if "." in spec else size + int(spec)
    with open(run.path(good), "rb") as fh:
        data = fh.read(cut)
    with open(run.path(name), "wb") as fh:
        fh.write(data)
    return None


def _sha(path):
    try:
        with open(path, "rb") as fh:
            return hashlib.sha256(fh.read()).hexdigest()
    except OSError:
        return None


def score_robust(case, run):
    protect = {p: _sha(run.path(p)) for p in case.get("protect", [])}
    r = run(case["argv"], "robust")
    changed = [p for p, h in protect.items() if _sha(run.path(p)) != h]
    v = judge.robust_verdict(r, changed)
    for leftover in ("_rep-bad", ):
        shutil.rmtree(run.path(leftover), ignore_errors=True)
    lines = [ln for ln in r["stderr"].splitlines() if ln.strip()]
    return {"id": "bad-" + case["id"], "kind": "robust", "verdict": v, "cmds": [_brief(r) | {"stderr": r["stderr"][-300:]}],
            "stderr_lines": len(lines), "changed": changed}
