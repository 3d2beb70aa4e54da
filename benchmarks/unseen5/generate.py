#!/usr/bin/env python3
"""Write the fifth blind scorecard's records (CSV) and its manifest (the truth).

    python benchmarks/unseen5/generate.py --out /tmp/unseen5 --seed 51 --quick

Nothing is imported from eddi, station or simulated_rig: the mechanics (physics.py, scipy's
solve_ivp), the sensor chain (sensors.py) and the cases (cases.py) are this folder's own. Every
random draw follows from --seed and the case id (the same seed gives the same files).
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


def _poly_terms(tr):
    nl = []
    for term, coef in tr["stiffness"].items():
        if term != "x":
            nl.append(("poly", 0, -1, coef, int(term.split("^")[1]), 0))
    if "x^2*v" in tr["damping"]:
        nl.append(("poly", 0, -1, tr["damping"]["x^2*v"], 2, 1))
    if "v^3" in tr["damping"]:
        nl.append(("poly", 0, -1, tr["damping"]["v^3"], 0, 3))
    return nl


def sdof_system(tr, hidden=None, k=0):
    """(System, sensor kwargs, gain factor) of a single-DOF truth with a hidden effect, capture k."""
    m, A = tr["mass"], tr["A"]
    w = 2 * np.pi * tr["fn"]
    k1, c1 = tr["stiffness"]["x"], tr["damping"]["v"]
    nl = _poly_terms(tr)
    M, K, C, b = [[m]], [[k1]], [[c1]], [1.0]
    sens, gain = {}, 1.0
    kind = hidden[0] if hidden else None
    if kind == "drag":
        nl.append(("drag", 0, hidden[1] * c1 / (w * A)))
    elif kind == "coulomb":
        nl.append(("coulomb", 0, hidden[1] * k1 * A, hidden[2] * w * A))
    elif kind == "highpass":
        sens["hp_hz"] = hidden[1]
    elif kind == "rattle":
        _, mf, gf, kr, zc = hidden
        mr, kc = mf * m, kr * k1
        M, K, C, b = np.diag([m, mr]), np.diag([k1, 0.0]), np.diag([c1, 0.0]), [1.0, 0.0]
        nl.append(("gap2", 1, 0, kc, gf * A, 2 * zc * np.sqrt(kc * mr)))
    elif kind == "thermal":
        K = [[k1 * (1 + hidden[1][k])]]
    elif kind == "clearance":
        nl.append(("gap2", 0, -1, hidden[1] * k1, hidden[2] * A, 0.0))
    elif kind == "joint":
        for ff, uf in hidden[1]:
            nl.append(("bw", 0, ff * k1 * A, uf * A, hidden[2], hidden[3]))
    elif kind == "mode2":
        _, mf, ratio, z2, cf = hidden
        m2 = mf * m
        k2m, kc = m2 * (ratio * w) ** 2, cf * k1
        c2 = 2 * z2 * m2 * ratio * w
        M = np.diag([m, m2])
        K = np.array([[k1 + kc, -kc], [-kc, k2m + kc]])
        C = np.diag([c1, c2])
        b = [1.0, 0.0]
    elif kind == "sensornl":
        sens.update(nl2=hidden[1], ref=w * w * A)
    elif kind == "gain":
        gain = hidden[1][k]
    return physics.System({"M": M, "K": K, "C": C, "b": b, "nl": nl}), sens, gain


def pilot_force(system, width_s, shape, target, rel=(0, -1)):
    """Peak force [N] that makes the linear part's displacement (rel: i - j) peak at target [m]."""
    lin = physics.System({"M": system.M, "K": system.K, "C": system.C, "b": system.b, "nl": []})
    fr = lin.linear_frequencies()
    f_lo = fr[fr > 1e-6].min()
    tp = np.linspace(0.0, width_s + 1.5 / f_lo, 6000)
    x, *_ = physics.simulate(lin, tp, 0.0, width_s, 1.0, shape, 1e-6)
    d = x[:, rel[0]] - (x[:, rel[1]] if rel[1] >= 0 else 0.0)
    return target / np.max(np.abs(d))


