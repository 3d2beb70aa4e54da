#!/usr/bin/env python3
"""Write the fourth blind scorecard's records (CSV) and its manifest (the truth).

    python benchmarks/unseen4/generate.py --out /tmp/unseen4 --seed 41 --quick

Nothing is imported from eddi, station or simulated_rig: the physics (physics.py), the sensor
chain (sensors.py) and the cases (cases.py, parameters in README.md) are this folder's own.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import cases  # noqa: E402
import physics  # noqa: E402
import robust  # noqa: E402
import sensors  # noqa: E402


def sdof_system(truth, hidden=None, rng=None):
    m = truth["mass"]
    st, dp = truth["stiffness"], truth["damping"]
    nl = []
    for term, p in (("x^2", 2), ("x^3", 3)):
        if term in st:
            nl.append(("poly", 0, -1, st[term], p, 0))
    if "x^2*v" in dp:
        nl.append(("poly", 0, -1, dp["x^2*v"], 2, 1))
    if "v^3" in dp:
        nl.append(("poly", 0, -1, dp["v^3"], 0, 3))
    k1, A, w = st["x"], truth["A"], 2 * np.pi * truth["fn"]
    if hidden:
        kind = hidden[0]
        if kind == "gap":
            nl.append(("gap", 0, hidden[1] * k1, hidden[2] * A))
        elif kind == "kmod":
            nl.append(("kmod", 0, hidden[1] * k1, hidden[2], float(rng.uniform(0, 2 * np.pi))))
        elif kind == "maxwell":
            km = hidden[1] * k1
            nl.append(("maxwell", 0, km, km * hidden[2] / w))
    return physics.System({"M": [[m]], "K": [[k1]], "C": [[dp["v"]]], "nl": nl})


def record(system, fs, ppm, pre, dur, width_s, peak_force, x_scale, rng, *, snr, bits, chan=None,
           stamp=1.0, gain=None, range_x=None, offset=None, sensor_kw=None):
    """One record: dict of sampled columns (t stamped by the DAQ at fs * stamp)."""
    fs_st = fs * stamp
    n = int(round((pre + dur) * fs_st))
    n_pre = int(round(pre * fs_st))
    tf, ts = sensors.fine_grid(n, fs_st, ppm, 0.0)
    t0 = (n_pre + rng.uniform(0.05, 0.95)) * ts  # the blow starts between samples
    x, v, acc, force = physics.simulate(system, tf, t0, width_s, peak_force, x_scale)
    free = tf > t0 + width_s
    cols = {"t": np.round((np.arange(n) - n_pre) / fs_st, 7)}
    gain = gain if gain is not None else 1 + rng.uniform(-0.02, 0.02)
    range_x = range_x if range_x is not None else rng.uniform(1.5, 3.0)
    offset = offset if offset is not None else rng.uniform(-2e-3, 2e-3)
    cols["force"] = sensors.chain(tf, force, ts, rng, snr_db=snr + 10, bits=bits, range_x=1.3,
                                  gain=1 + rng.uniform(-0.01, 0.01), offset_frac=rng.uniform(-1e-4, 1e-4))
    for i, name in enumerate(chan or ["acc"]):
        pk = np.max(np.abs(acc[free, i]))
        cols[name] = sensors.chain(tf, acc[:, i], ts, rng, snr_db=snr, bits=bits, range_x=range_x,
                                   gain=gain, offset_frac=offset, peak=pk, **(sensor_kw or {}))
    return cols


def write_csv(path, cols, order):
    data = np.column_stack([cols[c] for c in order])
    fmt = ["%.7f" if c == "t" else "%.9g" for c in order]
    np.savetxt(path, data, delimiter=",", header=",".join(order), comments="", fmt=fmt)


def sdof_force(truth, width):
    """Haversine peak [N] that gives about A of displacement: impulse m w A over width/2."""
    w = 2 * np.pi * truth["fn"]
    return 2 * truth["mass"] * w * truth["A"] / (width / truth["fn"])


def gen_ident(out, seed, cid, c):
    r = cases.rng(seed, cid)
    tr = c["sys"]
    system = sdof_system(tr)
    width_s = c["width"] / tr["fn"]
    f_ref = sdof_force(tr, c["width"])
    order = c.get("order", "t,force,acc").split(",")
    files = {}
    for role, level in (("fit", 1.0), ("held", 0.6)):
        ppm = float(r.choice([-1, 1]) * r.uniform(20, 180))
        cols = record(system, c["fs"], ppm, c["pre"], c["dur"], width_s, level * f_ref, tr["A"], r,
                      snr=c["snr"], bits=c["bits"])
        files[role] = f"{cid}-{role}.csv"
        write_csv(os.path.join(out, files[role]), cols, order)
        files[role + "_ppm"] = ppm
    return {"id": cid, "truth": tr, "files": files, "fs": c["fs"]}


def gen_diag(out, seed, cid, c):
    r = cases.rng(seed, cid)
    tr = c["sys"]
    hidden = c["hidden"]
    levels = cases.NULL_LEVELS if hidden is None else cases.EFFECT_LEVELS
    width_s = c["width"] / tr["fn"]
    f_ref = sdof_force(tr, c["width"])
    sensor_kw = {}
    if hidden and hidden[0] == "iepe":
        sensor_kw = {"iepe_hz": hidden[1]}
    if hidden and hidden[0] == "mount":
        sensor_kw = {"mount_hz": hidden[1] * tr["fn"], "mount_zeta": hidden[2]}
    files = []
    sessions = [dict(stamp=1.0, ppm=float(r.uniform(-60, 60)))]
    if hidden is None:  # a second DAQ session: its own calibrated rate, gain, offset, range
        cal = float(r.choice([-1, 1]) * r.uniform(50, 150)) * 1e-6
        sessions.append(dict(stamp=1 + cal, ppm=float(r.uniform(-15, 15))))
    for s in sessions:
        s.update(gain=1 + r.uniform(-0.02, 0.02), range_x=r.uniform(1.5, 3.0), offset=r.uniform(-2e-3, 2e-3))
    for k, level in enumerate(levels):
        s = sessions[k % len(sessions)]  # the sessions interleave in blow level
        system = sdof_system(tr, hidden, r)
        cols = record(system, c["fs"], s["ppm"], c["pre"], c["dur"], width_s, level * f_ref, tr["A"], r,
                      snr=c["snr"], bits=c["bits"], stamp=s["stamp"], gain=s["gain"],
                      range_x=s["range_x"], offset=s["offset"], sensor_kw=sensor_kw)
        name = f"{cid}-{k}.csv"
        write_csv(os.path.join(out, name), cols, ["t", "force", "acc"])
        files.append(name)
    given = hidden[1] if hidden and hidden[0] == "mass" else tr["mass"]
    return {"id": cid, "truth": tr, "files": files, "hidden": hidden, "given_mass": given,
            "expect": c["expect"], "near": c.get("near", []), "symptom": c.get("symptom"),
            "sessions": sessions}


def gen_mdof(out, seed, cid, c):
    r = cases.rng(seed, cid)
    spec, scale = cases.mdof_spec(c["kind"])
    lin = physics.System({**spec, "nl": []})
    fr = lin.linear_frequencies()
    width_s = c["width"] / fr[0]
    # pilot: linear response to a unit blow sets the force for the target nonlinear amplitude
    tp = np.linspace(0, 3 / fr[0] + width_s, 4000)
    xp, *_ = physics.simulate(lin, tp, 0.0, width_s, 1.0, 1e-6)
    targets = {"chain3": 0.5e-3, "ratio12": 1.0e-3, "cantilever": 2.0e-3}
    law0 = scale[0][1]
    rel = xp[:, law0[0]] - (xp[:, law0[1]] if law0[1] >= 0 else 0.0)
    D = targets[c["kind"]]
    f_ref = D / np.max(np.abs(rel))
    nl = list(spec["nl"])
    coefs = []
    for idx, (i, j), klin, eps, p in scale:
        e = list(nl[idx])
        e[3] = eps * klin / D ** (p - 1)
        nl[idx] = tuple(e)
        coefs.append({"law": e[0], "i": i, "j": j, "power": p, "coef": e[3]})
    system = physics.System({**spec, "nl": nl})
    files = {"train": [], "held": None}
    gain = 1 + r.uniform(-0.02, 0.02)
    for k, level in enumerate(cases.MDOF_TRAIN + [cases.MDOF_HELD]):
        ppm = float(r.uniform(-80, 80))
        cols = record(system, c["fs"], ppm, c["pre"], c["dur"], width_s, level * f_ref, D, r,
                      snr=c["snr"], bits=c["bits"], chan=c["columns"], gain=gain)
        name = f"{cid}-{'held' if k == len(cases.MDOF_TRAIN) else k}.csv"
        write_csv(os.path.join(out, name), cols, ["t", "force"] + c["columns"])
        if k == len(cases.MDOF_TRAIN):
            files["held"] = name
        else:
            files["train"].append(name)
    return {"id": cid, "files": files, "freqs_hz": fr.tolist(), "masses": np.diag(spec["M"]).tolist(),
            "nonlinear": coefs, "columns": c["columns"], "driving_point": c["driving"],
            "force_ref_n": f_ref, "h5": cid == "mdof-12"}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="folder for the records and manifest.json")
    p.add_argument("--seed", type=int, default=41, help="every random draw follows from it (default 41)")
    p.add_argument("--quick", action="store_true", help="the quick subset (README.md)")
    a = p.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    t0 = time.time()
    man = {"seed": a.seed, "quick": a.quick, "ident": [], "diagnose": [], "mdof": [], "robust": []}
    for cid, c in cases.IDENT.items():
        if c["quick"] or not a.quick:
            man["ident"].append(gen_ident(a.out, a.seed, cid, c))
            print(f"[{time.time() - t0:5.0f} s] {cid}", file=sys.stderr)
    for cid, c in cases.DIAG.items():
        if c["quick"] or not a.quick:
            man["diagnose"].append(gen_diag(a.out, a.seed, cid, c))
            print(f"[{time.time() - t0:5.0f} s] {cid}", file=sys.stderr)
    for cid, c in cases.MDOF.items():
        if c["quick"] or not a.quick:
            man["mdof"].append(gen_mdof(a.out, a.seed, cid, c))
            print(f"[{time.time() - t0:5.0f} s] {cid}", file=sys.stderr)
    man["robust"] = robust.write(a.out, a.seed, man)
    man["generate_s"] = round(time.time() - t0, 1)
    with open(os.path.join(a.out, "manifest.json"), "w") as fh:
        json.dump(man, fh, indent=1, default=float)
    print(f"wrote {a.out}/manifest.json ({man['generate_s']} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
