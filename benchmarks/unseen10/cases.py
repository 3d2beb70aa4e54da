"""The case kinds of the tenth scorecard; every number is drawn per seed (``draw.py``).

``CASES``: (id, manifest section, maker, in the quick set). A maker writes its records into the data
folder and returns the case's manifest entry (the truth the scorer judges against). The kinds are new
against unseen1-9 (written before the station was run on any of them): sensor chains with their own
dynamics (anti-alias filters of both kinds, two high-pass stages, clipping on the blow, hum with drift,
12-bit converters, a mounted resonance inside the band), mechanisms outside the catalogue and combinations of
two, files as labs write them (imperial units with decimal commas, UFF58 from a modal analyser in kN),
a lab's import-then-replay workflow with its known chain, and multi-DOF chains whose columns are not in mass
order or whose nonlinear link is far from the driving point. The id's first word is the judgement's rule
(``judge.py``).
"""

from __future__ import annotations

import os

import numpy as np

import draw
import formats
import physics

FORMATS = ["csv-si", "csv-export", "uff58", "mat"]
HUM = [50.0, 60.0]


def _captures(rng, cid, out, sysd, n, sensor="acc", chain=None, fmt=None, levels=None, system_fn=None,
              snr=(32.0, 58.0), max_samples=90000, chain_fn=None, y0=None):
    """n captures of one single-DOF (or hidden second-mode) system over two sessions; returns (files, meta).
    ``system_fn(c)``: capture c's system; ``chain_fn(c)``: capture c's chain options on top of ``chain``;
    ``y0``: the state the records start from (a deflected equilibrium)."""
    fs = draw.pick_rate(rng, sysd.get("f_top", sysd["fn_hz"]))
    pre, post = draw.timing(rng, sysd["fn_hz"], sysd["zeta"], fs, max_samples=max_samples)
    fmt = fmt or FORMATS[rng.integers(len(FORMATS))]
    levels = levels or list(rng.uniform(0.45, 1.0, n))
    tip = None
    files, meta = [], []
    for c, s in enumerate(draw.sessions(rng, n, snr=snr)):
        s.update(chain or {})
        s.update(chain_fn(c, fs) if chain_fn else {})
        system = system_fn(c) if system_fn else physics.System([sysd["mass"]] + sysd.get("extra_masses", []),
                                                              sysd["laws"])
        p, tip = draw.hammer(rng, sysd, sysd["fn_hz"], levels[c], tip=tip, fs=fs)
        t, ch = draw.record(rng, system, [p], fs, pre, post, s, sensor=sensor, y0=y0)
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


def _strength(sysd):
    L = sysd["laws"][0]
    k, c, X = L["k"][1], L["c"][1], sysd["X_ref"]
    return k, c, X, 2 * np.pi * sysd["fn_hz"] * X


def _hum(rng, lo, hi):
    return {"hum_db": float(rng.uniform(lo, hi)), "hum_hz": float(HUM[rng.integers(2)])}


# ----------------------------------------------------------------------------- diagnose: nulls -> `none`
def null_butter(rng, cid, out):
    """Both channels through the DAQ's analogue anti-alias filter (Butterworth, 4th-8th order, corner 0.2-0.4 x
    the rate; its delay not compensated): the same filter on force and response, a linear or cubic structure."""
    sysd = draw.base_system(rng, None, ["linear", "hardening", "softening"][rng.integers(3)])
    order, frac = int(rng.choice([4, 6, 8])), float(rng.uniform(0.2, 0.4))
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(38.0, 56.0),
                            chain_fn=lambda c, fs: {"aa": ("butter", order, frac * fs), "aa_force": True})
    return _entry(files, sysd, meta, None, ["none"])


