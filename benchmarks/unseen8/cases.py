"""The case kinds of the eighth scorecard; every number is drawn per seed (``draw.py``).

``CASES``: (id, manifest section, maker, in the quick set). A maker writes its records into the data
folder and returns the case's manifest entry (the truth the scorer judges against). The kinds differ from
unseen7's: nulls at the edges of scale, rate, noise and sensor; catalogued mechanisms at moderate strength;
three mechanisms outside the catalogue; multi-DOF chains (acc only, no mass given).
"""

from __future__ import annotations

import os

import numpy as np

import draw
import formats
import physics

FORMATS = ["csv-si", "csv-export", "uff58", "mat"]


def _captures(rng, cid, out, sysd, n, sensor="acc", chain=None, fmt=None, levels=None, system_fn=None,
              snr=(32.0, 58.0), max_samples=90000):
    """n captures of one single-DOF (or hidden second-mode) system; returns (files, meta)."""
    fs = draw.pick_rate(rng, sysd.get("f_top", sysd["fn_hz"]))
    pre, post = draw.timing(rng, sysd["fn_hz"], sysd["zeta"], fs, max_samples=max_samples)
    fmt = fmt or FORMATS[rng.integers(len(FORMATS))]
    levels = levels or list(rng.uniform(0.45, 1.0, n))
    tip = None
    files, meta = [], []
    for c, s in enumerate(draw.sessions(rng, n, snr=snr)):
        s.update(chain or {})
        system = system_fn(c) if system_fn else physics.System([sysd["mass"]] + sysd.get("extra_masses", []),
                                                              sysd["laws"])
        p, tip = draw.hammer(rng, sysd, sysd["fn_hz"], levels[c], tip=tip, fs=fs)
        t, ch = draw.record(rng, system, [p], fs, pre, post, s, sensor=sensor)
        if len(ch) > 2:  # a hidden second mass: only the first mass is measured
            ch = {"force": ch["force"], sensor: ch[sensor]}
        name = os.path.basename(formats.write(os.path.join(out, f"{cid}-{c}"), fmt, t, ch, rng))
        files.append(name)
        meta.append({"level": float(levels[c]), "session": s})
    return files, {"fs": fs, "pre_s": pre, "post_s": post, "fmt": fmt, "tip": tip, "sensor": sensor,
                   "captures": meta}


def _entry(files, sysd, meta, hidden, expect, **kw):
    return {"files": files, "given_mass": sysd["mass"], "hidden": hidden, "expect": expect, "system": sysd,
            "meta": meta, **kw}


# ----------------------------------------------------------------------------- (a) nulls -> `none`
def null_feather_vel(rng, cid, out):
    """A gram-light, stiff part (0.8-4 g, 150-900 Hz) seen by a laser vibrometer (velocity), high rate."""
    sysd = draw.base_system(rng, "feather", ["hardening", "linear"][rng.integers(2)])
    files, meta = _captures(rng, cid, out, sysd, int(rng.integers(3, 6)), sensor="vel", snr=(40.0, 65.0))
    return _entry(files, sysd, meta, None, ["none"])


def null_heavy_disp(rng, cid, out):
    """A 5-40 t soft-mounted mass (0.8-4 Hz) with a displacement sensor (LVDT), low rate, long records."""
    sysd = draw.base_system(rng, "heavy", ["hardening", "softening"][rng.integers(2)])
    files, meta = _captures(rng, cid, out, sysd, int(rng.integers(3, 6)), sensor="disp", snr=(35.0, 60.0))
    return _entry(files, sysd, meta, None, ["none"])


def null_noisy_short(rng, cid, out):
    """Noisy (25-32 dB) acceleration, three short records (each capped at 3000-8000 samples)."""
    sysd = draw.base_system(rng, None, ["linear", "hardening", "nldamp"][rng.integers(3)])
    files, meta = _captures(rng, cid, out, sysd, 3, snr=(25.0, 32.0), max_samples=int(rng.integers(3000, 8000)))
    return _entry(files, sysd, meta, None, ["none"])


def null_clean_asym(rng, cid, out):
    """Very clean (58-65 dB) quadratic+cubic polynomial spring (in the default library), four captures."""
    sysd = draw.base_system(rng, None, "asym")
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(58.0, 65.0))
    return _entry(files, sysd, meta, None, ["none"])


# ----------------------------------------------------------------------------- (b) catalogued, moderate
def _strength(sysd):
    L = sysd["laws"][0]
    k, c, X = L["k"][1], L["c"][1], sysd["X_ref"]
    return k, c, X, 2 * np.pi * sysd["fn_hz"] * X


