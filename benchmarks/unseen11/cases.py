"""The case kinds of the eleventh scorecard; every number is drawn per seed (``draw.py``).

``CASES``: (id, manifest section, maker, in the quick set). A maker writes its records into the data
folder and returns the case's manifest entry (the truth the scorer judges against). The kinds are new
against unseen1-10 (written before the station was run on any of them): the ends of a lab's range (3 g at
25-51 kHz, 200 kg at 500 Hz, damping from 0.05 % to 8 %), mechanisms outside the catalogue (a viscoelastic
mount, a stiffness drifting with the temperature inside the records, a soft bilinear stop offset from rest,
a softening spring near buckling), sensor chains (a charge amplifier's high-pass at a corner the lab declares,
a sensor whose mass loads the structure, a laser vibrometer's dropouts), records as acquisition software
writes them (a quoted metadata block, semicolons, decimal commas, g and mm/s, jittered time stamps),
cross-command consistency (identify / validate / diagnose / import + HDF5 / report on the same records) and
multi-DOF captures in those files and through import + replay. The id's first word is the judgement's rule
(``judge.py``).
"""

from __future__ import annotations

import os

import numpy as np

import draw
import formats
import physics

FORMATS = ["csv-si", "csv-export", "uff58", "mat"]  # csv-real only where the layout is the case
HUM = [50.0, 60.0]


def system(rng, m_rng, f_rng, z_rng, x_rng, kind="linear", scale="custom"):
    """A single-DOF polynomial system of mass, frequency, damping ratio and reference amplitude drawn
    log-uniformly from the ranges (``kind`` as draw.base_system's, plus ``nearbuckle``: a softening cubic
    taking 45-65 % of the tangent stiffness at the reference amplitude)."""
    m, fn, X = draw.loguni(rng, *m_rng), draw.loguni(rng, *f_rng), draw.loguni(rng, *x_rng)
    zeta = draw.loguni(rng, *z_rng)
    k = m * (2 * np.pi * fn) ** 2
    c = 2 * zeta * np.sqrt(k * m)
    kk = {1: k}
    if kind == "hardening":
        kk[3] = k * rng.uniform(0.06, 0.3) / X ** 2
    elif kind == "softening":
        kk[3] = -k * rng.uniform(0.04, 0.1) / X ** 2
    elif kind == "nearbuckle":  # tangent k - 3 a X^2: 35-55 % of k left at X; the barrier at >= 2.1 X
        kk[3] = -k * rng.uniform(0.15, 0.22) / X ** 2
    return {"scale": scale, "mass": m, "fn_hz": fn, "X_ref": X, "zeta": zeta,
            "laws": [{"law": "poly", "i": 0, "k": kk, "c": {1: c}, "cx2v": 0.0}]}


GRAMS = dict(m_rng=(0.003, 0.012), f_rng=(300.0, 1500.0), x_rng=(5e-6, 4e-5))
HEAVY = dict(m_rng=(60.0, 200.0), f_rng=(2.0, 12.0), x_rng=(1e-3, 8e-3))
MIDDLE = dict(m_rng=(0.3, 20.0), f_rng=(8.0, 80.0), x_rng=(2e-4, 2e-3))


def _rate(rng, sysd, lo=None):
    """The DAQ's rate: draw.pick_rate, or the rates from ``lo`` up that give 25-150 points per period."""
    if lo is None:
        return draw.pick_rate(rng, sysd.get("f_top", sysd["fn_hz"]))
    ok = [r for r in draw.RATES if r >= lo and r <= 150 * sysd["fn_hz"]] or [r for r in draw.RATES if r >= lo][:1]
    return int(ok[rng.integers(len(ok))])