def null_sigmadelta(rng, cid, out):
    """A sigma-delta DAQ: both channels through its linear-phase FIR (63-255 taps, corner 0.42-0.46 x the rate,
    the group delay taken out of the stamps), so the hammer pulse rings before it starts; 24 bits."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    taps, frac = int(rng.choice([63, 127, 255])), float(rng.uniform(0.42, 0.46))
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(40.0, 58.0), chain={"bits": 24},
                            chain_fn=lambda c, fs: {"aa": ("fir", taps, frac * fs), "aa_force": True})
    return _entry(files, sysd, meta, None, ["none"])


def null_imperial(rng, cid, out):
    """A US lab's export (force in lbf, acceleration in in/s^2 or g, semicolons, decimal commas), a linear or
    cubic structure: read as SI it would be 4.45 x off in force. A one-line refusal naming the units is honest."""
    sysd = draw.base_system(rng, None, ["linear", "hardening", "softening"][rng.integers(3)])
    files, meta = _captures(rng, cid, out, sysd, 4, fmt="csv-imperial", snr=(40.0, 58.0))
    return _entry(files, sysd, meta, None, ["none"],
                  refusal_ok=[r"\blbf\b", r"\bunits?\b", r"pound", r"in/s", r"\binch"])


# ----------------------------------------------------------------------------- diagnose: catalogued
def cat_softfric(rng, cid, out):
    """Two mechanisms at once: a softening cubic spring (in the library) and dry friction (2-4 % of k X_ref), the
    blows at 40-90 % of the reference."""
    sysd = draw.base_system(rng, None, "softening")
    sysd["laws"][0]["cx2v"] = 0.0
    k, c, X, V = _strength(sysd)
    sysd["laws"].append({"law": "coulomb", "i": 0, "fc": k * X * rng.uniform(0.02, 0.04), "veps": V * 1e-3})
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(40.0, 58.0), levels=list(rng.uniform(0.4, 0.9, 4)))
    return _entry(files, sysd, meta, "softening_coulomb", ["coulomb_friction", "hysteresis"])


def cat_harddrag(rng, cid, out):
    """Two mechanisms at once: a hardening cubic spring (in the library) and quadratic drag taking 40-70 % of
    the loss per cycle at the reference amplitude."""
    sysd = draw.base_system(rng, None, "hardening")
    sysd["laws"][0]["cx2v"] = 0.0
    k, c, X, V = _strength(sysd)
    share = rng.uniform(0.4, 0.7)
    # loss per cycle: viscous pi c w X^2, drag (8/3) cq w^2 X^3; cq for the share at X
    w = 2 * np.pi * sysd["fn_hz"]
    cq = share / (1 - share) * np.pi * c * w * X ** 2 / (8.0 / 3.0 * w ** 2 * X ** 3)
    sysd["laws"].append({"law": "drag", "i": 0, "cq": float(cq)})
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(40.0, 58.0), levels=list(rng.uniform(0.5, 1.0, 4)))
    return _entry(files, sysd, meta, "hardening_drag", ["quadratic_damping"])


def cat_preload(rng, cid, out):
    """A vertical hardening mount carrying its mass and a payload: a constant force deflects it by 0.6-1.2 x the
    reference amplitude, so the motion about the deflected equilibrium has an x^2 term (3 k3 x0) and an
    x^3 term; the records start at rest there."""
    sysd = draw.base_system(rng, None, "linear")
    L = sysd["laws"][0]
    L["cx2v"] = 0.0
    k1, X = L["k"][1], sysd["X_ref"]
    a, b = rng.uniform(0.1, 0.3), rng.uniform(0.6, 1.2)
    k3 = k1 * a / X ** 2
    L["k"] = {1: k1, 3: k3}
    x0 = -b * X
    w = -(k1 * x0 + k3 * x0 ** 3)  # the weight holds the spring at x0
    sysd["laws"].append({"law": "weight", "i": 0, "w": float(w)})
    keff = k1 + 3 * k3 * x0 ** 2
    sysd["fn_hz"] = float(np.sqrt(keff / sysd["mass"]) / (2 * np.pi))
    sysd["x0"] = float(x0)
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(40.0, 58.0), levels=list(rng.uniform(0.5, 1.0, 4)),
                            y0=[x0, 0.0])
    return _entry(files, sysd, meta, "preload_asym", ["asymmetric_stiffness"],
                  about_x0={"k1": keff, "k2": 3 * k3 * x0, "k3": k3})


def cat_bigstop(rng, cid, out):
    """A stiff one-sided stop (10-30 x k) beyond a gap at 55-80 % of the largest blow's amplitude: only the
    larger blows reach it (short contacts, a hard bumper)."""
    sysd = draw.base_system(rng, None, "linear")
    sysd["laws"][0]["cx2v"] = 0.0
    k, c, X, V = _strength(sysd)
    levels = list(rng.uniform(0.5, 1.0, 4))
    sysd["laws"].append({"law": "stop", "i": 0, "gap": X * max(levels) * rng.uniform(0.55, 0.8),
                         "kc": k * rng.uniform(10.0, 30.0)})
    files, meta = _captures(rng, cid, out, sysd, 4, levels=levels, snr=(40.0, 58.0))
    return _entry(files, sysd, meta, "stiff_stop", ["clearance", "asymmetric_stiffness"])


# ----------------------------------------------------------------------------- diagnose: outside the catalogue
def hid_fracdamp(rng, cid, out):
    """Fractional-power damping ``cp sign(v) |v|^0.5`` (a squeeze film) taking 40-70 % of the loss at the
    reference amplitude, linear viscous the rest; a linear or hardening spring."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    sysd["laws"][0]["cx2v"] = 0.0
    k, c, X, V = _strength(sysd)
    share = rng.uniform(0.4, 0.7)
    w = 2 * np.pi * sysd["fn_hz"]
    # loss per cycle of cp |v|^p over a cycle of amplitude V: 4 cp V^(p+1)/w * int_0^{pi/2} cos^(p+1) ~ 0.874 (p=.5)
    cp = share / (1 - share) * np.pi * c * w * X ** 2 / (4 * V ** 1.5 / w * 0.874)
    sysd["laws"][0]["c"] = {1: c}
    sysd["laws"].append({"law": "fracpow", "i": 0, "cp": float(cp), "p": 0.5, "veps": V * 1e-3})
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(40.0, 58.0), levels=list(rng.uniform(0.3, 1.0, 4)))
    return _entry(files, sysd, meta, "fractional_damping", ["unexplained"])