def cat_friction(rng, cid, out):
    """Dry friction: fc 0.4-1.2 % of k X_ref (a linear or hardening spring)."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    k, c, X, V = _strength(sysd)
    sysd["laws"].append({"law": "coulomb", "i": 0, "fc": k * X * rng.uniform(0.004, 0.012), "veps": V * 2e-3})
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(38.0, 55.0))
    return _entry(files, sysd, meta, "dry_friction", ["coulomb_friction", "hysteresis"])


def cat_gap(rng, cid, out):
    """A two-sided clearance: contact springs kc 0.3-1 k beyond a gap of 40-70 % of X_ref."""
    sysd = draw.base_system(rng, None, "linear")
    k, c, X, V = _strength(sysd)
    sysd["laws"].append({"law": "gap", "i": 0, "gap": X * rng.uniform(0.4, 0.7), "kc": k * rng.uniform(0.3, 1.0),
                         "cc": 0.0})
    files, meta = _captures(rng, cid, out, sysd, 4, levels=list(rng.uniform(0.6, 1.1, 4)))
    return _entry(files, sysd, meta, "gap", ["clearance", "smooth_stiffening", "asymmetric_stiffness"])


def cat_drag(rng, cid, out):
    """Quadratic drag cq v|v|, at the reference speed 0.5-1.5 x the linear damping force."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    sysd["laws"][0]["cx2v"] = 0.0
    k, c, X, V = _strength(sysd)
    sysd["laws"].append({"law": "drag", "i": 0, "cq": c * V * rng.uniform(0.5, 1.5) / V ** 2})
    files, meta = _captures(rng, cid, out, sysd, 4)
    return _entry(files, sysd, meta, "drag", ["quadratic_damping", "amplitude_damping", "cubic_damping"])


def cat_cubicdamp(rng, cid, out):
    """Cubic damping c3 v^3, at the reference speed 0.5-1.5 x the linear damping force."""
    sysd = draw.base_system(rng, None, "linear")
    sysd["laws"][0]["cx2v"] = 0.0
    k, c, X, V = _strength(sysd)
    sysd["laws"][0]["c"][3] = c * V * rng.uniform(0.5, 1.5) / V ** 3
    files, meta = _captures(rng, cid, out, sysd, 4)
    return _entry(files, sysd, meta, "cubic_damping", ["cubic_damping", "amplitude_damping", "quadratic_damping"])


def cat_asym(rng, cid, out):
    """Asymmetric stiffness: stiffer by 25-50 % on one side (a bilinear spring)."""
    sysd = draw.base_system(rng, None, "linear")
    k, c, X, V = _strength(sysd)
    sysd["laws"].append({"law": "stop", "i": 0, "gap": 0.0, "kc": k * rng.uniform(0.25, 0.5)})
    files, meta = _captures(rng, cid, out, sysd, 4)
    return _entry(files, sysd, meta, "bilinear", ["asymmetric_stiffness", "clearance"])


def cat_secondmode(rng, cid, out):
    """A second mode 2.3-4.5 x the first (a light second mass, 5-15 % of the first, on its own spring); one
    accelerometer on the first mass."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    k, c, X, V = _strength(sysd)
    m2 = sysd["mass"] * rng.uniform(0.05, 0.15)
    r = rng.uniform(2.3, 4.5)
    k2 = m2 * (2 * np.pi * sysd["fn_hz"] * r) ** 2
    c2 = 2 * rng.uniform(0.005, 0.02) * np.sqrt(k2 * m2)
    sysd["extra_masses"] = [m2]
    sysd["laws"].append({"law": "poly", "i": 1, "j": 0, "k": {1: k2}, "c": {1: c2}})
    sysd["f_top"] = sysd["fn_hz"] * r * 1.1
    files, meta = _captures(rng, cid, out, sysd, 4)
    return _entry(files, sysd, meta, "second_mode", ["second_mode"])


def cat_accac(rng, cid, out):
    """An AC-coupled accelerometer (first-order high-pass at 4-12 % of the natural frequency)."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    chain = {"hp_hz": sysd["fn_hz"] * rng.uniform(0.04, 0.12)}
    files, meta = _captures(rng, cid, out, sysd, 4, chain=chain)
    return _entry(files, sysd, meta, "ac_coupled", ["sensor_highpass"], chain=chain)


