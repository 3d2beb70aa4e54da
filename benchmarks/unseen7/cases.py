"""The case kinds of the seventh scorecard; every number is drawn per seed (``draw.py``).

``CASES``: (id, manifest section, maker, in the quick set). A maker writes its records into the data
folder and returns the case's manifest entry (the truth the scorer judges against). The kinds are new
against unseen5 and unseen6: mains hum, a 12-bit converter set for a bigger blow, the station's own
HDF5 session as the lab's archive, a mass that leaks between captures, a one-sided preloaded stop,
velocity-squared damping with a dead band, an inverted accelerometer, a DC offset step, g written under
an SI header, a clipped force channel, a dropped block, rounded time stamps, a units row, a campaign
whose stiffness drifts with temperature, a multi-DOF export with the force column last.
"""

from __future__ import annotations

import os

import numpy as np

import draw
import formats
import physics

FORMATS = ["csv-si", "csv-export", "uff58", "mat"]
G = formats.G


def _captures(rng, cid, out, sysd, n, sensor="acc", chain=None, fmt=None, levels=None, system_fn=None,
              post_fn=None, chain_fn=None):
    """n captures of one single-DOF system over two sessions; returns (files, meta).

    ``system_fn(c)``: the system of capture c (default: ``sysd``'s); ``chain_fn(c)``: chain options of
    capture c on top of ``chain``; ``post_fn(c, t, ch)``: edits the sampled record before it is written."""
    fs = draw.pick_rate(rng, sysd["fn_hz"])
    pre, post = draw.timing(rng, sysd["fn_hz"], sysd["zeta"], fs)
    fmt = fmt or FORMATS[rng.integers(len(FORMATS))]
    levels = levels or list(rng.uniform(0.45, 1.0, n))
    tip = None
    files, meta = [], []
    for c, s in enumerate(draw.sessions(rng, n)):
        s.update(chain or {})
        s.update(chain_fn(c) if chain_fn else {})
        system = system_fn(c) if system_fn else physics.System([sysd["mass"]], sysd["laws"])
        p, tip = draw.hammer(rng, sysd, sysd["fn_hz"], levels[c], tip=tip, fs=fs)
        t, ch = draw.record(rng, system, [p], fs, pre, post, s, sensor=sensor)
        if post_fn:
            t, ch = post_fn(c, t, ch)
        f_c = FORMATS[rng.integers(len(FORMATS))] if fmt == "mixed" else fmt
        name = os.path.basename(formats.write(os.path.join(out, f"{cid}-{c}"), f_c, t, ch, rng))
        files.append(name)
        meta.append({"level": float(levels[c]), "session": s})
    return files, {"fs": fs, "pre_s": pre, "post_s": post, "fmt": fmt, "tip": tip, "sensor": sensor,
                   "captures": meta}


# ----------------------------------------------------------------------------- (a) nulls -> `none`
def null_hum(rng, cid, out):
    """Mains pickup on the accelerometer cable: 50 or 60 Hz and its third harmonic, 38-46 dB below the
    free response's peak, in every sample (the pre-trigger shows it)."""
    sysd = draw.base_system(rng, None, ["hardening", "softening", "nldamp"][rng.integers(3)])
    chain = {"hum_db": rng.uniform(38, 46), "hum_hz": float(rng.choice([50.0, 60.0])), "bits": 24}
    files, meta = _captures(rng, cid, out, sysd, 5, chain=chain)
    return {"files": files, "given_mass": sysd["mass"], "hidden": None, "expect": ["none"], "system": sysd,
            "meta": meta, "chain": chain}


def null_adc12(rng, cid, out):
    """A 12-bit converter (full scale 1.5-3 x the record's peak, the blow's spike included), so the ring-down
    ends a few LSB tall and slow extremes sit on one code for several samples; otherwise clean (white noise
    62-70 dB down)."""
    sysd = draw.base_system(rng, ["kilograms", "tonnes"][rng.integers(2)], ["hardening", "linear"][rng.integers(2)])
    chain = {"bits": 12, "range_x": (1.5, 3.0), "snr_db": float(rng.uniform(62, 70))}
    files, meta = _captures(rng, cid, out, sysd, 5, chain=chain, fmt="csv-si")
    return {"files": files, "given_mass": sysd["mass"], "hidden": None, "expect": ["none"], "system": sysd,
            "meta": meta, "chain": chain}


