"""The case kinds of the sixth scorecard; every number is drawn per seed (``draw.py``).

``CASES``: (id, manifest section, maker, in the quick set). A maker writes its records into the data
folder and returns the case's manifest entry (the truth the scorer judges against).
"""

from __future__ import annotations

import os

import numpy as np

import draw
import formats
import physics

FORMATS = ["csv-si", "csv-export", "uff58", "mat"]


def _write(rng, out, base, t, chans, fmt=None):
    fmt = fmt or FORMATS[rng.integers(len(FORMATS))]
    path = formats.write(os.path.join(out, base), fmt, t, chans, rng)
    return os.path.basename(path), fmt


def _captures(rng, cid, out, sysd, n, sensor="acc", chain=None, extra_pulse=False, fmt=None, y0_fn=None,
              levels=None):
    """n captures of one single-DOF system over two sessions; returns (files, fmt, meta)."""
    system = physics.System([sysd["mass"]], sysd["laws"])
    fs = draw.pick_rate(rng, sysd["fn_hz"])
    pre, post = draw.timing(rng, sysd["fn_hz"], sysd["zeta"], fs)
    fmt = fmt or FORMATS[rng.integers(len(FORMATS))]
    levels = levels or list(rng.uniform(0.45, 1.0, n))
    tip = None
    files, meta = [], []
    for c, s in enumerate(draw.sessions(rng, n)):
        s.update(chain or {})
        p, tip = draw.hammer(rng, sysd, sysd["fn_hz"], levels[c], tip=tip, fs=fs)
        pulses = [p]
        if extra_pulse:  # the hammer bounces: a second, weaker hit a few pulse widths later
            p2 = list(p)
            p2[0] = p[1] * rng.uniform(1.5, 4.0)
            p2[2] = p[2] * rng.uniform(0.15, 0.4)
            pulses.append(p2)
        y0 = y0_fn(-pre) if y0_fn else None
        t, ch = draw.record(rng, system, pulses, fs, pre, post, s, sensor=sensor, y0=y0)
        name, _ = _write(rng, out, f"{cid}-{c}", t, ch, fmt)
        files.append(name)
        meta.append({"level": float(levels[c]), "session": s})
    return files, {"fs": fs, "pre_s": pre, "post_s": post, "fmt": fmt, "tip": tip, "sensor": sensor,
                   "captures": meta}


def null_case(kind, sensor="acc", double_hit=False, scale=None):
    def make(rng, cid, out):
        sysd = draw.base_system(rng, scale, kind)
        files, meta = _captures(rng, cid, out, sysd, 5, sensor=sensor, extra_pulse=double_hit)
        return {"files": files, "given_mass": sysd["mass"], "hidden": None, "expect": ["none"],
                "system": sysd, "meta": meta}
    return make


def effect_case(effect, scale=None):
    """A hidden effect: catalogued (its name expected, ``unexplained`` abstains) or not (``unexplained``)."""
    def make(rng, cid, out):
        sysd = draw.base_system(rng, scale, ["hardening", "linear", "softening"][rng.integers(3)]
                                if effect not in ("sensor_highpass",) else "linear")
        k, m, fn, X = sysd["laws"][0]["k"][1], sysd["mass"], sysd["fn_hz"], sysd["X_ref"]
        chain, y0_fn, expect, sensor, refusal_ok = {}, None, [effect], "acc", None
        if effect == "coulomb_friction":
            fc = k * X * rng.uniform(0.008, 0.025)
            sysd["laws"].append({"law": "coulomb", "i": 0, "fc": fc, "veps": 2e-4 * 2 * np.pi * fn * X})
        elif effect == "clearance":
            sysd["laws"].append({"law": "gap", "i": 0, "gap": X * rng.uniform(0.35, 0.6),
                                 "kc": k * rng.uniform(1.0, 3.0), "cc": 0.0})
        elif effect == "quadratic_damping":
            c = sysd["laws"][0]["c"][1]
            sysd["laws"].append({"law": "drag", "i": 0, "cq": c * rng.uniform(1.0, 3.0) / (2 * np.pi * fn * X)})
        elif effect == "sensor_highpass":
            chain["hp_hz"] = float(np.clip(fn * rng.uniform(0.05, 0.15), 0.1, 5.0))
        elif effect == "parametric":
            sysd["laws"].append({"law": "parametric", "i": 0, "k": k, "eps": rng.uniform(0.06, 0.14),
                                 "f_hz": fn * rng.uniform(0.13, 0.37), "phase": rng.uniform(0, 2 * np.pi)})
            expect = ["unexplained"]
        elif effect == "tone":
            ratio = rng.uniform(0.35, 0.65) * rng.choice([1, 2.6])
            om = 2 * np.pi * fn * ratio
            c = sysd["laws"][0]["c"][1]
            Xb = X * rng.uniform(0.05, 0.1)
            amp = Xb * np.hypot(k - m * om ** 2, c * om)
            ph = rng.uniform(0, 2 * np.pi)
            dl = np.arctan2(c * om, k - m * om ** 2)
            sysd["laws"].append({"law": "tone", "i": 0, "amp": amp, "f_hz": om / 2 / np.pi, "phase": ph})
            y0_fn = lambda t0: [Xb * np.sin(om * t0 + ph - dl), Xb * om * np.cos(om * t0 + ph - dl)]  # noqa: E731
            expect = ["unexplained"]
        elif effect == "clipped":
            chain["clip_frac"] = rng.uniform(0.55, 0.8)
            expect = ["unexplained"]
            refusal_ok = "clip"  # detecting the overload and refusing in one line is an honest answer
        files, meta = _captures(rng, cid, out, sysd, 4, sensor=sensor, chain=chain, y0_fn=y0_fn)
        return {"files": files, "given_mass": m, "hidden": effect, "expect": expect, "system": sysd,
                "meta": meta, "refusal_ok": refusal_ok}
    return make