# ----------------------------------------------------------------------------- (c) outside the catalogue
def hid_parametric(rng, cid, out):
    """A stiffness pumped in time (3-6 % at 0.3-0.7 x the natural frequency, a rotating part nearby)."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    k, c, X, V = _strength(sysd)
    sysd["laws"].append({"law": "parametric", "i": 0, "k": k, "eps": rng.uniform(0.03, 0.06),
                         "f_hz": sysd["fn_hz"] * rng.uniform(0.3, 0.7), "phase": rng.uniform(0, 2 * np.pi)})
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(40.0, 58.0))
    return _entry(files, sysd, meta, "pumped", ["unexplained"])


def hid_tone(rng, cid, out):
    """An unmeasured harmonic force (a machine on the floor) at 1.3-2.2 x the natural frequency, its response
    6-12 % of the free response's peak."""
    sysd = draw.base_system(rng, None, ["linear", "softening"][rng.integers(2)])
    k, c, X, V = _strength(sysd)
    r = rng.uniform(1.3, 2.2)
    amp = k * X * abs(1 - r * r) * rng.uniform(0.06, 0.12)
    sysd["laws"].append({"law": "tone", "i": 0, "amp": amp, "f_hz": sysd["fn_hz"] * r,
                         "phase": rng.uniform(0, 2 * np.pi)})
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(40.0, 58.0))
    return _entry(files, sysd, meta, "tone", ["unexplained"])


def cat_dirstiff(rng, cid, out):
    """A spring 5-12 % stiffer while it moves one way than the other (a force k (1 + eps tanh(v / veps)) x:
    a rate-independent loop, structural damping). Its catalogue name is hysteresis."""
    sysd = draw.base_system(rng, None, "linear")
    k, c, X, V = _strength(sysd)
    sysd["laws"].append({"law": "bilin", "i": 0, "k": k, "eps": rng.uniform(0.05, 0.12), "veps": V * 0.02})
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(40.0, 58.0))
    return _entry(files, sysd, meta, "dirstiff", ["hysteresis"])


# ----------------------------------------------------------------------------- (d) multi-DOF
def _chain_K(ks):
    n = len(ks)
    K = np.zeros((n, n))
    for i, kv in enumerate(ks):
        K[i, i] += kv
        if i > 0:
            K[i - 1, i - 1] += kv
            K[i, i - 1] -= kv
            K[i - 1, i] -= kv
    return K


def _coupling_effect(ms, laws, drive, p, fs, pre, post, names):
    """Per channel, the nrmse between the held blow's clean acceleration with the nonlinear spring and with its
    cubic term removed (the sink: replaced by the linear spring tuned to its pilot stretch): how far the
    coupling moves the record, against which the judge weighs a `none`."""
    lin = [dict(L, k={q: v for q, v in L["k"].items() if int(q) == 1}) for L in laws]
    if not lin[-1]["k"]:  # the sink: a linear spring tuned to the host's first mode
        f1 = physics.linear_freqs(ms[:-1], _chain_K([L["k"][1] for L in laws[:-1]]))[0]
        lin[-1]["k"] = {1: ms[-1] * (2 * np.pi * f1) ** 2}
    t = np.arange(0, int(post * fs)) / fs
    pulse = [tuple(p[:3]) + (tuple(p[3]),)]
    a_nl = physics.simulate(physics.System(ms, laws, drive=drive), pulse, t)[2]
    a_li = physics.simulate(physics.System(ms, lin, drive=drive), pulse, t)[2]
    after = t > 2 * p[1]
    return {n: float(np.sqrt(np.mean((a_nl[i, after] - a_li[i, after]) ** 2) / np.mean(a_nl[i, after] ** 2)))
            for i, n in enumerate(names)}