def null_h5session(rng, cid, out):
    """Softening-then-stiffening spring (x^3 < 0, x^5 > 0, both in the default library); the lab keeps its
    records in the station's own HDF5: `station import` (with --mass) first, then diagnose the session's
    captures without --mass (the mass comes from the file)."""
    sysd = draw.base_system(rng, None, "softstiff")
    files, meta = _captures(rng, cid, out, sysd, 5, fmt="csv-export")
    h5 = f"{cid}-session.h5"
    return {"files": [f"{h5}:{i}" for i in range(len(files))], "given_mass": None, "hidden": None,
            "expect": ["none"], "system": sysd, "meta": meta,
            "setup": [["import", *files, "--out", h5, "--mass", repr(sysd["mass"])]], "cleanup": [h5]}


def null_mixed(rng, cid, out):
    """One system, five captures saved by different tools of the lab (the station's CSV, a logger export in
    g / mm/s^2 and kN with a decimal comma, UFF58, MATLAB): the units must agree across files."""
    sysd = draw.base_system(rng, None, ["hardening", "asym", "nldamp"][rng.integers(3)])
    files, meta = _captures(rng, cid, out, sysd, 5, fmt="mixed")
    return {"files": files, "given_mass": sysd["mass"], "hidden": None, "expect": ["none"], "system": sysd,
            "meta": meta}


# ----------------------------------------------------------------------------- (b)/(c) hidden effects
def hid_massleak(rng, cid, out):
    """A container that leaks (sand, fluid): each capture's moving mass 1-2.5 % lighter than the one before;
    the mass given is the first capture's (weighed at the start). Out of the catalogue."""
    sysd = draw.base_system(rng, None, ["hardening", "linear", "softening"][rng.integers(3)])
    drop = rng.uniform(0.01, 0.025)
    masses = [sysd["mass"] * (1 - drop) ** c for c in range(5)]
    files, meta = _captures(rng, cid, out, sysd, 5, system_fn=lambda c: physics.System([masses[c]], sysd["laws"]))
    return {"files": files, "given_mass": sysd["mass"], "hidden": "mass_leak", "expect": ["unexplained"],
            "system": sysd, "meta": meta, "masses": masses}


def cat_stop(rng, cid, out):
    """A preloaded bumper on one side: a spring ``kc (x - gap)`` for x > gap only (gap 30-60 % of the
    reference amplitude, kc 0.8-2.5 k). Either of the catalogue's names for a stiffness that changes with the
    sign or beyond a gap is right."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    k, X = sysd["laws"][0]["k"][1], sysd["X_ref"]
    sysd["laws"].append({"law": "stop", "i": 0, "gap": X * rng.uniform(0.3, 0.6), "kc": k * rng.uniform(0.8, 2.5)})
    files, meta = _captures(rng, cid, out, sysd, 4, levels=list(rng.uniform(0.6, 1.1, 4)))
    return {"files": files, "given_mass": sysd["mass"], "hidden": "one_sided_stop",
            "expect": ["clearance", "asymmetric_stiffness"], "system": sysd, "meta": meta}


def cat_dbdrag(rng, cid, out):
    """A fluid damper whose valve opens above a speed: ``cq sign(v) max(|v| - vdb, 0)^2``, vdb 15-35 % of the
    reference speed, cq so that at the reference speed it is 1-3 x the linear damping force. Any of the
    catalogue's names for damping that grows faster than linearly with speed is right."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    sysd["laws"][0]["cx2v"] = 0.0
    c, fn, X = sysd["laws"][0]["c"][1], sysd["fn_hz"], sysd["X_ref"]
    V = 2 * np.pi * fn * X
    vdb = V * rng.uniform(0.15, 0.35)
    cq = c * V * rng.uniform(1.0, 3.0) / (V - vdb) ** 2
    sysd["laws"].append({"law": "dbdrag", "i": 0, "cq": cq, "vdb": vdb})
    files, meta = _captures(rng, cid, out, sysd, 4, levels=list(rng.uniform(0.5, 1.1, 4)))
    return {"files": files, "given_mass": sysd["mass"], "hidden": "deadband_drag",
            "expect": ["quadratic_damping", "amplitude_damping", "cubic_damping"], "system": sysd, "meta": meta}