def hid_hertz(rng, cid, out):
    """A Hertzian contact in parallel with the linear spring, ``kh sign(x) |x|^1.5``, 15-35 % of the linear
    force at the reference amplitude (not a polynomial; `smooth_stiffening` comes closest)."""
    sysd = draw.base_system(rng, None, "linear")
    sysd["laws"][0]["cx2v"] = 0.0
    k, c, X, V = _strength(sysd)
    kh = k * X * rng.uniform(0.15, 0.35) / X ** 1.5
    sysd["laws"].append({"law": "hertz", "i": 0, "kh": float(kh)})
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(40.0, 58.0), levels=list(rng.uniform(0.3, 1.0, 4)))
    return _entry(files, sysd, meta, "hertz_contact", ["unexplained", "smooth_stiffening"])


# ----------------------------------------------------------------------------- diagnose: chain defects
def chain_clipblow(rng, cid, out):
    """A sound linear or cubic structure; the accelerometer channel's range set on the ring-down (1.15-1.5 x its
    peak), so the blow's own acceleration peak (F / m) clips for a few samples in every capture."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    chain = {"clip_frac": float(rng.uniform(1.15, 1.5)), "bits": 16, "range_x": (1.0, 1.0)}
    files, meta = _captures(rng, cid, out, sysd, 4, chain=chain, snr=(40.0, 56.0))
    return _entry(files, sysd, meta, "clipped_blow", ["none", "unexplained"], chain=chain)


def chain_hp2(rng, cid, out):
    """A sound structure; the accelerometer's own high-pass (its corner fn/40-fn/15) and a charge amplifier's
    (fn/10-fn/4): two first-order stages, not declared. `sensor_highpass` describes it."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    fn = sysd["fn_hz"]
    chain = {"hp_hz": float(fn / rng.uniform(4.0, 10.0)), "hp2_hz": float(fn / rng.uniform(15.0, 40.0))}
    files, meta = _captures(rng, cid, out, sysd, 4, chain=chain, snr=(40.0, 58.0))
    return _entry(files, sysd, meta, "two_highpass", ["sensor_highpass", "unexplained"], chain=chain)