def _captures(rng, cid, out, sysd, n, sensor="acc", chain=None, fmt=None, levels=None, system_fn=None,
              snr=(36.0, 56.0), max_samples=90000, chain_fn=None, rate_lo=None, fs=None):
    """n captures of one single-DOF system over two sessions; returns (files, meta). ``system_fn(c, pre,
    post)``: capture c's system; ``chain_fn(c, fs)``: capture c's chain options on top of ``chain``."""
    fs = fs or _rate(rng, sysd, rate_lo)
    pre, post = draw.timing(rng, sysd["fn_hz"], sysd["zeta"], fs, max_samples=max_samples)
    fmt = fmt or FORMATS[rng.integers(len(FORMATS))]
    levels = levels or list(rng.uniform(0.45, 1.0, n))
    tip = None
    files, meta = [], []
    for c, s in enumerate(draw.sessions(rng, n, snr=snr)):
        s.update(chain or {})
        s.update(chain_fn(c, fs) if chain_fn else {})
        sysm = system_fn(c, pre, post) if system_fn else physics.System([sysd["mass"]], sysd["laws"])
        p, tip = draw.hammer(rng, dict(sysd, mass=sysd.get("moving_mass", sysd["mass"])), sysd["fn_hz"], levels[c],
                             tip=tip, fs=fs)
        t, ch = draw.record(rng, sysm, [p], fs, pre, post, s, sensor=sensor)
        name = os.path.basename(formats.write(os.path.join(out, f"{cid}-{c}"), fmt, t, ch, rng))
        files.append(name)
        meta.append({"level": float(levels[c]), "session": s})
    return files, {"fs": fs, "pre_s": pre, "post_s": post, "fmt": fmt, "tip": tip, "sensor": sensor,
                   "captures": meta}


def _entry(files, sysd, meta, hidden, expect, **kw):
    return {"files": files, "given_mass": sysd["mass"], "hidden": hidden, "expect": expect, "system": sysd,
            "meta": meta, **kw}


def _kind(rng, kinds):
    return kinds[rng.integers(len(kinds))]


# ----------------------------------------------------------------------------- diagnose: nulls -> `none`
def null_chargeamp(rng, cid, out):
    """A charge amplifier whose AC coupling the lab set to a high corner (fn/7-fn/3: a long cable's drift
    suppressed), first order, declared with ``--sensor-highpass HZ``; a linear or cubic structure."""
    sysd = system(rng, **MIDDLE, z_rng=(0.005, 0.03), kind=_kind(rng, ["linear", "hardening", "softening"]))
    hp = float(sysd["fn_hz"] / rng.uniform(3.0, 7.0))
    files, meta = _captures(rng, cid, out, sysd, 4, chain={"hp_hz": hp}, fmt=_kind(rng, ["csv-si", "csv-export"]))
    return _entry(files, sysd, meta, None, ["none"], args=["--sensor-highpass", f"{hp:.6g}"], highpass_hz=hp)


def null_ldvnan(rng, cid, out):
    """A laser vibrometer (velocity, a logger export in m/s or mm/s) whose software marks 3-6 signal dropouts of 1-3 samples as
    NaN in every capture; a linear or hardening structure. `none`, or one line refusing the NaN samples."""
    sysd = system(rng, **MIDDLE, z_rng=(0.004, 0.02), kind=_kind(rng, ["linear", "hardening"]))
    files, meta = _captures(rng, cid, out, sysd, 4, sensor="vel", fmt="csv-export",
                            chain_fn=lambda c, fs: {"dropouts": int(rng.integers(3, 7)), "dropout_value": float("nan")})
    return _entry(files, sysd, meta, None, ["none"],
                  refusal_ok=[r"\bnan\b", r"missing", r"dropout", r"\bgap", r"not a (finite )?number", r"finite", r"empty",
                              r"invalid"])


def null_realfile(rng, cid, out):
    """A linear or cubic structure recorded by acquisition software that writes a quoted metadata block with no
    comment sign (docs/capture-format.md documents `#` notes), semicolons, decimal commas, acceleration in g:
    `none`, or one line refusing the file that names its header."""
    sysd = system(rng, **MIDDLE, z_rng=(0.004, 0.02), kind=_kind(rng, ["linear", "hardening", "softening"]))
    files, meta = _captures(rng, cid, out, sysd, 4, fmt="csv-real")
    return _entry(files, sysd, meta, None, ["none"], refusal_ok=LAYOUT_WORDS)