def record(system, c, s, level_force, x_scale, rng, *, chans=(0,), names=("acc",), sens=None,
           gain=1.0, width_s=None):
    """One record: dict of sampled columns, t stamped by the DAQ at fs * stamp (s: the session)."""
    fs_st = c["fs"] * s["stamp"]
    n = int(round((c["pre"] + c["dur"]) * fs_st))
    n_pre = int(round(c["pre"] * fs_st))
    tf, ts = sensors.fine_grid(n, fs_st, s["ppm"])
    t0 = (n_pre + rng.uniform(0.05, 0.95)) * ts
    shape = cases.TIPS[c["tip"]]
    x, v, acc, force = physics.simulate(system, tf, t0, width_s, level_force, shape, x_scale)
    free = tf > t0 + width_s
    cols = {"t": np.round((np.arange(n) - n_pre) / fs_st, 9)}
    fa = sensors.convert(sensors.analog(force, ts), n, c["adc"])
    cols["force"] = sensors.digitise(fa, rng, peak=np.max(np.abs(fa)), snr_db=c["snr"] + 12, bits=c["bits"],
                                     range_x=1.25, gain=1 + rng.uniform(-0.005, 0.005),
                                     offset_frac=rng.uniform(-2e-4, 2e-4))
    for ch, name in zip(chans, names):
        ya = sensors.convert(sensors.analog(acc[:, ch], ts, **(sens or {})), n, c["adc"])
        pk = np.max(np.abs(acc[free, ch]))
        cols[name] = sensors.digitise(ya, rng, peak=pk, snr_db=c["snr"], bits=c["bits"],
                                      range_x=s["range_x"], gain=s["gain"] * gain,
                                      offset_frac=s["offset"])
    return cols


def write_csv(path, cols, order):
    data = np.column_stack([cols[c] for c in order])
    fmt = ["%.9f" if c == "t" else "%.10g" for c in order]
    np.savetxt(path, data, delimiter=",", header=",".join(order), comments="", fmt=fmt)


def _device(r):
    """One DAQ and sensor set: its clock's true offset from the stamped rate and the accelerometer's
    calibration error (a lab's calibrated chain: +-1 %)."""
    return dict(ppm=float(r.uniform(-60, 60)), gain=1 + float(r.uniform(-0.01, 0.01)))


def _session(r, dev):
    """A session on a device: the clock drifts a few ppm, the sensor re-mounted (gain +-0.3 %), its
    own range, offset and hammer width (+-15 %)."""
    return dict(stamp=1.0, ppm=dev["ppm"] + float(r.uniform(-2, 2)),
                gain=dev["gain"] * (1 + float(r.uniform(-0.003, 0.003))),
                range_x=float(r.uniform(1.4, 2.8)), offset=float(r.uniform(-3e-3, 3e-3)),
                width=float(r.uniform(0.85, 1.15)))


def gen_sdof_set(out, seed, cid, c, levels, n_sessions):
    """Captures of one single-DOF case at the given levels (sessions interleaved)."""
    r = cases.rng(seed, cid)
    tr, hidden = c["sys"], c.get("hidden")
    dev = _device(r)
    sessions = [_session(r, dev)]
    for _ in range(n_sessions - 1):  # the same DAQ again, or (hidden "twodaq") another one
        if hidden and hidden[0] == "twodaq":
            other = _device(r)
            other["ppm"] = dev["ppm"] + float(r.choice([-1, 1])) * hidden[1]
            sessions.append(_session(r, other))
        else:
            sessions.append(_session(r, dev))
    files = []
    width0 = c["width"] / tr["fn"]
    for k, level in enumerate(levels):
        s = sessions[k % len(sessions)]
        system, sens, gain = sdof_system(tr, hidden, k)
        width_s = width0 * s["width"]
        f_ref = pilot_force(system, width_s, cases.TIPS[c["tip"]], tr["A"])
        cols = record(system, c, s, level * f_ref, tr["A"], r, sens=sens, gain=gain, width_s=width_s)
        name = f"{cid}-{k}.csv"
        write_csv(os.path.join(out, name), cols, ["t", "force", "acc"])
        files.append(name)
    return files, sessions