def chain_humdrift(rng, cid, out):
    """A sound structure; mains hum (50 or 60 Hz and its third harmonic, 36-46 dB below the peak) and a slow
    offset drift (a ramp of 2-8 % and a bow of 1-4 % of the peak over the record) on the response channel;
    a 12-bit converter."""
    sysd = draw.base_system(rng, None, ["linear", "hardening", "softening"][rng.integers(3)])
    chain = {**_hum(rng, 36.0, 46.0), "bits": 12,
             "drift": (float(rng.uniform(0.02, 0.08) * rng.choice([-1, 1])), float(rng.uniform(0.01, 0.04)))}
    files, meta = _captures(rng, cid, out, sysd, 4, chain=chain, snr=(44.0, 56.0))
    return _entry(files, sysd, meta, "hum_drift_12bit", ["none", "unexplained"], chain=chain)


# ----------------------------------------------------------------------------- identification
def ident_case(defect):
    """Identification with the true terms on the level-1 blow, validation on a 55-75 % blow (unseen7's rule:
    ``warn_words`` name the defect in a warning, ``refusal_ok`` in a one-line refusal)."""
    def make(rng, cid, out):
        kind = ["hardening", "softening", "nldamp"][rng.integers(3)]
        sysd = draw.base_system(rng, None, kind)
        chain, fmt, sensor, words, refusal = {"gain": 1.0, "ppm": 0.0}, None, "acc", None, None
        if defect == "antialias":  # the response's conditioner alone low-passes (4th order at 4-8 x fn)
            chain["aa"] = ("butter", 4, float(sysd["fn_hz"] * rng.uniform(4.0, 8.0)))
            fmt = ["csv-si", "csv-export"][rng.integers(2)]
            words = refusal = [r"delay", r"\blag", r"latenc", r"align", r"phase", r"filter", r"causal", r"\blead",
                               r"before the (force|blow|impact)", r"low.?pass", r"anti.?alias"]
        elif defect == "drift":
            chain["drift"] = (float(rng.uniform(0.03, 0.1) * rng.choice([-1, 1])), float(rng.uniform(0.02, 0.06)))
        elif defect == "hum12":
            chain.update(_hum(rng, 30.0, 40.0), bits=12)
        elif defect == "imperial":
            fmt = "csv-imperial"
            refusal = [r"\blbf\b", r"\bunits?\b", r"pound", r"in/s", r"\binch"]
        elif defect == "uffmixed":
            fmt = "uff-mixed"
            refusal = [r"\bunits?\b", r"\bkn\b", r"direction", r"node"]
        elif defect == "mountlow":  # a soft magnet mount: the sensor's resonance at 1.8-3 x fn, inside the band
            r = rng.uniform(1.8, 3.0)
            sysd["f_top"] = sysd["fn_hz"] * r
            chain.update(mount_hz=float(sysd["fn_hz"] * r), mount_zeta=float(rng.uniform(0.03, 0.08)))
            refusal = [r"resonan", r"mode", r"mount", r"sensor"]
        levels = [1.0, float(rng.uniform(0.55, 0.75))]
        files, meta = _captures(rng, cid, out, sysd, 2, sensor=sensor, chain=chain, fmt=fmt, levels=levels)
        damp, stiff = draw.truth_terms(sysd)
        return {"files": {"fit": files[0], "held": files[1]}, "truth": {"mass": sysd["mass"], "damping": damp,
                "stiffness": stiff}, "given_mass": sysd["mass"], "system": sysd, "meta": meta,
                "defect": defect, "warn_words": words, "refusal_ok": refusal}
    return make