def chain_humvel(rng, cid, out):
    """A velocity sensor (geophone, mm/s) with 50 or 60 Hz mains hum and its third harmonic 34-44 dB below the
    peak on a linear or hardening structure whose frequency is not near the hum: the hum outlasts the ring-down's
    tail, so `unexplained` is as honest as `none` (unseen10's rule for hum on the response channel)."""
    for _ in range(50):
        sysd = system(rng, **MIDDLE, z_rng=(0.004, 0.02), kind=_kind(rng, ["linear", "hardening"]))
        hz = float(HUM[rng.integers(2)])
        if all(abs(sysd["fn_hz"] / f - 1) > 0.15 for f in (hz, 3 * hz)):
            break
    files, meta = _captures(rng, cid, out, sysd, 4, sensor="vel", fmt="csv-export",
                            chain={"hum_db": float(rng.uniform(34.0, 44.0)), "hum_hz": hz})
    return _entry(files, sysd, meta, "hum_velocity", ["none", "unexplained"])


def null_heavy(rng, cid, out):
    """A 60-200 kg structure at 2-12 Hz, damping 0.05-0.3 %, sampled at 500-2000 Hz (a floor or a machine
    base): the record ends long before the ring-down does. Linear or hardening; the lab's software export."""
    sysd = system(rng, **HEAVY, z_rng=(0.0005, 0.003), kind=_kind(rng, ["linear", "hardening"]), scale="heavy")
    files, meta = _captures(rng, cid, out, sysd, 4, fmt="csv-export", rate_lo=500, max_samples=60000)
    return _entry(files, sysd, meta, None, ["none"])


def null_grams(rng, cid, out):
    """A 3-12 g part at 300-1500 Hz with 2-8 % damping (a polymer bracket), sampled at 25.6-51.2 kHz: a few
    cycles of ring-down. Linear or softening."""
    sysd = system(rng, **GRAMS, z_rng=(0.02, 0.08), kind=_kind(rng, ["linear", "softening"]), scale="grams")
    files, meta = _captures(rng, cid, out, sysd, 4, rate_lo=25600, fmt=_kind(rng, ["csv-si", "mat", "uff58"]))
    return _entry(files, sysd, meta, None, ["none"])


def null_nearbuckle(rng, cid, out):
    """An axially loaded strip near buckling: a softening cubic that takes 45-65 % of the tangent stiffness at
    the reference amplitude (in the default library: x^3), the blows at 50-100 %."""
    sysd = system(rng, **MIDDLE, z_rng=(0.004, 0.02), kind="nearbuckle")
    files, meta = _captures(rng, cid, out, sysd, 4, levels=list(rng.uniform(0.5, 1.0, 4)),
                            fmt=_kind(rng, ["csv-si", "csv-export"]))
    return _entry(files, sysd, meta, None, ["none"])


# ----------------------------------------------------------------------------- diagnose: catalogued
def cat_bilinear(rng, cid, out):
    """A soft bilinear stop offset from rest: a second spring of 0.6-1.5 x k engages on one side beyond
    10-35 % of the largest blow's amplitude (a rubber buffer with a small clearance)."""
    sysd = system(rng, **MIDDLE, z_rng=(0.004, 0.02), kind="linear")
    k, X = sysd["laws"][0]["k"][1], sysd["X_ref"]
    levels = list(rng.uniform(0.5, 1.0, 4))
    sysd["laws"].append({"law": "stop", "i": 0, "gap": float(X * max(levels) * rng.uniform(0.1, 0.35)),
                         "kc": float(k * rng.uniform(0.6, 1.5))})
    files, meta = _captures(rng, cid, out, sysd, 4, levels=levels)
    return _entry(files, sysd, meta, "bilinear_offset", ["asymmetric_stiffness", "clearance"])