def ident_case(sensor, fmt, clip=False):
    def make(rng, cid, out):
        sysd = draw.base_system(rng, None, ["hardening", "softening", "nldamp"][rng.integers(3)])
        damp, stiff = draw.truth_terms(sysd)
        chain = {"gain": 1.0, "ppm": 0.0}
        if clip:
            chain["clip_frac"] = rng.uniform(0.6, 0.85)
        files, meta = _captures(rng, cid, out, sysd, 2, sensor=sensor, chain=chain, fmt=fmt,
                                levels=[1.0, float(rng.uniform(0.55, 0.75))])
        return {"files": {"fit": files[0], "held": files[1]}, "truth": {"mass": sysd["mass"], "damping": damp,
                "stiffness": stiff}, "ppm": [0.0], "system": sysd, "meta": meta, "refusal_ok": "clip" if clip else None}
    return make


def campaign_case(rng, cid, out):
    sysd = draw.base_system(rng, None, "hardening")
    damp, stiff = draw.truth_terms(sysd)
    folder = os.path.join(out, cid)
    os.makedirs(folder, exist_ok=True)
    files, meta = _captures(rng, os.path.join(cid, "run"), out, sysd, 4, chain={"gain": 1.0, "ppm": 0.0},
                            fmt="csv-si" if rng.random() < 0.5 else "uff58")
    with open(os.path.join(folder, "run-broken.csv"), "w") as fh:  # a logger that died mid-write
        fh.write("t,force,acc\n0,0,0\n0.001,nan,0.5\n0.002,1.0\n")
    return {"folder": cid, "files": files, "broken": "run-broken.csv", "truth": {"mass": sysd["mass"],
            "damping": damp, "stiffness": stiff}, "system": sysd, "meta": meta}