# ----------------------------------------------------------------------------- workflow: import, then replay
def workflow_import(rng, cid, out):
    """A lab's routine: three captures exported by its logger (semicolons, decimal commas, units in the header)
    through a charge amplifier whose high-pass corner it knows from the data sheet (fn/12-fn/5), imported into
    one session with ``station import --mass M --sensor-highpass HZ`` and identified with ``station replay``
    on the true terms (identify on one capture, validate on the others)."""
    sysd = draw.base_system(rng, None, ["hardening", "softening"][rng.integers(2)])
    hp = float(sysd["fn_hz"] / rng.uniform(5.0, 12.0))
    files, meta = _captures(rng, cid, out, sysd, 3, chain={"gain": 1.0, "ppm": 0.0, "hp_hz": hp},
                            fmt="csv-export", levels=[1.0, float(rng.uniform(0.6, 0.8)), float(rng.uniform(0.4, 0.6))],
                            snr=(40.0, 56.0))
    if not all(f.endswith(".csv") for f in files):  # import takes CSV files: the logger's .txt/.tsv renamed
        new = []
        for f in files:
            g = os.path.splitext(f)[0] + ".csv"
            if f != g:
                os.replace(os.path.join(out, f), os.path.join(out, g))
            new.append(g)
        files = new
    damp, stiff = draw.truth_terms(sysd)
    return {"files": files, "truth": {"mass": sysd["mass"], "damping": damp, "stiffness": stiff},
            "given_mass": sysd["mass"], "highpass_hz": hp, "system": sysd, "meta": meta}
# ----------------------------------------------------------------------------- multi-DOF
def _chain_K(ks, ground_only_first=True):
    n = len(ks)
    K = np.zeros((n, n))
    for i, kv in enumerate(ks):
        K[i, i] += kv
        if i > 0:
            K[i - 1, i - 1] += kv
            K[i, i - 1] -= kv
            K[i - 1, i] -= kv
    return K


def _shapes(ms, K):
    """Mass-normalised mode shapes (columns, ascending frequency) of M x'' + K x = 0."""
    from scipy.linalg import eigh
    return eigh(K, np.diag(ms))[1]


def _coupling_effect(ms, laws, drive, p, fs, post, names, sensor):
    """Per channel, the nrmse between the held blow's clean response with the nonlinear terms and without them
    (only the linear springs kept): how far the nonlinearity moves the record, against which `none` is
    weighed."""
    lin = [dict(L, k={q: v for q, v in L["k"].items() if int(q) == 1}) if L["law"] == "poly" else L for L in laws]
    t = np.arange(0, int(post * fs)) / fs
    pulse = [tuple(p[:3]) + (tuple(p[3]),)]
    q = {"disp": 0, "vel": 1, "acc": 2}[sensor]
    a_nl = physics.simulate(physics.System(ms, laws, drive=drive), pulse, t)[q]
    a_li = physics.simulate(physics.System(ms, lin, drive=drive), pulse, t)[q]
    after = t > 2 * p[1]
    return {n: float(np.sqrt(np.mean((a_nl[i, after] - a_li[i, after]) ** 2) / np.mean(a_nl[i, after] ** 2)))
            for i, n in enumerate(names)}