# ----------------------------------------------------------------------------- diagnose: outside the catalogue
def hid_maxwell(rng, cid, out):
    """A viscoelastic mount (standard linear solid): a Maxwell branch k2 = 0.2-0.5 k with its relaxation time
    0.3-3 / w in parallel with the main spring and a light dashpot. Linear, but its loss and stiffness depend
    on frequency and it creeps back after the blow."""
    sysd = system(rng, **MIDDLE, z_rng=(0.002, 0.006), kind="linear")
    L = sysd["laws"][0]
    k, m = L["k"][1], sysd["mass"]
    w0 = 2 * np.pi * sysd["fn_hz"]
    k2, r = k * rng.uniform(0.2, 0.5), draw.loguni(rng, 0.3, 3.0)
    tau = r / w0
    sysd["laws"].append({"law": "maxwell", "i": 0, "k2": float(k2), "c2": float(k2 * tau)})
    keff = k + k2 * r * r / (1 + r * r)
    sysd["fn_hz"] = float(np.sqrt(keff / m) / (2 * np.pi))
    sysd["zeta"] = float(sysd["zeta"] + k2 * r / (1 + r * r) / (2 * keff))
    files, meta = _captures(rng, cid, out, sysd, 4, levels=list(rng.uniform(0.4, 1.0, 4)))
    return _entry(files, sysd, meta, "viscoelastic", ["unexplained"])


def hid_tempdrift(rng, cid, out):
    """A hardening mount warming through the test: its linear stiffness falls 3-6 % over the four captures,
    steadily, inside each record too (k1 (1 - D (c + s) / 4), s the fraction of record c elapsed)."""
    sysd = system(rng, **MIDDLE, z_rng=(0.004, 0.02), kind="hardening")
    D = rng.uniform(0.03, 0.06)
    k1 = sysd["laws"][0]["k"][1]
    sysd["drift_total"] = float(D)

    def system_fn(c, pre, post):
        T = pre + post
        law = {"law": "kramp", "i": 0, "k": k1, "eps": -D / 4, "t0": -pre - c * T, "T": T}
        return physics.System([sysd["mass"]], sysd["laws"] + [law])
    files, meta = _captures(rng, cid, out, sysd, 4, system_fn=system_fn, snr=(42.0, 56.0))
    return _entry(files, sysd, meta, "temperature_drift", ["unexplained"])


# ----------------------------------------------------------------------------- diagnose: chain defects
def chain_massload(rng, cid, out):
    """A heavy accelerometer (with its magnet base) on a light structure: 6-15 % of the structure's mass moves
    with it; the lab gives the structure's mass alone. The station's impulse/mass check is the answer."""
    sysd = system(rng, **MIDDLE, z_rng=(0.004, 0.02), kind=_kind(rng, ["linear", "hardening"]))
    ms = sysd["mass"] * rng.uniform(0.06, 0.15)
    sysd["sensor_mass"] = float(ms)
    sysd["moving_mass"] = sysd["mass"] + ms
    sysd["fn_hz"] = float(sysd["fn_hz"] * np.sqrt(sysd["mass"] / (sysd["mass"] + ms)))
    files, meta = _captures(rng, cid, out, sysd, 4,
                            system_fn=lambda c, pre, post: physics.System([sysd["moving_mass"]], sysd["laws"]))
    return _entry(files, sysd, meta, "sensor_mass_loading", ["unexplained"])