def mdof_case(n_mass):
    def make(rng, cid, out):
        for _ in range(200):
            scale = ["grams", "kilograms", "tonnes"][rng.integers(3)]
            (m0, m1), (f0, f1), (x0, x1) = draw.SCALES[scale]
            ms = [draw.loguni(rng, m0, m1)]
            ms += [ms[0] * draw.loguni(rng, 0.3, 1.5) for _ in range(n_mass - 1)]
            f_target = draw.loguni(rng, f0, f1)
            ks = [ms[0] * (2 * np.pi * f_target) ** 2 * draw.loguni(rng, 0.5, 2.0) for _ in range(n_mass)]
            K = _chain_K(ks)
            fr = physics.linear_freqs(ms, K)
            ratios = [fr[i + 1] / fr[i] for i in range(n_mass - 1)] + [fr[-1] / fr[0]]
            if min(ratios[:-1]) > 1.35 and all(abs(r - q) > 0.12 for r in ratios for q in (2.0, 3.0)):
                break
        X = draw.loguni(rng, x0, x1)
        zeta = draw.loguni(rng, 0.005, 0.02)
        laws = [{"law": "poly", "i": i, "j": i - 1, "k": {1: kv}, "c": {1: 2 * zeta * np.sqrt(kv * ms[i])}}
                for i, kv in enumerate(ks)]
        drive = int(rng.integers(n_mass))
        system = physics.System(ms, laws, drive=drive)
        fs = draw.pick_rate(rng, fr[-1])
        sysd = {"mass": ms[drive], "fn_hz": fr[0], "X_ref": X}
        # a linear pilot at level 1 measures the coupling spring's stretch; the cubic part is then set to
        # 15-40 % of the linear force at that stretch (a nonlinearity the records can resolve)
        p, _ = draw.hammer(rng, sysd, fr[-1], 1.0, width_frac=0.1, tip="plastic", fs=fs)
        tp = np.arange(0, int(6 / fr[0] * fs)) / fs
        xp = physics.simulate(system, [tuple(p[:3]) + (tuple(p[3]),)], tp)[0]
        stretch = float(np.abs(xp[1] - xp[0]).max())
        laws[1]["k"][3] = ks[1] * rng.uniform(0.15, 0.4) / stretch ** 2
        system = physics.System(ms, laws, drive=drive)
        labels = list(rng.choice(["base", "mid", "top", "left", "right", "hub", "tip", "arm"], n_mass, replace=False))
        names = [f"acc_{lab}" for lab in labels]
        pre, post = draw.timing(rng, fr[0], zeta, fs, max_samples=40000)
        files = []
        levels = list(rng.uniform(0.5, 1.0, 4))
        tip = None
        order = ["force"] + [names[i] for i in rng.permutation(n_mass)]  # one logger layout per case
        for c, s in enumerate(draw.sessions(rng, 4, snr=(40.0, 55.0))):
            s["names"] = names
            p, tip = draw.hammer(rng, sysd, fr[-1], levels[c], width_frac=rng.uniform(0.05, 0.15), tip=tip, fs=fs)
            t, ch = draw.record(rng, system, [p], fs, pre, post, s)
            name, _ = _write(rng, out, f"{cid}-{c}", t, {k: ch[k] for k in order}, "csv-export"
                             if rng.random() < 0.5 else "csv-si")
            files.append(name)
        return {"files": {"train": files[:3], "held": files[3]}, "driving_point": names[drive],
                "columns": names, "freqs_hz": fr, "masses": ms, "laws": laws, "fs": fs,
                "pilot_stretch_m": stretch}
    return make


def _chain_K(ks):
    n = len(ks)
    K = np.zeros((n, n))
    for i, kv in enumerate(ks):
        K[i, i] += kv
        if i > 0:
            K[i - 1, i - 1] += kv
            K[i - 1, i] -= kv
            K[i, i - 1] -= kv
    return K


CASES = [
    ("null-hard", "diagnose", null_case("hardening", "acc"), True),
    ("null-soft-vel", "diagnose", null_case("softening", "vel"), True),
    ("null-doublehit", "diagnose", null_case("hardening", "acc", double_hit=True), True),
    ("null-asym-disp", "diagnose", null_case("asym", "disp"), False),
    ("null-tonnes", "diagnose", null_case("nldamp", "acc", scale="tonnes"), True),
    ("cat-friction", "diagnose", effect_case("coulomb_friction"), True),
    ("cat-iepe", "diagnose", effect_case("sensor_highpass", scale="tonnes"), True),
    ("cat-gap", "diagnose", effect_case("clearance"), True),
    ("cat-drag", "diagnose", effect_case("quadratic_damping"), False),
    ("hid-parametric", "diagnose", effect_case("parametric"), True),
    ("hid-tone", "diagnose", effect_case("tone"), True),
    ("hid-clipped", "diagnose", effect_case("clipped"), True),
    ("id-vel", "ident", ident_case("vel", "csv-export"), True),
    ("id-disp", "ident", ident_case("disp", "uff58"), True),
    ("id-mat", "ident", ident_case("acc", "mat"), True),
    ("id-clip", "ident", ident_case("acc", "csv-si", clip=True), False),
    ("camp", "campaign", campaign_case, True),
    ("mdof-2", "mdof", mdof_case(2), True),
    ("mdof-3", "mdof", mdof_case(3), False),
]