def mdof_case(n_mass, coupling=None, drive="notfirst", sensor="acc", heavy=False, dampmode=False, gyro=False,
              soft=False, shuffle=False, chain=None):
    """A chain of ``n_mass`` masses to the ground (``gyro``: two coordinates of one rotor instead).
    ``coupling``: ``"link1"`` a cubic spring on the link between masses 0 and 1 (15-40 % of its linear force at
    the level-1 stretch), ``"ground"`` a cubic spring from mass 0 to the ground (same share: not a coupling
    term in physical coordinates, docs/multi-dof.md: `none` with a model that predicts), None linear.
    ``drive``: the struck mass, ``notfirst`` (any but the first column), ``mid`` or ``last``; the columns are
    written in mass order, so the driving point is never the first column. ``heavy``: one mass 5-10 x the
    others. ``dampmode``: the link between masses 0 and 1 carries a dashpot 10-25 x the others
    (non-proportional damping, one mode much more damped). Tenth set: ``coupling="link2"`` the cubic spring on
    the link between masses 1 and 2; ``soft`` a softening cubic (-8 to -15 % of the linear force at the level-1
    stretch); ``shuffle`` the columns written in a random order (not mass order; the driving point anywhere);
    ``chain`` sensor-chain options for every response channel (``hum``: mains hum 44-50 dB down and 16 bits)."""
    def make(rng, cid, out):
        for _ in range(400):
            scale = ["grams", "kilograms", "tonnes"][rng.integers(3)]
            (m0, m1), (f0, f1), (x0, x1) = draw.SCALES[scale]
            ms = [draw.loguni(rng, m0, m1)]
            ms += [ms[-1] * draw.loguni(rng, 0.4, 1.5) for _ in range(n_mass - 1)]
            if heavy:
                ms[int(rng.integers(n_mass))] *= draw.loguni(rng, 5.0, 10.0)
            f_target = draw.loguni(rng, f0, f1)
            ks = [ms[0] * (2 * np.pi * f_target) ** 2 * draw.loguni(rng, 0.4, 2.5) for _ in range(n_mass)]
            if gyro:
                ms = [ms[0], ms[0]]
                ks = [ks[0], ks[0] * draw.loguni(rng, 1.15, 1.6)]  # an anisotropic support
                K = np.diag(ks)
            else:
                K = _chain_K(ks)
            fr = physics.linear_freqs(ms, K)
            rs = [fr[i + 1] / fr[i] for i in range(n_mass - 1)]
            d = {"notfirst": int(rng.integers(1, n_mass)), "mid": n_mass // 2, "last": n_mass - 1,
                 "first": 0}[drive]
            # a lab strikes where every mode moves: no mode with a node near the driving point (its shape there
            # at least 30 % of its largest entry), else that mode is barely excited and no method can fit it
            shapes = _shapes(ms, K)
            struck = min(abs(shapes[d, r]) / np.abs(shapes[:, r]).max() for r in range(n_mass))
            if (min(rs) > (1.08 if gyro else 1.35) and all(abs(r - q) > 0.12 for r in rs for q in (2.0, 3.0))
                    and (gyro or struck >= 0.3)):
                break
        else:
            raise RuntimeError("no chain drawn")
        X = draw.loguni(rng, x0, x1)
        zeta = draw.loguni(rng, 0.005, 0.02)
        if gyro:
            laws = [{"law": "poly", "i": i, "j": -1, "k": {1: kv}, "c": {1: 2 * zeta * np.sqrt(kv * ms[i])}}
                    for i, kv in enumerate(ks)]
            w1 = 2 * np.pi * fr[0]
            laws.append({"law": "gyro", "i": 0, "j": 1, "g": ms[0] * w1 * rng.uniform(0.15, 0.4)})
        else:
            laws = [{"law": "poly", "i": i, "j": i - 1, "k": {1: kv}, "c": {1: 2 * zeta * np.sqrt(kv * ms[i])}}
                    for i, kv in enumerate(ks)]
        if dampmode:
            laws[1]["c"] = {1: laws[1]["c"][1] * rng.uniform(10.0, 25.0)}
        system = physics.System(ms, laws, drive=d)
        fr = physics.linear_freqs(ms, K)
        f_hi = max(fr)
        fs = draw.pick_rate(rng, f_hi)
        sysd = {"mass": ms[d], "fn_hz": fr[0], "X_ref": X}
        p, _ = draw.hammer(rng, sysd, f_hi, 1.0, width_frac=0.1, tip="plastic", fs=fs)
        tp = np.arange(0, int(6 / fr[0] * fs)) / fs
        if coupling:
            xp = physics.simulate(system, [tuple(p[:3]) + (tuple(p[3]),)], tp)[0]
            share = -rng.uniform(0.08, 0.15) if soft else rng.uniform(0.15, 0.4)
            if coupling in ("link1", "link2"):
                j = 1 if coupling == "link1" else 2
                stretch = float(np.abs(xp[j] - xp[j - 1]).max())
                laws[j]["k"] = {1: ks[j], 3: ks[j] * share / stretch ** 2}
            else:
                stretch = float(np.abs(xp[0]).max())
                laws[0]["k"] = {1: ks[0], 3: ks[0] * share / stretch ** 2}
            system = physics.System(ms, laws, drive=d)
        if gyro:
            labels = ["horiz", "vert"]
        else:
            labels = list(rng.choice(["deck", "frame", "motor", "plate", "cab", "boom", "arm"], n_mass, replace=False))
        names = [f"{sensor}_{lab}" for lab in labels]
        pre, post = draw.timing(rng, fr[0], zeta, fs, max_samples=30000)
        files, tip, noise = [], None, []
        levels = list(rng.uniform(0.5, 1.0, 4))
        fmt = ["csv-si", "csv-export"][rng.integers(2)]
        order = list(rng.permutation(n_mass)) if shuffle else list(range(n_mass))
        extra = {}
        if chain == "hum":
            extra = {**_hum(rng, 44.0, 50.0), "bits": 16}
        for c, s in enumerate(draw.sessions(rng, 4, snr=(40.0, 55.0))):
            s["names"] = names
            s.update(extra)
            p, tip = draw.hammer(rng, sysd, f_hi, levels[c], width_frac=rng.uniform(0.05, 0.15), tip=tip, fs=fs)
            t, ch = draw.record(rng, system, [p], fs, pre, post, s, sensor=sensor)
            ch = {"force": ch["force"], **{names[i]: ch[names[i]] for i in order}}
            noise.append(s["noise_nrmse_ch"])
            path = formats.write(os.path.join(out, f"{cid}-{c}"), fmt, t, ch, rng)
            files.append(os.path.basename(path))
        effect = _coupling_effect(ms, laws, d, p, fs, post, names, sensor) if coupling else {}
        return {"files": {"train": files[:3], "held": files[3]}, "driving_point": names[d],
                "columns": [names[i] for i in order], "chain": extra, "soft": soft,
                "coupling_effect_nrmse": effect, "freqs_hz": fr, "masses": ms, "laws": laws, "fs": fs,
                "coupling": coupling, "gyro": gyro, "noise_nrmse": noise, "sensor": sensor}
    return make