# ----------------------------------------------------------------------------- identification
IDENT = {
    # defect: (system ranges and kinds, chain, fmt, sensor, rate_lo, warn_words, refusal_ok, extra args)
    "chargeamp": "a charge amplifier's high-pass at fn/8-fn/3, declared with --sensor-highpass on identify and "
                 "validate",
    "massload": "a sensor of 6-15 % of the mass on the structure, the lab giving the structure's mass",
    "ldvdrop": "a laser vibrometer (mm/s) with 4-8 dropouts to zero of 1-3 samples in the ring-down",
    "jitter": "a logger's export (`#` notes, ms, decimal commas, units in brackets) whose time column is the "
              "logger's own jittered stamps (1-4 % of a period) printed to 7 digits",
    "heavy": "60-200 kg at 2-12 Hz, 4-8 % damping, 500-2000 Hz, the lab's software export in g",
    "grams": "3-12 g at 300-1500 Hz, 0.05-0.3 % damping, 25.6-51.2 kHz",
    "clipfew": "an accelerometer channel whose range was set on a smaller blow: the first ring-down peaks clip "
               "(at 85-95 % of the peak) for a few samples",
    "hum60": "a velocity sensor with 60 Hz mains hum and its third harmonic 34-42 dB below the peak",
    "veldrift": "a velocity sensor (mm/s) whose offset drifts slowly (a ramp of 4-12 % and a bow of 2-6 % of "
                "the peak)",
}
LAYOUT_WORDS = [r"header", r"metadata", r"\bcolumn"]  # a refusal of the metadata block that names it
TIME_WORDS = [r"\btime", r"uniform", r"jitter", r"spacing", r"\bstep", r"stamp", r"interval", r"grid", r"irregular"]


def ident_case(defect):
    """Identification with the true terms on the level-1 blow, validation on a 55-75 % blow (unseen7's rule:
    ``warn_words`` name the defect in a warning, ``refusal_ok`` in a one-line refusal)."""
    def make(rng, cid, out):
        kind = _kind(rng, ["hardening", "softening"])
        rng_sys = MIDDLE
        z_rng = (0.004, 0.025)
        chain, fmt, sensor, words, refusal, args, rate_lo = {"gain": 1.0, "ppm": 0.0}, None, "acc", None, None, [], None
        given = None
        if defect == "heavy":
            rng_sys, z_rng, fmt, rate_lo = HEAVY, (0.04, 0.08), "csv-export", 500
        elif defect == "grams":
            rng_sys, z_rng, rate_lo = GRAMS, (0.0005, 0.003), 25600
            fmt = _kind(rng, ["csv-si", "mat"])
        sysd = system(rng, **rng_sys, z_rng=z_rng, kind=kind)
        if defect == "chargeamp":
            hp = float(sysd["fn_hz"] / rng.uniform(3.0, 8.0))
            chain["hp_hz"] = hp
            args = ["--sensor-highpass", f"{hp:.6g}"]
        elif defect == "massload":
            ms = sysd["mass"] * rng.uniform(0.06, 0.15)
            given = sysd["mass"]
            sysd["sensor_mass"] = float(ms)
            sysd["moving_mass"] = sysd["mass"] + ms
            sysd["fn_hz"] = float(sysd["fn_hz"] * np.sqrt(sysd["mass"] / (sysd["mass"] + ms)))
            words = refusal = [r"\bmass", r"impulse", r"momentum", r"sensor", r"load"]
        elif defect == "ldvdrop":
            sensor, fmt = "vel", "csv-export"
            chain["dropouts"] = int(rng.integers(4, 9))
            words = refusal = [r"dropout", r"spike", r"outlier", r"glitch", r"\bzero", r"jump", r"\bgap", r"sample"]
        elif defect == "jitter":
            fmt = "csv-export-jitter"
            words = refusal = TIME_WORDS
        elif defect == "clipfew":  # the range set on a smaller blow: the first 1-3 peaks clip for a few samples
            chain.update(clip_frac=float(rng.uniform(0.85, 0.95)), bits=16, range_x=(1.0, 1.0))
            words = refusal = [r"clip", r"saturat", r"overload", r"\brange", r"flat"]
        elif defect == "hum60":  # a velocity sensor's cable near a 60 Hz machine
            sensor = "vel"
            chain.update(hum_db=float(rng.uniform(34.0, 42.0)), hum_hz=60.0)
            words = refusal = [r"\bhum\b", r"mains", r"\b60 ?hz", r"tone", r"line frequency", r"harmonic"]
        elif defect == "veldrift":
            sensor, fmt = "vel", "csv-export"
            chain["drift"] = (float(rng.uniform(0.04, 0.12) * rng.choice([-1, 1])), float(rng.uniform(0.02, 0.06)))
        levels = [1.0, float(rng.uniform(0.55, 0.75))]
        sys_fn = None
        if sysd.get("moving_mass"):
            sys_fn = lambda c, pre, post: physics.System([sysd["moving_mass"]], sysd["laws"])  # noqa: E731
        files, meta = _captures(rng, cid, out, sysd, 2, sensor=sensor, chain=chain, fmt=fmt, levels=levels,
                                rate_lo=rate_lo, system_fn=sys_fn, max_samples=60000)
        damp, stiff = draw.truth_terms(sysd)
        return {"files": {"fit": files[0], "held": files[1]}, "truth": {"mass": sysd["mass"], "damping": damp,
                "stiffness": stiff}, "given_mass": given or sysd["mass"], "system": sysd, "meta": meta,
                "defect": defect, "warn_words": words, "refusal_ok": refusal, "args": args}
    make.__doc__ = IDENT[defect]
    return make