def gen_diag(out, seed, cid, c):
    null = c.get("hidden") is None or c["hidden"][0] == "twodaq"
    files, sessions = gen_sdof_set(out, seed, cid, c, cases.NULL_LEVELS if null else cases.EFFECT_LEVELS,
                                   2 if null else 1)
    return {"id": cid, "truth": c["sys"], "files": files, "hidden": c.get("hidden"),
            "expect": c.get("expect", ["none"]), "near": c.get("near", []),
            "given_mass": c["sys"]["mass"], "sessions": sessions}


def gen_ident(out, seed, cid, c):
    files, sessions = gen_sdof_set(out, seed, cid, c, [1.0, 0.65], 2)
    return {"id": cid, "truth": c["sys"], "files": {"fit": files[0], "held": files[1]},
            "ppm": [s["ppm"] + 1e6 * (s["stamp"] - 1) for s in sessions], "fs": c["fs"],
            "fit_gain": sessions[0]["gain"], "sessions": sessions}


def gen_mdof(out, seed, cid, c):
    r = cases.rng(seed, cid)
    spec, scale = cases.mdof_spec(c["kind"])
    (idx, (i, j), klin, eps, p, D), = scale
    nl = list(spec["nl"])
    e = list(nl[idx])
    e[3] = eps * klin / D ** (p - 1)
    nl[idx] = tuple(e)
    system = physics.System({**spec, "nl": nl})
    fr = system.linear_frequencies()
    width_s = c["width"] / fr[0]
    f_ref = pilot_force(system, width_s, cases.TIPS[c["tip"]], D, rel=(i, j))
    s = _session(r, _device(r))
    chan_gain = [1 + float(r.uniform(-0.01, 0.01)) for _ in c["columns"]]
    order = {"acc_main": 0, "acc_tmd": 1, "acc_hub": 0, "acc_arm1": 1, "acc_arm2": 2}
    chans = [order[n] for n in c["columns"]]
    files = {"train": [], "held": None}
    for k, level in enumerate(cases.MDOF_TRAIN + [cases.MDOF_HELD]):
        s["ppm"] = float(r.uniform(-80, 80))
        cols = record(system, c, s, level * f_ref, D, r, chans=chans, names=c["columns"], width_s=width_s)
        for name, g in zip(c["columns"], chan_gain):
            cols[name] = cols[name] * g
        held = k == len(cases.MDOF_TRAIN)
        name = f"{cid}-{'held' if held else k}.csv"
        write_csv(os.path.join(out, name), cols, ["t", "force"] + c["columns"])
        if held:
            files["held"] = name
        else:
            files["train"].append(name)
    return {"id": cid, "files": files, "freqs_hz": fr.tolist(), "masses": np.diag(spec["M"]).tolist(),
            "nonlinear": {"i": i, "j": j, "power": p, "coef": e[3]}, "columns": c["columns"],
            "driving_point": c["driving"], "force_ref_n": f_ref}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="folder for the records and manifest.json")
    p.add_argument("--seed", type=int, default=51, help="every random draw follows from it (default 51)")
    p.add_argument("--quick", action="store_true", help="the quick subset (README.md)")
    p.add_argument("--only", default="", help="comma-separated case ids to generate (debugging)")
    a = p.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    t0 = time.time()
    man = {"seed": a.seed, "quick": a.quick, "ident": [], "diagnose": [], "mdof": [], "robust": []}
    keep = lambda cid, c: (c["quick"] or not a.quick) and (not a.only or cid in a.only.split(","))  # noqa: E731
    for group, table, fn in (("ident", cases.IDENT, gen_ident), ("diagnose", cases.NULLS, gen_diag),
                             ("diagnose", cases.EFFECTS, gen_diag), ("mdof", cases.MDOF, gen_mdof)):
        for cid, c in table.items():
            if keep(cid, c):
                man[group].append(fn(a.out, a.seed, cid, c))
                print(f"[{time.time() - t0:5.0f} s] {cid}", file=sys.stderr, flush=True)
    if man["ident"]:
        man["robust"] = robust.write(a.out, a.seed, man, a.quick)
    man["generate_s"] = round(time.time() - t0, 1)
    with open(os.path.join(a.out, "manifest.json"), "w") as fh:
        json.dump(man, fh, indent=1, default=float)
    print(f"wrote {a.out}/manifest.json ({man['generate_s']} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
