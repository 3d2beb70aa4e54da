#!/usr/bin/env python3
"""Generate the fourteenth blind scorecard's records and its manifest (the truth score.py reads).

    python benchmarks/unseen14/generate.py --out /tmp/unseen14 --seed SEED --quick

Every case draws its parameters (mass 0.05-50 kg, natural frequency 3-2000 Hz, damping, sample rate, noise,
sensor chain, file layout, blow levels) from a generator seeded by (--seed, case id). The families are listed in
README.md; what each case hides is only here and in the manifest. Nothing is imported from the station: the
records come from an RK4 integration of the equations of motion (numba, records.py), sampled through a model of
the sensor chain (the DAQ's linear-phase decimation filter, an extra anti-alias filter, AC coupling, gain,
offset, hum, jitter, noise, ADC quantisation, clipping).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import zlib

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from records import SUB, _mdof, chain, draw_sdof, one_dof_record, write_csv, write_h5  # noqa: E402

# --------------------------------------------------------------------------- case makers (see cases_* below)
LEVELS = (1.0, 0.45, 0.7, 0.85)


def diag_case(rng, label, out, sysd, chain_c, rule, expect, hidden, args=(), free=False, per_capture=None):
    files = []
    for i, lev in enumerate(LEVELS):
        c = dict(chain_c)
        s = dict(sysd, p=np.array(sysd["p"], float))
        if per_capture:
            per_capture(i, s, c)
        t, force, acc, _ = one_dof_record(rng, s, lev, c, free)
        if c.get("rate_written"):
            t = t * sysd["fs"] / c["rate_written"]
        cols = {"t": t, "acc": acc} if free else {"t": t, "force": force, "acc": acc}
        name = f"{label}-{i + 1}.csv"
        write_csv(os.path.join(out, name), cols)
        files.append(name)
    return {"files": files, "given_mass": sysd["mass"], "args": list(args), "rule": rule, "expect": list(expect),
            "hidden": hidden, "system": _sys(sysd), "chain": chain_c}


def _sys(s):
    return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in s.items()}


def base_chain(rng, snr=(44, 56)):
    return {"snr_acc": float(rng.uniform(*snr)), "snr_force": float(rng.uniform(50, 60))}


def _set(sysd, **kw):
    """Coefficients relative to the top displacement A (k: N/m, so k3 = r k / A^2 ...)."""
    p, k, A, c = sysd["p"], sysd["k1"], sysd["A"], sysd["p"][0]
    w = 2 * np.pi * sysd["fn_hz"]
    for name, r in kw.items():
        if name == "k2":
            p[5] = r * k / A
        elif name == "k3":
            p[6] = r * k / A ** 2
        elif name == "k5":
            p[7] = r * k / A ** 4
        elif name == "cxxv":
            p[3] = r * c / A ** 2
        elif name == "c3":
            p[2] = r * c / (w * A) ** 2
        elif name == "cq":  # quadratic loss over viscous loss at the top amplitude: (8/3) cq w A / (pi c)
            p[1] = r * np.pi * c / (8 / 3 * w * A)
    return sysd


def _truth(sysd, damping, stiffness):
    p = sysd["p"]
    col = {"v": p[0], "abs(v)*v": p[1], "v^3": p[2], "x^2*v": p[3], "x": p[4], "x^2": p[5], "x^3": p[6],
           "x^5": p[7], "x^4": p[19]}
    return {"mass": sysd["mass"], "damping": {t: float(col[t]) for t in damping},
            "stiffness": {t: float(col[t]) for t in stiffness}}


def d_cases():
    """(id, rule, maker(rng) -> (sysd, chain, expect, hidden, args, free, per_capture))."""
    def null(lo, hi, flo, fhi, hidden, chain_kw=None, zeta=(0.005, 0.02), free=False, **coef):
        def make(rng):
            s = _set(draw_sdof(rng, lo, hi, flo, fhi, zeta), **coef)
            return s, {**base_chain(rng), **(chain_kw or {})}, [], hidden, [], free, None
        return make

    def drag(rng):
        s = _set(draw_sdof(rng, 10, 50, 4, 12, (0.004, 0.008)), cq=3.0)
        return s, base_chain(rng), ["quadratic_damping"], "viscous + quadratic drag (3x at the top)", \
            ["--damping", "v"], False, None

    def fric(rng):
        s = draw_sdof(rng, 5, 30, 5, 20, (0.003, 0.006))
        s["p"][13], s["p"][14] = 0.012 * s["k1"] * s["A"], 1e-3 * s["A"] * 2 * np.pi * s["fn_hz"]
        return s, base_chain(rng), ["coulomb_friction"], "Coulomb friction 1.2 % of k A", [], False, None

    def gap(rng):
        s = draw_sdof(rng, 0.5, 2, 30, 80, (0.005, 0.012))
        s["p"][11], s["p"][12] = 1.2 * s["k1"], 0.45 * s["A"]
        return s, base_chain(rng), ["clearance"], "symmetric contact beyond 0.45 A, 1.2 k", [], False, None

    def bw(rng):
        s = draw_sdof(rng, 0.2, 1, 40, 150, (0.002, 0.004))
        s["p"][16], s["p"][17], s["p"][18] = 0.12 * s["k1"] * s["A"], 0.15 * s["A"], 2.0
        return s, base_chain(rng), ["hysteresis"], "Bouc-Wen Fy 0.12 k A, dy 0.15 A, n 2", [], False, None

    def hp(rng):
        s = draw_sdof(rng, 5, 20, 6, 15, (0.008, 0.02))
        r = float(rng.uniform(0.04, 0.07))
        return s, {**base_chain(rng), "hp_hz": r * s["fn_hz"]}, ["sensor_highpass"], f"AC coupling f_c/f {r:.3f}", \
            [], False, None

    def crack(rng):
        s = draw_sdof(rng, 1, 4, 20, 60)
        s["p"][8] = -0.15 * s["k1"]
        return s, base_chain(rng), [], "bilinear (breathing crack) k(1 -/+ 0.15)", [], False, None

    def stop(rng):
        s = draw_sdof(rng, 0.1, 0.6, 80, 300)
        s["p"][9], s["p"][10] = 2.0 * s["k1"], 0.35 * s["A"]
        return s, base_chain(rng), ["clearance"], "one-sided stop at +0.35 A, 2 k", [], False, None

    def reid(rng):
        s = draw_sdof(rng, 0.5, 5, 100, 600, (0.001, 0.002))
        s["p"][15], s["p"][14] = 0.03 * s["k1"], 1e-3 * s["A"] * 2 * np.pi * s["fn_hz"]
        return s, base_chain(rng), ["hysteresis"], "Reid hysteretic damping eta 0.03", [], False, None

    def drift(rng):
        s = draw_sdof(rng, 2, 10, 15, 50)
        k0 = s["k1"]

        def per(i, ss, c):
            ss["p"][4] = k0 * (1 - 0.012 * i)
        return s, base_chain(rng), [], "k drops 1.2 % per capture (warming)", [], False, per

    def clip(rng):
        s = draw_sdof(rng, 0.2, 2, 50, 300)
        top = s["A"] * (2 * np.pi * s["fn_hz"]) ** 2
        return s, {**base_chain(rng), "clip": 0.7 * top}, ["clipping"], "acc ADC clips at 0.7 x the top peak", \
            [], False, None

    def gain(rng):
        s = _set(draw_sdof(rng, 0.5, 8, 20, 200), k3=0.1)
        return s, {**base_chain(rng), "gain": 0.06}, ["impulse_mass"], "accelerometer sensitivity 6 % off", \
            [], False, None

    def rate(rng):
        s = draw_sdof(rng, 1, 5, 150, 240)
        s["fs"] = 5120.0

        def per(i, ss, c):
            if i == 2:
                c["rate_written"] = 5000.0
        return s, base_chain(rng), [], "capture 3 written at 5000 Hz, sampled at 5120 Hz", [], False, per

    def jitter(rng):
        s = draw_sdof(rng, 0.3, 3, 60, 250)
        return s, {**base_chain(rng, (55, 60)), "jitter": 0.08}, [], "sample-time jitter 8 % of dt rms", \
            [], False, None

    def aa_acc(rng):
        s = draw_sdof(rng, 0.2, 2, 100, 500)
        return s, {**base_chain(rng), "aa_frac": 0.15, "aa_order": 4}, ["sensor_lowpass", "response_lag"], \
            "4-pole low-pass at 0.15 fs on the acc only (conditioner)", [], False, None

    def mode2(rng):
        s = draw_sdof(rng, 0.5, 4, 20, 60, (0.006, 0.012))
        m2, r = 0.08 * s["mass"], float(rng.uniform(2.3, 2.7))
        k2 = m2 * (2 * np.pi * r * s["fn_hz"]) ** 2
        s["mode2"] = (m2, k2, 2 * 0.01 * np.sqrt(k2 * m2))
        s["fs"] = float(min(x for x in (1024, 2048, 2560, 5120, 10240) if x >= 20 * r * s["fn_hz"]))
        return s, base_chain(rng), ["second_mode"], f"unmeasured second mass 8 %, its mode at ~{r:.2f} f", [], \
            False, None

    def drag_light(rng):
        s = _set(draw_sdof(rng, 0.05, 0.2, 300, 800, (0.002, 0.005)), cq=5.0)
        return s, base_chain(rng), ["quadratic_damping"], "viscous + quadratic drag (5x at the top)", [], \
            False, None

    def fric_light(rng):
        s = draw_sdof(rng, 0.1, 0.5, 150, 500, (0.002, 0.004))
        s["p"][13], s["p"][14] = 0.015 * s["k1"] * s["A"], 1e-3 * s["A"] * 2 * np.pi * s["fn_hz"]
        return s, base_chain(rng), ["coulomb_friction"], "Coulomb friction 1.5 % of k A", [], False, None

    def double(rng):
        s = draw_sdof(rng, 0.5, 5, 30, 150)
        return s, {**base_chain(rng), "double_hit": True}, ["double_hit"], \
            "hammer bounce: a 30 % second blow 2.5 periods later on the two largest", [], False, None

    def hum(rng):
        s = draw_sdof(rng, 0.5, 5, 65, 95)
        return s, {**base_chain(rng), "hum": 0.02, "mains": float(rng.choice([50.0, 60.0]))}, \
            ["mains_interference"], "mains hum 2 % of peak + harmonics", [], False, None

    def quant(rng):
        s = draw_sdof(rng, 0.1, 1, 100, 400)
        return s, {**base_chain(rng, (60, 70)), "bits": 10, "range_x": 3.0}, [], "10-bit ADC, range 3x peak", \
            [], False, None

    return [
        ("null-tiny", "null", null(0.05, 0.09, 1200, 2000, "k3 0.15", zeta=(0.004, 0.01), k3=0.15)),
        ("null-heavy", "null", null(25, 50, 3, 5, "linear")),
        ("null-mix", "null", null(2, 8, 40, 120, "k3 -0.3 k5 0.25 x^2 v", k3=-0.3, k5=0.25, cxxv=1.0)),
        ("null-aa", "null", null(0.3, 1.5, 150, 400, "k2 0.1; AA 6-pole 0.4 fs both, 16 bit both",
                                 {"aa_frac": 0.4, "aa_both": True, "aa_order": 6, "bits": 16, "quant_both": True,
                                  "range_x": 2.5}, k2=0.1)),
        ("null-dc", "null", null(1, 5, 20, 60, "k3 0.1; acc DC 1 %", {"dc": 0.01}, k3=0.1)),
        ("null-v3", "null", null(0.1, 0.5, 60, 200, "v^3 2x at top", c3=2.0)),
        ("null-free", "null", null(0.5, 3, 10, 30, "free decays, k3 0.1", free=True, k3=0.1)),
        ("cat-drag", "cat", drag), ("cat-fric", "cat", fric), ("cat-gap", "cat", gap), ("cat-bw", "cat", bw),
        ("cat-hp", "cat", hp),
        ("hid-crack", "hid", crack), ("hid-stop", "hid", stop), ("hid-reid", "hid", reid),
        ("hid-drift", "hid", drift),
        ("chain-clip", "chain", clip), ("chain-gain", "chain", gain), ("chain-rate", "chain", rate),
        ("cat-mode2", "cat", mode2), ("cat-drag-light", "cat", drag_light), ("cat-fric-light", "cat", fric_light),
        ("null-soft", "null", null(10, 40, 8, 20, "k3 -0.1, x^2 v", k3=-0.1, cxxv=0.6)),
        ("chain-double", "chain", double),
        ("chain-aa", "cat", aa_acc), ("noisy-jitter", "noisy", jitter), ("noisy-quant", "noisy", quant),
        ("hum-mains", "hum", hum),
    ]


def make_diag(rng, cid, rule, maker, label, out):
    s, c, expect, hidden, args, free, per = maker(rng)
    case = diag_case(rng, label, out, s, c, rule, expect, hidden, args, free, per)
    case["kind"] = "diagnose"
    case["refusal_ok"] = REFUSAL.get(cid.split("-b")[0] if cid.endswith("-b") else cid, [])
    return case


REFUSAL = {"chain-clip": [r"clip", r"overload", r"flat at its extreme", r"saturat"],
           "chain-rate": [r"sample rate", r"ppm", r"\brates?\b"],
           "chain-gain": [r"impulse", r"sensitiv", r"gain", r"momentum"],
           "chain-double": [r"double", r"second (hit|blow|impact)", r"bounce"]}


# ----------------------------------------------------------------------------- identify + validate
I_CASES = [  # id, masses, freqs, zeta, coefficients, damping terms, stiffness terms, chain, layout
    ("ident-tiny", (0.05, 0.09), (1200, 2000), (0.004, 0.01), {"k3": 0.2}, ["v"], ["x", "x^3"], {}, "si"),
    ("ident-heavy", (25, 50), (3, 6), (0.008, 0.02), {"k3": -0.08}, ["v"], ["x", "x^3"], {}, "si"),
    ("ident-mix", (2, 6), (25, 60), (0.005, 0.01), {"k3": -0.3, "k5": 0.25, "cq": 1.0}, ["v", "abs(v)*v"],
     ["x", "x^3", "x^5"], {}, "si"),
    ("ident-aa16", (0.3, 1.5), (150, 500), (0.005, 0.015), {"k2": 0.12}, ["v"], ["x", "x^2"],
     {"aa_frac": 0.4, "aa_both": True, "aa_order": 6, "bits": 16, "quant_both": True, "range_x": 2.5}, "si"),
    ("ident-eu", (1, 3), (30, 90), (0.005, 0.015), {"k3": 0.15}, ["v"], ["x", "x^3"], {}, "eu"),
    ("ident-offset", (0.5, 4), (40, 120), (0.005, 0.015), {"k3": 0.12}, ["v"], ["x", "x^3"], {"dc": 0.01}, "si"),
]


def make_ident(rng, spec, label, out):
    cid, mr, fr, zr, coef, damping, stiffness, chain_kw, layout = spec
    s = _set(draw_sdof(rng, *mr, *fr, zr), **coef)
    c = {**base_chain(rng), **chain_kw}
    files = {}
    for role, lev in (("fit", 1.0), ("held", 0.6)):
        t, force, acc, _ = one_dof_record(rng, s, lev, c)
        name = f"{label}-{role}.csv"
        write_csv(os.path.join(out, name), {"t": t, "force": force, "acc": acc}, layout)
        files[role] = name
    return {"kind": "ident", "files": files, "given_mass": s["mass"], "truth": _truth(s, damping, stiffness),
            "system": _sys(s), "chain": c, "layout": layout}


# ----------------------------------------------------------------------------- several accelerometers
M_CASES = [  # id, masses, cubic link (x its linear spring at the top relative stroke), driving point, dead,
    # mass range [kg], first spring's frequency range [Hz]
    ("mdof-lin2", 2, 0.0, 1, False, (0.3, 3), (25, 80)), ("mdof-cubic2", 2, 0.5, 1, False, (0.3, 3), (25, 80)),
    ("mdof-lin3", 3, 0.0, 2, False, (0.3, 3), (25, 80)), ("mdof-dead", 2, 0.0, 1, True, (0.3, 3), (25, 80)),
    ("mdof-heavy2", 2, 0.0, 1, False, (8, 40), (6, 15)), ("mdof-cubic3", 3, 0.5, 2, False, (0.2, 2), (30, 90)),
]


def make_mdof(rng, spec, label, out):
    cid, n, cubic, d, dead, mr, fr = spec
    M = np.exp(rng.uniform(np.log(mr[0]), np.log(mr[1]), n))
    f0 = float(rng.uniform(*fr))
    K = M[0] * (2 * np.pi * f0) ** 2 * np.concatenate([[1.0], rng.uniform(0.5, 1.2, n - 1)])
    Kf = np.zeros((n, n))  # the stiffness matrix, for the modes
    Kf[0, 0] += K[0]
    for i in range(1, n):
        Kf[i, i] += K[i]
        Kf[i - 1, i - 1] += K[i]
        Kf[i, i - 1] -= K[i]
        Kf[i - 1, i] -= K[i]
    w = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(np.diag(M), Kf)).real))
    zeta = float(rng.uniform(0.008, 0.015))
    C = 2 * zeta / w[0] * K  # stiffness-proportional: every mode's damping ratio >= zeta
    fs = float(min(r for r in (512, 1024, 2560, 5120, 10240, 12800, 25600) if r >= 25 * w[-1] / (2 * np.pi)))
    dur = min(np.log(300) / (zeta * w[0]), 36000 / fs)
    n_pre = max(100, int(dur * fs) // 20)
    nsamp = int(dur * fs) + n_pre
    t0 = (n_pre - 32) / fs  # the DAQ filter's delay: the blow lands at t = 0
    tau = max(0.1 / (w[-1] / (2 * np.pi)), 5 / fs)
    A = float(np.exp(rng.uniform(np.log(1e-4), np.log(1e-3))))
    P = A * M[d] * w[0] * np.pi / (2 * tau)
    h = 1 / (fs * SUB)
    kc3 = 0.0
    if cubic:
        xs, _, _ = _mdof(M, K, C, 0.0, d, h, nsamp * SUB // 4, P, t0, tau)
        stroke = np.max(np.abs(xs[:, 1] - xs[:, 0]))
        kc3 = cubic * K[1] / stroke ** 2
    snr = float(rng.uniform(46, 56))
    files, noise = [], []
    for i, lev in enumerate((1.0, 0.5, 0.75, 0.85)):
        _, acc, f = _mdof(M, K, C, kc3, d, h, nsamp * SUB, P * lev, t0, tau)
        t = (np.arange(nsamp) - n_pre) / fs
        cols = {"t": t, "force": chain(f, fs * SUB, fs, rng, {"snr_force": 58.0}, np.max(np.abs(f)), False)}
        for j in range(n):
            pk = np.max(np.abs(acc[:, j]))
            cols[f"acc{j + 1}"] = chain(acc[:, j], fs * SUB, fs, rng, {"snr_acc": snr}, pk, True)
        if dead:
            pk = np.max(np.abs(acc[:, 0]))
            cols[f"acc{n + 1}"] = rng.normal(0, 3e-4 * pk, nsamp) + 2e-4 * pk
        name = f"{label}-{i + 1}.csv"
        write_csv(os.path.join(out, name), cols)
        files.append(name)
    return {"kind": "mdof", "files": files[:3], "held": files[3], "driving_point": f"acc{d + 1}",
            "expect": "modal_coupling" if cubic else "none", "dead": f"acc{n + 1}" if dead else None,
            "masses": M.tolist(), "springs": K.tolist(), "cubic_n_per_m3": kc3, "freqs_hz": (w / 2 / np.pi).tolist(),
            "fs": fs, "snr_db": snr, "zeta": zeta}


# ----------------------------------------------------------------------------- bad and odd files
def make_bad(rng, out):
    s = _set(draw_sdof(rng, 0.5, 2, 20, 80), k3=0.0)
    t, force, acc, _ = one_dof_record(rng, s, 1.0, base_chain(rng, (50, 56)))
    m = s["mass"]
    cases = []

    def add(cid, fname, argv, rule="refuse", **kw):
        cases.append({"id": cid, "kind": "bad", "file": fname, "argv": argv, "rule": rule, "mass": m,
                      "k1": s["k1"], **kw})

    def csv_text(rows_acc=None, header="t,force,acc", tcol=None):
        tt = t if tcol is None else tcol
        lines = [header]
        for i in range(len(tt)):
            a = rows_acc(i) if rows_acc else f"{acc[i]:.9g}"
            lines.append(f"{tt[i]:.9g},{force[i]:.9g},{a}")
        return "\n".join(lines) + "\n"

    def put(name, text, mode="w"):
        with open(os.path.join(out, name), mode) as fh:
            fh.write(text)
        return name

    ident = ["identify", None, "--mass", repr(m), "--json"]
    lin = ["--damping", "v", "--stiffness", "x"]
    n0 = int(rng.integers(len(t) // 5, len(t) // 3))
    put("b1.csv", csv_text(lambda i: "nan" if n0 <= i < n0 + 25 else f"{acc[i]:.9g}"))
    add("nan-run", "b1.csv", ident)
    write_h5(os.path.join(out, "b2-full.h5"), t, force, acc, m)
    raw = open(os.path.join(out, "b2-full.h5"), "rb").read()
    put("b2.h5", raw[: int(len(raw) * 0.55)], "wb")
    os.remove(os.path.join(out, "b2-full.h5"))
    add("h5-truncated", "b2.h5", ident)
    put("b3.csv", csv_text(header="Time [s],Force [N],Acceleration [mV]"))
    add("acc-in-millivolts", "b3.csv", ident)
    write_csv(os.path.join(out, "b4.csv"), {"t": t, "force": force, "acc": acc}, "kgf")
    add("force-in-kgf", "b4.csv", ident[:4] + lin + ["--json"], rule="read-or-refuse")
    gap = int(rng.integers(len(t) // 4, len(t) // 2))
    keep = np.r_[0:gap, gap + 37:len(t)]
    put("b5.csv", "t,force,acc\n" + "".join(f"{t[i]:.9g},{force[i]:.9g},{acc[i]:.9g}\n" for i in keep))
    add("dropped-burst", "b5.csv", ident)
    put("b6.csv", "t,force,acc\n")
    add("header-only", "b6.csv", ident)
    ovl = set(int(i) for i in rng.integers(50, len(t) // 3, 3))
    put("b7.csv", csv_text(lambda i: "OVL" if i in ovl else f"{acc[i]:.9g}"))
    add("overload-text", "b7.csv", ident)
    put("b8.h5", csv_text())
    add("csv-named-h5", "b8.h5", ident)
    write_csv(os.path.join(out, "b9.csv"), {"t": t, "force": force, "acc": acc}, "utf16")
    add("utf16", "b9.csv", ident[:4] + lin + ["--json"], rule="read-or-refuse")
    put("b10.csv", csv_text(lambda i: f"{acc[i] / 9.80665:.9g}", header="t [s],force [N],acc [m/s^2]"))
    add("acc-in-g-labelled-si", "b10.csv", ident, rule="refuse-or-warn",
        words=[r"impulse", r"momentum", r"sensitiv", r"calibrat", r"\bin g\b"])
    put("b11.csv", "t,force,acc\n" + "".join(f"{t[i]:.9g},{-force[i]:.9g},{acc[i]:.9g}\n" for i in range(len(t))))
    add("force-polarity-reversed", "b11.csv", ident, rule="refuse-or-warn",
        words=[r"sign", r"polarit", r"invert", r"revers", r"negative", r"opposite"])
    g = 9.80665
    put("b12.txt", "Time\tForce\tAccel\n[s]\t[N]\t[g]\n" + "".join(
        f"{t[i]:.9g}\t{force[i]:.9g}\t{acc[i] / g:.9g}\n".replace(".", ",") for i in range(len(t))))
    add("tab-comma-units-row", "b12.txt", ident[:4] + lin + ["--json"], rule="must-read")
    put("b13.csv", "Acceleration [m/s^2],Time [s],Force [N]\n" + "".join(
        f"{acc[i]:.9g},{t[i]:.9g},{force[i]:.9g}\n" for i in range(len(t))))
    add("columns-reordered", "b13.csv", ident[:4] + lin + ["--json"], rule="must-read")
    put("b14.csv", "Time (ms),Hammer (lbf),Accel (in/s^2)\n" + "".join(
        f"{1e3 * t[i]:.9g},{force[i] / 4.4482216152605:.9g},{acc[i] / 0.0254:.9g}\n" for i in range(len(t))))
    add("imperial-units", "b14.csv", ident[:4] + lin + ["--json"], rule="must-read")
    half = len(t) // 2
    put("b15.csv", "t,force,acc\n" + "".join(f"{t[i]:.9g},{force[i]:.9g},{acc[i]:.9g}\n" for i in range(half))
        + "t,force,acc\n" + "".join(f"{t[i]:.9g},{force[i]:.9g},{acc[i]:.9g}\n" for i in range(half)))
    add("second-block-appended", "b15.csv", ident)
    put("b16.csv", "t,force,acc,\n" + "".join(f"{t[i]:.9g},{force[i]:.9g},{acc[i]:.9g},\n" for i in range(len(t))))
    add("trailing-delimiters", "b16.csv", ident[:4] + lin + ["--json"], rule="read-or-refuse")
    for c in cases:
        c["argv"] = [c["file"] if a is None else a for a in c["argv"]]
    return cases


# ----------------------------------------------------------------------------- main
def rng_for(seed, cid):
    return np.random.default_rng([seed, zlib.crc32(cid.encode())])


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="folder to write (created)")
    p.add_argument("--seed", type=int, required=True, help="every draw follows from it and the case id")
    p.add_argument("--quick", action="store_true", help="the quick set (every case; the full set adds a "
                   "second draw of each diagnose case)")
    a = p.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    t0 = time.time()
    cases = []
    reps = (0,) if a.quick else (0, 1)
    diag = [(f"{cid}{'' if r == 0 else '-b'}", rule, mk) for r in reps for cid, rule, mk in d_cases()]
    for i, (cid, rule, mk) in enumerate(diag):
        c = make_diag(rng_for(a.seed, cid), cid, rule, mk, f"d{i + 1}", a.out)
        cases.append({"id": cid, "label": f"D{i + 1}", **c})
        print(f"[{time.time() - t0:5.1f} s] D{i + 1}", file=sys.stderr, flush=True)
    for i, spec in enumerate(I_CASES):
        cases.append({"id": spec[0], "label": f"I{i + 1}", **make_ident(rng_for(a.seed, spec[0]), spec,
                                                                       f"i{i + 1}", a.out)})
    for i, spec in enumerate(M_CASES):
        cases.append({"id": spec[0], "label": f"M{i + 1}", **make_mdof(rng_for(a.seed, spec[0]), spec,
                                                                      f"m{i + 1}", a.out)})
        print(f"[{time.time() - t0:5.1f} s] M{i + 1}", file=sys.stderr, flush=True)
    for i, c in enumerate(make_bad(rng_for(a.seed, "bad"), a.out)):
        cases.append({**c, "label": f"B{i + 1}"})
    with open(os.path.join(a.out, "manifest.json"), "w") as fh:
        json.dump({"seed": a.seed, "quick": a.quick, "cases": cases}, fh, indent=1, default=_json)
    print(f"wrote {len(cases)} cases to {a.out} in {time.time() - t0:.0f} s", file=sys.stderr)
    return 0


def _json(o):
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(type(o))


if __name__ == "__main__":
    sys.exit(main())