# ----------------------------------------------------------------------------- consistency
def consistency(rng, cid, out):
    """Three captures of a hardening or softening structure (0.3-20 kg), written as the station's own CSV
    (SI): the same records through identify, validate, diagnose, import + identify on the HDF5 session, and
    report; the scorer compares their numbers with each other and with the truth."""
    sysd = system(rng, **MIDDLE, z_rng=(0.004, 0.025), kind=_kind(rng, ["hardening", "softening"]))
    levels = [float(rng.uniform(0.4, 0.55)), 1.0, float(rng.uniform(0.6, 0.8))]
    files, meta = _captures(rng, cid, out, sysd, 3, fmt="csv-si", levels=levels, max_samples=40000,
                            snr=(40.0, 56.0), chain={"gain": 1.0, "ppm": 0.0})
    damp, stiff = draw.truth_terms(sysd)
    return {"files": files, "truth": {"mass": sysd["mass"], "damping": damp, "stiffness": stiff},
            "given_mass": sysd["mass"], "system": sysd, "meta": meta, "fit_file": files[1]}


def formats_same(rng, cid, out):
    """One capture and a second blow of a cubic structure, each written three ways: the station's CSV (SI), a
    logger export (`#` notes, ms, tab or semicolon, decimal commas, g or mm/s^2, N or kN) and a MATLAB file:
    identify gives the same model from each (within a tenth of its ci95: the files differ in rounding only)."""
    sysd = system(rng, **MIDDLE, z_rng=(0.004, 0.025), kind=_kind(rng, ["hardening", "softening"]))
    fs = _rate(rng, sysd)
    pre, post = draw.timing(rng, sysd["fn_hz"], sysd["zeta"], fs, max_samples=40000)
    sess = draw.sessions(rng, 2, snr=(40.0, 56.0))
    files = {}
    tip = None
    for c, lev in enumerate([1.0, float(rng.uniform(0.55, 0.75))]):
        s = dict(sess[c], gain=1.0, ppm=0.0)
        p, tip = draw.hammer(rng, sysd, sysd["fn_hz"], lev, tip=tip, fs=fs)
        t, ch = draw.record(rng, physics.System([sysd["mass"]], sysd["laws"]), [p], fs, pre, post, s)
        for fmt in ("csv-si", "csv-export", "mat"):
            name = os.path.basename(formats.write(os.path.join(out, f"{cid}-{c}-{fmt.split('-')[-1]}"), fmt, t, ch,
                                                  rng))
            files.setdefault(fmt, []).append(name)
        sess[c] = s
    damp, stiff = draw.truth_terms(sysd)
    meta = {"fs": fs, "pre_s": pre, "post_s": post, "fmt": "three", "tip": tip, "sensor": "acc",
            "captures": [{"session": s} for s in sess]}
    return {"files": files["csv-si"], "by_format": files, "truth": {"mass": sysd["mass"], "damping": damp,
            "stiffness": stiff}, "given_mass": sysd["mass"], "system": sysd, "meta": meta}