def mdof_case(n_mass, coupling, ratio=None, nes=False):
    """A chain of ``n_mass`` masses to the ground; ``coupling``: a cubic spring on the last link at 15-40 % of
    its linear force at the level-1 stretch; ``ratio``: the two modes near that ratio; ``nes``: the last mass
    5 % of the first on a purely cubic spring (no linear stiffness)."""
    def make(rng, cid, out):
        for _ in range(400):
            scale = ["grams", "kilograms", "tonnes"][rng.integers(3)]
            (m0, m1), (f0, f1), (x0, x1) = draw.SCALES[scale]
            ms = [draw.loguni(rng, m0, m1)]
            ms += [ms[-1] * draw.loguni(rng, 0.4, 1.5) for _ in range(n_mass - 1)]
            f_target = draw.loguni(rng, f0, f1)
            ks = [ms[0] * (2 * np.pi * f_target) ** 2 * draw.loguni(rng, 0.4, 2.5) for _ in range(n_mass)]
            if nes:
                ms[-1] = ms[0] * 0.05
                fr = physics.linear_freqs(ms[:-1], _chain_K(ks[:-1]))
                break
            fr = physics.linear_freqs(ms, _chain_K(ks))
            rs = [fr[i + 1] / fr[i] for i in range(n_mass - 1)]
            if ratio:
                if abs(fr[1] / fr[0] - ratio) < 0.12:
                    break
            elif min(rs) > 1.35 and all(abs(r - q) > 0.12 for r in rs for q in (2.0, 3.0)):
                break
        else:
            raise RuntimeError("no chain drawn")
        X = draw.loguni(rng, x0, x1)
        zeta = draw.loguni(rng, 0.005, 0.02)
        laws = [{"law": "poly", "i": i, "j": i - 1, "k": {1: kv}, "c": {1: 2 * zeta * np.sqrt(kv * ms[i])}}
                for i, kv in enumerate(ks)]
        drive = 0 if nes else int(rng.integers(n_mass))
        if nes:
            laws[-1]["k"] = {}
            laws[-1]["c"] = {1: 2 * 0.02 * ms[-1] * 2 * np.pi * fr[0]}
        system = physics.System(ms, laws, drive=drive)
        f_hi = max(fr) * (1.5 if nes else 1.0)
        fs = draw.pick_rate(rng, f_hi)
        sysd = {"mass": ms[drive], "fn_hz": fr[0], "X_ref": X}
        p, _ = draw.hammer(rng, sysd, f_hi, 1.0, width_frac=0.1, tip="plastic", fs=fs)
        tp = np.arange(0, int(6 / fr[0] * fs)) / fs
        if coupling or nes:
            pilot = [dict(L) for L in laws]
            if nes:  # the pilot's sink: a linear spring tuned to the first mode
                pilot[-1] = dict(laws[-1], k={1: ms[-1] * (2 * np.pi * fr[0]) ** 2})
            xp = physics.simulate(physics.System(ms, pilot, drive=drive), [tuple(p[:3]) + (tuple(p[3]),)], tp)[0]
            stretch = float(np.abs(xp[-1] - xp[-2]).max())
            if nes:  # the sink's cubic spring as stiff at the pilot stretch as the tuned linear one
                laws[-1]["k"] = {3: ms[-1] * (2 * np.pi * fr[0]) ** 2 / stretch ** 2 * rng.uniform(0.7, 1.5)}
            else:
                laws[-1]["k"] = {1: ks[-1], 3: ks[-1] * rng.uniform(0.15, 0.4) / stretch ** 2}
            system = physics.System(ms, laws, drive=drive)
        labels = list(rng.choice(["deck", "frame", "motor", "plate", "cab", "boom", "arm"], n_mass, replace=False))
        names = [f"acc_{lab}" for lab in labels]
        pre, post = draw.timing(rng, fr[0], zeta, fs, max_samples=30000)
        files, tip, noise = [], None, []
        levels = list(rng.uniform(0.5, 1.0, 4))
        fmt = ["csv-si", "csv-export"][rng.integers(2)]
        for c, s in enumerate(draw.sessions(rng, 4, snr=(40.0, 55.0))):
            s["names"] = names
            p, tip = draw.hammer(rng, sysd, f_hi, levels[c], width_frac=rng.uniform(0.05, 0.15), tip=tip, fs=fs)
            t, ch = draw.record(rng, system, [p], fs, pre, post, s)
            noise.append(s["noise_nrmse_ch"])
            path = formats.write(os.path.join(out, f"{cid}-{c}"), fmt, t, ch, rng)
            files.append(os.path.basename(path))
        effect = _coupling_effect(ms, laws, drive, p, fs, pre, post, names) if (coupling or nes) else {}
        return {"files": {"train": files[:3], "held": files[3]}, "driving_point": names[drive], "columns": names,
                "coupling_effect_nrmse": effect,
                "freqs_hz": fr, "masses": ms, "laws": laws, "fs": fs, "coupling": bool(coupling or nes),
                "noise_nrmse": noise, "nes": nes}
    return make


CASES = [
    ("null-feather-vel", "diagnose", null_feather_vel, True),
    ("null-heavy-disp", "diagnose", null_heavy_disp, True),
    ("null-noisy-short", "diagnose", null_noisy_short, True),
    ("null-clean-asym", "diagnose", null_clean_asym, True),
    ("cat-friction", "diagnose", cat_friction, True),
    ("cat-gap", "diagnose", cat_gap, True),
    ("cat-drag", "diagnose", cat_drag, True),
    ("cat-cubicdamp", "diagnose", cat_cubicdamp, True),
    ("cat-asym", "diagnose", cat_asym, True),
    ("cat-secondmode", "diagnose", cat_secondmode, True),
    ("cat-accac", "diagnose", cat_accac, True),
    ("hid-parametric", "diagnose", hid_parametric, True),
    ("hid-tone", "diagnose", hid_tone, True),
    ("cat-dirstiff", "diagnose", cat_dirstiff, True),
    ("mdof-2lin", "mdof", mdof_case(2, False), True),
    ("mdof-2cubic", "mdof", mdof_case(2, True), False),
    ("mdof-3cubic", "mdof", mdof_case(3, True), True),
    ("mdof-3lin", "mdof", mdof_case(3, False), False),
    ("mdof-nes", "mdof", mdof_case(2, False, nes=True), False),
    ("mdof-1to3", "mdof", mdof_case(2, True, ratio=3.0), True),
]