# ----------------------------------------------------------------------------- (d) identification
def _drop_block(c, t, ch, rng):
    """The fit capture (c == 0) loses one USB block of 256-1024 samples in the free response (the time
    column jumps)."""
    if c != 0:
        return t, ch
    n = int(rng.choice([256, 512, 1024]))
    i0 = int(np.searchsorted(t, 0.0)) + int(rng.uniform(0.15, 0.4) * (len(t) - np.searchsorted(t, 0.0)))
    n = min(n, (len(t) - i0) // 3)
    keep = np.r_[0:i0, i0 + n:len(t)]
    return t[keep], {k: v[keep] for k, v in ch.items()}


def ident_case(defect):
    """Identification with the true terms on the level-1 blow, validation on a 55-75 % blow.

    ``warn_words``: regular expressions (searched in the lower-cased text); when the coefficients miss, a
    warning that matches one passes (`warned`); ``refusal_ok``: a refusal in one line (exit 2) that matches
    one passes (`refused-detected`). They name the defect, not just the record's time or samples."""
    def make(rng, cid, out):
        kind = "softstiff" if defect == "softstiff-vel" else ["hardening", "softening", "nldamp"][rng.integers(3)]
        sysd = draw.base_system(rng, None, kind)
        damp, stiff = draw.truth_terms(sysd)
        chain, fmt, sensor, post_fn, chain_fn = {"gain": 1.0, "ppm": 0.0}, None, "acc", None, None
        words, refusal = None, None
        if defect == "inverted":  # mounted upside down (or a charge amplifier that inverts)
            chain["gain"] = -1.0
            fmt = "csv-si"
            words = refusal = [r"\bsign\b", r"invert", r"polarit", r"upside", r"opposite"]
        elif defect == "dcstep":  # the conditioner switched range in the fit capture's free response
            chain_fn = lambda c: ({"step_frac": float(rng.uniform(0.003, 0.01) * rng.choice([-1, 1])),  # noqa: E731
                                   "step_at": float(rng.uniform(0.2, 0.6))} if c == 0 else {})
            fmt = "csv-si"
            words = refusal = [r"offset", r"\bdc\b", r"jump", r"drift", r"(?<!time )\bstep\b", r"level shift"]
        elif defect == "g-as-si":
            fmt = "csv-g-unlabelled"
            words = refusal = [r"\bunits?\b", r"\bin g\b", r"gain", r"impulse", r"momentum", r"sensitivit",
                               r"calibrat", r"\bmass\b.*(error|differ|disagree|mismatch|off\b)"]
        elif defect == "force-clip":  # the force channel's range was set for a softer hammer
            fmt = "csv-si"
            words = refusal = [r"clip", r"satur", r"overload", r"out of range|full.scale", r"\bflat\b"]
        elif defect == "dropped-block":
            fmt = "csv-si"
            words = refusal = [r"\bgap", r"drop", r"missing", r"uniform", r"spacing", r"jump", r"\blost\b", r"skip",
                               r"irregular"]
        elif defect == "roundtime":
            fmt = "csv-roundtime"
        elif defect == "unitsrow":
            fmt = "csv-unitsrow"
        elif defect == "jitter":  # sample instants scattered 0.1-0.3 % of a period (rms) about the stamps
            chain["jitter_frac"] = float(rng.uniform(0.001, 0.003))
            fmt = ["csv-si", "csv-export"][rng.integers(2)]
        elif defect == "softstiff-vel":
            sensor, fmt = "vel", ["csv-export", "uff58", "mat"][rng.integers(3)]
        levels = [1.0, float(rng.uniform(0.55, 0.75))]
        kw = dict(sensor=sensor, chain=chain, fmt=fmt, levels=levels, chain_fn=chain_fn)
        if defect == "dropped-block":
            sub = np.random.default_rng(int(rng.integers(1 << 31)))
            kw["post_fn"] = lambda c, t, ch: _drop_block(c, t, ch, sub)
        if defect == "force-clip":
            kw["post_fn"] = _force_clip(float(rng.uniform(0.45, 0.7)))
        files, meta = _captures(rng, cid, out, sysd, 2, **kw)
        return {"files": {"fit": files[0], "held": files[1]}, "truth": {"mass": sysd["mass"], "damping": damp,
                "stiffness": stiff}, "system": sysd, "meta": meta, "defect": defect, "warn_words": words,
                "refusal_ok": refusal}
    return make


def _force_clip(rel):
    """The force channel saturates at ``rel`` x the fit capture's (c == 0) peak, in every capture (one range
    setting for the session): the converter's last code repeated."""
    level = {}

    def fn(c, t, ch):
        f = ch["force"]
        if c == 0:
            level["v"] = rel * np.abs(f).max()
        ch = dict(ch, force=np.clip(f, -level["v"], level["v"]))
        return t, ch
    return fn


# ----------------------------------------------------------------------------- (e) campaign
def campaign_thermal(rng, cid, out):
    """A rubber-mounted part warming through a campaign: the linear stiffness falls 0.8-2 % per record (5
    records over two days' folders), everything else fixed. Files as the lab's logger wrote them (the
    station's CSV and semicolon / decimal-comma exports, all ``.csv``), one aborted record (header only)."""
    sysd = draw.base_system(rng, None, "hardening")
    k1 = sysd["laws"][0]["k"][1]
    rate = rng.uniform(0.008, 0.02)
    ks = [k1 * (1 - rate) ** c for c in range(5)]
    folder = os.path.join(out, cid)
    for d in ("day1", "day2"):
        os.makedirs(os.path.join(folder, d), exist_ok=True)

    def system_fn(c):
        laws = [dict(sysd["laws"][0], k={**sysd["laws"][0]["k"], 1: ks[c]})]
        return physics.System([sysd["mass"]], laws)

    files = []
    meta = []
    for c in range(5):
        day = "day1" if c < 3 else "day2"
        fmt = "csv-si" if rng.random() < 0.5 else "csv-export"
        f, m = _captures(rng, os.path.join(cid, day, f"run{c:02d}"), out, sysd, 1, chain={"gain": 1.0, "ppm": 0.0},
                         fmt=fmt, system_fn=lambda _c, c=c: system_fn(c), levels=[float(rng.uniform(0.6, 1.0))])
        name = f[0]
        if not name.endswith(".csv"):  # the lab names every export .csv, whatever its delimiter
            name = os.path.splitext(name)[0] + ".csv"
            os.replace(os.path.join(folder, day, f[0]), os.path.join(folder, day, name))
        files.append(os.path.join(day, name))
        meta.append(m)
    with open(os.path.join(folder, "day2", "run99-aborted.csv"), "w") as fh:
        fh.write("t,force,acc\n")
    damp, stiff = draw.truth_terms(sysd)
    truths = [{"mass": sysd["mass"], "damping": damp, "stiffness": {**stiff, "x": ks[c]}} for c in range(5)]
    return {"folder": cid, "files": files, "broken": "day2/run99-aborted.csv", "truths": truths,
            "truth": truths[0], "system": sysd, "meta": meta, "k1": ks}


# ----------------------------------------------------------------------------- (f) multi-DOF
def mdof_forcelast(rng, cid, out):
    """Two masses in a chain, a cubic spring between them (15-40 % of the linear force at the level-1
    stretch); the logger writes the time in ms, the accelerations in mixed units (g, m/s^2, mm/s^2) and the
    force column LAST; the driving point is named on the command line."""
    n_mass = 2
    for _ in range(200):
        scale = ["grams", "kilograms", "tonnes"][rng.integers(3)]
        (m0, m1), (f0, f1), (x0, x1) = draw.SCALES[scale]
        ms = [draw.loguni(rng, m0, m1)]
        ms += [ms[0] * draw.loguni(rng, 0.3, 1.5)]
        f_target = draw.loguni(rng, f0, f1)
        ks = [ms[0] * (2 * np.pi * f_target) ** 2 * draw.loguni(rng, 0.5, 2.0) for _ in range(n_mass)]
        K = np.array([[ks[0] + ks[1], -ks[1]], [-ks[1], ks[1]]])
        fr = physics.linear_freqs(ms, K)
        r = fr[1] / fr[0]
        if r > 1.35 and all(abs(r - q) > 0.12 for q in (2.0, 3.0)):
            break
    X = draw.loguni(rng, x0, x1)
    zeta = draw.loguni(rng, 0.005, 0.02)
    laws = [{"law": "poly", "i": i, "j": i - 1, "k": {1: kv}, "c": {1: 2 * zeta * np.sqrt(kv * ms[i])}}
            for i, kv in enumerate(ks)]
    drive = int(rng.integers(n_mass))
    system = physics.System(ms, laws, drive=drive)
    fs = draw.pick_rate(rng, fr[-1])
    sysd = {"mass": ms[drive], "fn_hz": fr[0], "X_ref": X}
    p, _ = draw.hammer(rng, sysd, fr[-1], 1.0, width_frac=0.1, tip="plastic", fs=fs)
    tp = np.arange(0, int(6 / fr[0] * fs)) / fs
    xp = physics.simulate(system, [tuple(p[:3]) + (tuple(p[3]),)], tp)[0]
    stretch = float(np.abs(xp[1] - xp[0]).max())
    laws[1]["k"][3] = ks[1] * rng.uniform(0.15, 0.4) / stretch ** 2
    system = physics.System(ms, laws, drive=drive)
    labels = list(rng.choice(["deck", "frame", "motor", "plate", "cab", "boom"], n_mass, replace=False))
    names = [f"acc_{lab}" for lab in labels]
    pre, post = draw.timing(rng, fr[0], zeta, fs, max_samples=40000)
    files, tip = [], None
    levels = list(rng.uniform(0.5, 1.0, 4))
    order = [names[i] for i in rng.permutation(n_mass)] + ["force"]
    for c, s in enumerate(draw.sessions(rng, 4, snr=(40.0, 55.0))):
        s["names"] = names
        p, tip = draw.hammer(rng, sysd, fr[-1], levels[c], width_frac=rng.uniform(0.05, 0.15), tip=tip, fs=fs)
        t, ch = draw.record(rng, system, [p], fs, pre, post, s)
        path = formats.write(os.path.join(out, f"{cid}-{c}"), "csv-export", t, {k: ch[k] for k in order}, rng)
        files.append(os.path.basename(path))
    return {"files": {"train": files[:3], "held": files[3]}, "driving_point": names[drive], "columns": names,
            "freqs_hz": fr, "masses": ms, "laws": laws, "fs": fs, "pilot_stretch_m": stretch}


CASES = [
    ("null-hum", "diagnose", null_hum, True),
    ("null-adc12", "diagnose", null_adc12, True),
    ("null-h5session", "diagnose", null_h5session, True),
    ("null-mixed", "diagnose", null_mixed, True),
    ("hid-massleak", "diagnose", hid_massleak, True),
    ("cat-stop", "diagnose", cat_stop, True),
    ("cat-dbdrag", "diagnose", cat_dbdrag, True),
    ("id-inverted", "ident", ident_case("inverted"), True),
    ("id-dcstep", "ident", ident_case("dcstep"), True),
    ("id-g-as-si", "ident", ident_case("g-as-si"), True),
    ("id-force-clip", "ident", ident_case("force-clip"), True),
    ("id-dropped-block", "ident", ident_case("dropped-block"), True),
    ("id-roundtime", "ident", ident_case("roundtime"), True),
    ("id-unitsrow", "ident", ident_case("unitsrow"), True),
    ("id-softstiff-vel", "ident", ident_case("softstiff-vel"), True),
    ("id-jitter", "ident", ident_case("jitter"), True),
    ("camp-thermal", "campaign", campaign_thermal, True),
    ("mdof-forcelast", "mdof", mdof_forcelast, True),
]