# ----------------------------------------------------------------------------- multi-DOF
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


def _shapes(ms, K):
    from scipy.linalg import eigh
    return eigh(K, np.diag(ms))[1]


def _coupling_effect(ms, laws, drive, p, fs, post, names, sensor):
    """Per channel, the nrmse between the held blow's clean response with the nonlinear terms and without them."""
    lin = [dict(L, k={q: v for q, v in L["k"].items() if int(q) == 1}) if L["law"] == "poly" else L for L in laws]
    t = np.arange(0, int(post * fs)) / fs
    pulse = [tuple(p[:3]) + (tuple(p[3]),)]
    q = {"disp": 0, "vel": 1, "acc": 2}[sensor]
    a_nl = physics.simulate(physics.System(ms, laws, drive=drive), pulse, t)[q]
    a_li = physics.simulate(physics.System(ms, lin, drive=drive), pulse, t)[q]
    after = t > 2 * p[1]
    return {n: float(np.sqrt(np.mean((a_nl[i, after] - a_li[i, after]) ** 2) / np.mean(a_nl[i, after] ** 2)))
            for i, n in enumerate(names)}


def mdof_case(n_mass, coupling=None, sensor="acc", scale=None, fmt=None, z_rng=(0.005, 0.02), rate_lo=None):
    """A chain of ``n_mass`` masses to the ground, struck at a mass other than the first, every mass measured.
    ``coupling``: ``"link1"`` a cubic spring on the link between masses 0 and 1 (15-40 % of its linear force at
    the level-1 stretch), None linear. ``scale``: draw.SCALES' key (grams, kilograms, tonnes); ``fmt`` the file
    layout; ``rate_lo`` the lowest DAQ rate (a high-rate laser vibrometer)."""
    def make(rng, cid, out):
        for _ in range(400):
            sc = scale or ["grams", "kilograms"][rng.integers(2)]
            (m0, m1), (f0, f1), (x0, x1) = draw.SCALES[sc]
            ms = [draw.loguni(rng, m0, m1)]
            ms += [ms[-1] * draw.loguni(rng, 0.4, 1.5) for _ in range(n_mass - 1)]
            f_target = draw.loguni(rng, f0, f1)
            ks = [ms[0] * (2 * np.pi * f_target) ** 2 * draw.loguni(rng, 0.4, 2.5) for _ in range(n_mass)]
            K = _chain_K(ks)
            fr = physics.linear_freqs(ms, K)
            rs = [fr[i + 1] / fr[i] for i in range(n_mass - 1)]
            d = int(rng.integers(1, n_mass))
            shapes = _shapes(ms, K)
            struck = min(abs(shapes[d, r]) / np.abs(shapes[:, r]).max() for r in range(n_mass))
            if min(rs) > 1.35 and all(abs(r - q) > 0.12 for r in rs for q in (2.0, 3.0)) and struck >= 0.3:
                break
        else:
            raise RuntimeError("no chain drawn")
        X = draw.loguni(rng, x0, x1)
        zeta = draw.loguni(rng, *z_rng)
        laws = [{"law": "poly", "i": i, "j": i - 1, "k": {1: kv}, "c": {1: 2 * zeta * np.sqrt(kv * ms[i])}}
                for i, kv in enumerate(ks)]
        system_ = physics.System(ms, laws, drive=d)
        f_hi = max(fr)
        fs = _rate(rng, {"fn_hz": f_hi}, rate_lo)
        sysd = {"mass": ms[d], "fn_hz": fr[0], "X_ref": X}
        p, _ = draw.hammer(rng, sysd, f_hi, 1.0, width_frac=0.1, tip="plastic", fs=fs)
        if coupling:
            tp = np.arange(0, int(6 / fr[0] * fs)) / fs
            xp = physics.simulate(system_, [tuple(p[:3]) + (tuple(p[3]),)], tp)[0]
            share = rng.uniform(0.15, 0.4)
            stretch = float(np.abs(xp[1] - xp[0]).max())
            laws[1]["k"] = {1: ks[1], 3: ks[1] * share / stretch ** 2}
            system_ = physics.System(ms, laws, drive=d)
        labels = list(rng.choice(["deck", "frame", "motor", "plate", "cab", "boom", "arm"], n_mass, replace=False))
        names = [f"{sensor}_{lab}" for lab in labels]
        pre, post = draw.timing(rng, fr[0], zeta, fs, max_samples=30000)
        files, tip, noise = [], None, []
        levels = list(rng.uniform(0.5, 1.0, 4))
        f_ = fmt or ["csv-si", "csv-export"][rng.integers(2)]
        for c, s in enumerate(draw.sessions(rng, 4, snr=(40.0, 55.0))):
            s["names"] = names
            p, tip = draw.hammer(rng, sysd, f_hi, levels[c], width_frac=rng.uniform(0.05, 0.15), tip=tip, fs=fs)
            t, ch = draw.record(rng, system_, [p], fs, pre, post, s, sensor=sensor)
            noise.append(s["noise_nrmse_ch"])
            path = formats.write(os.path.join(out, f"{cid}-{c}"), f_, t, ch, rng)
            files.append(os.path.basename(path))
        effect = _coupling_effect(ms, laws, d, p, fs, post, names, sensor) if coupling else {}
        return {"files": {"train": files[:3], "held": files[3]}, "all_files": files, "driving_point": names[d],
                "columns": names, "coupling_effect_nrmse": effect, "freqs_hz": fr, "masses": ms, "laws": laws,
                "fs": fs, "coupling": coupling, "gyro": False, "noise_nrmse": noise, "sensor": sensor, "fmt": f_,
                "refusal_ok": LAYOUT_WORDS if f_ == "csv-real" else None}
    return make