CASES = [
    ("null-butter", "diagnose", null_butter, True),
    ("null-sigmadelta", "diagnose", null_sigmadelta, True),
    ("null-imperial", "diagnose", null_imperial, True),
    ("cat-softfric", "diagnose", cat_softfric, True),
    ("cat-harddrag", "diagnose", cat_harddrag, True),
    ("cat-preload", "diagnose", cat_preload, True),
    ("cat-bigstop", "diagnose", cat_bigstop, True),
    ("hid-fracdamp", "diagnose", hid_fracdamp, True),
    ("hid-hertz", "diagnose", hid_hertz, True),
    ("chain-clipblow", "diagnose", chain_clipblow, True),
    ("chain-hp2", "diagnose", chain_hp2, True),
    ("chain-humdrift", "diagnose", chain_humdrift, True),
    ("id-antialias", "ident", ident_case("antialias"), True),
    ("id-drift", "ident", ident_case("drift"), True),
    ("id-hum12", "ident", ident_case("hum12"), True),
    ("id-imperial", "ident", ident_case("imperial"), True),
    ("id-uffmixed", "ident", ident_case("uffmixed"), True),
    ("id-mountlow", "ident", ident_case("mountlow"), True),
    ("wf-import", "workflow", workflow_import, True),
    ("mdof-2soft-link", "mdof", mdof_case(2, "link1", soft=True), True),
    ("mdof-3lin-shuffled", "mdof", mdof_case(3, None, drive="first", shuffle=True), True),
    ("mdof-3link2", "mdof", mdof_case(3, "link2", drive="notfirst", shuffle=True), True),
    ("mdof-2lin-hum", "mdof", mdof_case(2, None, chain="hum"), True),
    ("mdof-3soft-ground", "mdof", mdof_case(3, "ground", soft=True, drive="mid"), False),
]