CASES = [
    ("null-chargeamp", "diagnose", null_chargeamp, True),
    ("null-ldvnan", "diagnose", null_ldvnan, True),
    ("null-realfile", "diagnose", null_realfile, True),
    ("null-heavy", "diagnose", null_heavy, True),
    ("null-grams", "diagnose", null_grams, True),
    ("null-nearbuckle", "diagnose", null_nearbuckle, True),
    ("cat-bilinear", "diagnose", cat_bilinear, True),
    ("hid-maxwell", "diagnose", hid_maxwell, True),
    ("hid-tempdrift", "diagnose", hid_tempdrift, True),
    ("chain-massload", "diagnose", chain_massload, True),
    ("chain-humvel", "diagnose", chain_humvel, True),
    ("id-chargeamp", "ident", ident_case("chargeamp"), True),
    ("id-massload", "ident", ident_case("massload"), True),
    ("id-ldvdrop", "ident", ident_case("ldvdrop"), True),
    ("id-jitter", "ident", ident_case("jitter"), True),
    ("id-heavy", "ident", ident_case("heavy"), True),
    ("id-grams", "ident", ident_case("grams"), True),
    ("id-veldrift", "ident", ident_case("veldrift"), True),
    ("id-clipfew", "ident", ident_case("clipfew"), True),
    ("id-hum60", "ident", ident_case("hum60"), True),
    ("x-cross", "consistency", consistency, True),
    ("x-h5", "consistency", consistency, True),
    ("x-formats", "consistency", formats_same, True),
    ("mdof-2real", "mdof", mdof_case(2, None, fmt="csv-real", scale="kilograms"), True),
    ("mdof-3vel-grams", "mdof", mdof_case(3, "link1", sensor="vel", scale="grams", rate_lo=25600, fmt="csv-export"),
     True),
    ("mdofr-2link", "mdofreplay", mdof_case(2, "link1", fmt="csv-si"), True),
    ("mdof-3heavy-lin", "mdof", mdof_case(3, None, fmt="csv-export", scale="kilograms"), False),
]
