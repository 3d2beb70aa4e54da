"""The case kinds of the ninth scorecard; every number is drawn per seed (``draw.py``).

``CASES``: (id, manifest section, maker, in the quick set). A maker writes its records into the data
folder and returns the case's manifest entry (the truth the scorer judges against). The kinds are new
against unseen1-8 (written before the station was run on any of them): systems outside the catalogue, sensor
chains and files as a lab meets them, a growing model, a campaign of 30 captures and multi-DOF chains whose
driving point is not the first column. The id's first word is the judgement's rule (``judge.py``).
"""

from __future__ import annotations

import os

import numpy as np

import draw
import formats
import physics

FORMATS = ["csv-si", "csv-export", "uff58", "mat"]


def _captures(rng, cid, out, sysd, n, sensor="acc", chain=None, fmt=None, levels=None, system_fn=None,
              snr=(32.0, 58.0), max_samples=90000, chain_fn=None):
    """n captures of one single-DOF (or hidden second-mode) system over two sessions; returns (files, meta).
    ``system_fn(c)``: capture c's system; ``chain_fn(c)``: capture c's chain options on top of ``chain``."""
    fs = draw.pick_rate(rng, sysd.get("f_top", sysd["fn_hz"]))
    pre, post = draw.timing(rng, sysd["fn_hz"], sysd["zeta"], fs, max_samples=max_samples)
    fmt = fmt or FORMATS[rng.integers(len(FORMATS))]
    levels = levels or list(rng.uniform(0.45, 1.0, n))
    tip = None
    files, meta = [], []
    for c, s in enumerate(draw.sessions(rng, n, snr=snr)):
        s.update(chain or {})
        s.update(chain_fn(c) if chain_fn else {})
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


def _strength(sysd):
    L = sysd["laws"][0]
    k, c, X = L["k"][1], L["c"][1], sysd["X_ref"]
    return k, c, X, 2 * np.pi * sysd["fn_hz"] * X


def _pendulum(rng, sysd):
    """Replace the polynomial spring by ``k L sin(x / L)``, the largest blow reaching 0.5-0.9 rad."""
    L0 = sysd["laws"][0]
    k = L0["k"][1]
    Lp = sysd["X_ref"] / rng.uniform(0.5, 0.9)
    L0["k"] = {}
    L0["cx2v"] = 0.0
    sysd["laws"].append({"law": "sine", "i": 0, "k": k, "L": Lp})
    return k, Lp


# ----------------------------------------------------------------------------- diagnose: nulls -> `none`
def null_pendulum(rng, cid, out):
    """A pendulum-like softening spring ``k L sin(x / L)`` (not a polynomial; its Taylor series to x^5 is
    in the default library and within 1e-4 of it up to 1 rad), four captures."""
    sysd = draw.base_system(rng, None, "linear")
    _pendulum(rng, sysd)
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(38.0, 58.0), levels=list(rng.uniform(0.5, 1.0, 4)))
    return _entry(files, sysd, meta, None, ["none"])


def null_heavydamp(rng, cid, out):
    """A well damped mount (4-8 % of critical, short ring-downs of 10-20 cycles), linear or hardening."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    L = sysd["laws"][0]
    z = draw.loguni(rng, 0.04, 0.08)
    L["c"][1] *= z / sysd["zeta"]
    sysd["zeta"] = z
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(36.0, 55.0))
    return _entry(files, sysd, meta, None, ["none"])


def null_xtalk(rng, cid, out):
    """The hammer channel leaks into the accelerometer's conditioner (2-6 % of the response's peak per peak
    force, during the blow only): the free response is untouched."""
    sysd = draw.base_system(rng, None, ["linear", "hardening", "softening"][rng.integers(3)])
    chain = {"xtalk_frac": float(rng.uniform(0.02, 0.06) * rng.choice([-1, 1]))}
    files, meta = _captures(rng, cid, out, sysd, 4, chain=chain, snr=(36.0, 55.0))
    return _entry(files, sysd, meta, None, ["none"], chain=chain)


def null_dispquant(rng, cid, out):
    """A displacement laser whose resolution is 0.4-1.2 % of the ring-down's peak (the tail steps between a few
    codes, the rest before the blow sits on one), little analogue noise (50-60 dB)."""
    sysd = draw.base_system(rng, ["grams", "kilograms"][rng.integers(2)], ["hardening", "linear"][rng.integers(2)])
    chain = {"lsb_frac": float(rng.uniform(0.004, 0.012))}
    files, meta = _captures(rng, cid, out, sysd, 4, sensor="disp", chain=chain, snr=(50.0, 60.0))
    return _entry(files, sysd, meta, None, ["none"], chain=chain)


# ----------------------------------------------------------------------------- diagnose: catalogued
def cat_coulomb_low(rng, cid, out):
    """Dry friction with viscous damping, the blows small (30-60 % of the reference): fc 1.2-2.5 % of k X_ref,
    so friction takes a large share of the loss at these amplitudes."""
    sysd = draw.base_system(rng, None, "linear")
    sysd["laws"][0]["cx2v"] = 0.0
    k, c, X, V = _strength(sysd)
    sysd["laws"].append({"law": "coulomb", "i": 0, "fc": k * X * rng.uniform(0.012, 0.025), "veps": V * 1e-3})
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(40.0, 58.0), levels=list(rng.uniform(0.3, 0.6, 4)))
    return _entry(files, sysd, meta, "coulomb_viscous", ["coulomb_friction", "hysteresis"])


def cat_stop_damped(rng, cid, out):
    """A one-sided stop beyond a gap (20-50 % of X_ref), a contact spring 0.8-2 k and a contact dashpot 2-6 x
    the linear one (a rubber bumper)."""
    sysd = draw.base_system(rng, None, "linear")
    sysd["laws"][0]["cx2v"] = 0.0
    k, c, X, V = _strength(sysd)
    sysd["laws"].append({"law": "stop", "i": 0, "gap": X * rng.uniform(0.2, 0.5), "kc": k * rng.uniform(0.8, 2.0),
                         "cc": c * rng.uniform(2.0, 6.0)})
    files, meta = _captures(rng, cid, out, sysd, 4, levels=list(rng.uniform(0.6, 1.1, 4)), snr=(38.0, 58.0))
    return _entry(files, sysd, meta, "damped_stop", ["clearance", "asymmetric_stiffness"])


def cat_dampedmode(rng, cid, out):
    """A second mode 2.2-4 x the first, much more damped (4-10 % of critical against 0.4-2.5 %): a 10-25 %
    second mass on its own spring and dashpot, one accelerometer on the first mass."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    m2 = sysd["mass"] * rng.uniform(0.10, 0.25)
    r = rng.uniform(2.2, 4.0)
    k2 = m2 * (2 * np.pi * sysd["fn_hz"] * r) ** 2
    c2 = 2 * rng.uniform(0.04, 0.10) * np.sqrt(k2 * m2)
    sysd["extra_masses"] = [m2]
    sysd["laws"].append({"law": "poly", "i": 1, "j": 0, "k": {1: k2}, "c": {1: c2}})
    sysd["f_top"] = sysd["fn_hz"] * r * 1.1
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(40.0, 58.0))
    return _entry(files, sysd, meta, "damped_second_mode", ["second_mode"])


# ----------------------------------------------------------------------------- diagnose: outside the catalogue
def hid_basemotion(rng, cid, out):
    """The floor moves under the mount (traffic, a machine): three ground components at 0.3-3 x the natural
    frequency, their forces through the mount's spring 3-7 % of k X_ref, all through every capture; the
    accelerometer reads the mass's absolute acceleration."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    k, c, X, V = _strength(sysd)
    comps = []
    for _ in range(3):
        r = float(np.exp(rng.uniform(np.log(0.3), np.log(3.0))))
        while abs(r - 1) < 0.15:
            r = float(np.exp(rng.uniform(np.log(0.3), np.log(3.0))))
        comps.append([X * rng.uniform(0.03, 0.07) / np.sqrt(3), sysd["fn_hz"] * r, float(rng.uniform(0, 2 * np.pi))])
    sysd["laws"].append({"law": "base", "i": 0, "k": k, "c": c, "comps": comps})
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(40.0, 58.0))
    return _entry(files, sysd, meta, "base_motion", ["unexplained"])


def hid_kdrift(rng, cid, out):
    """A rubber mount warming through the test: each capture's linear stiffness 1.5-3 % below the one before
    (the captures given in the order they were taken)."""
    sysd = draw.base_system(rng, None, ["linear", "hardening", "softening"][rng.integers(3)])
    drop = rng.uniform(0.015, 0.03)
    k1 = sysd["laws"][0]["k"][1]
    ks = [k1 * (1 - drop) ** c for c in range(4)]

    def system_fn(c):
        return physics.System([sysd["mass"]], [dict(sysd["laws"][0], k={**sysd["laws"][0]["k"], 1: ks[c]})])
    files, meta = _captures(rng, cid, out, sysd, 4, system_fn=system_fn, snr=(40.0, 58.0))
    return _entry(files, sysd, meta, "stiffness_drift", ["unexplained"], k1=ks)


# ----------------------------------------------------------------------------- diagnose: chain defects (null structure)
def chain_softsat(rng, cid, out):
    """A linear structure; the accelerometer's amplifier compresses softly (``S tanh(a / S)``, S fixed for the
    session at 1.2-1.7 x the largest blow's free-response peak): a nonlinearity of the chain, not of the
    structure."""
    sysd = draw.base_system(rng, None, "linear")
    levels = list(rng.uniform(0.5, 1.0, 4))
    sx = rng.uniform(1.2, 1.7) * max(levels)
    files, meta = _captures(rng, cid, out, sysd, 4, levels=levels, snr=(40.0, 58.0),
                            chain_fn=lambda c: {"sat_x": float(sx / levels[c])})
    return _entry(files, sysd, meta, "amplifier_saturation", ["unexplained"], none_rule=True)


def chain_mountres(rng, cid, out):
    """A hardening or linear structure; the accelerometer's mounted resonance (a magnet mount) at 4-8 x the
    natural frequency, 2-5 % damped, rings after every blow. The measured signal holds a second mode, so
    `second_mode` describes it; `none` is held to the floor rule."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    r = rng.uniform(4.0, 8.0)
    sysd["f_top"] = sysd["fn_hz"] * r
    chain = {"mount_hz": float(sysd["fn_hz"] * r), "mount_zeta": float(rng.uniform(0.02, 0.05))}
    files, meta = _captures(rng, cid, out, sysd, 4, chain=chain, snr=(40.0, 58.0))
    return _entry(files, sysd, meta, "mount_resonance", ["unexplained", "second_mode"], none_rule=True,
                  chain=chain)


def chain_massgrams(rng, cid, out):
    """The lab typed the mass in grams where the station asks for kg (1000 x too large); the force channel
    is there, so the impulse against the momentum shows it. docs/diagnosis.md: a measurement-chain finding
    (`impulse_mass`) turns `none` or a name into `unexplained`."""
    sysd = draw.base_system(rng, ["kilograms", "grams"][rng.integers(2)], ["linear", "hardening"][rng.integers(2)])
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(40.0, 58.0))
    e = _entry(files, sysd, meta, "mass_in_grams", ["unexplained"])
    e["given_mass"] = sysd["mass"] * 1000.0
    return e


# ----------------------------------------------------------------------------- identification
def ident_case(defect):
    """Identification with the true terms on the level-1 blow, validation on a 55-75 % blow (unseen7's rule:
    ``warn_words`` name the defect in a warning, ``refusal_ok`` in a one-line refusal)."""
    def make(rng, cid, out):
        kind = ["hardening", "softening", "nldamp"][rng.integers(3)]
        sysd = draw.base_system(rng, None, kind)
        chain, fmt, sensor, words, refusal = {"gain": 1.0, "ppm": 0.0}, None, "acc", None, None
        mass = None
        if defect == "dispquant":  # a displacement laser at 0.15-0.4 % resolution
            sensor, fmt = "disp", ["csv-si", "csv-export"][rng.integers(2)]
            chain["lsb_frac"] = float(rng.uniform(0.0015, 0.004))
        elif defect == "mountres":
            r = rng.uniform(5.0, 10.0)
            sysd["f_top"] = sysd["fn_hz"] * r
            chain.update(mount_hz=float(sysd["fn_hz"] * r), mount_zeta=float(rng.uniform(0.02, 0.05)))
            refusal = [r"resonan", r"mode", r"mount", r"sensor"]  # not promised: any warning is honest
        elif defect == "clockskew":  # force and response from two DAQs: the force's latency and clock
            period = 1.0 / sysd["fn_hz"]
            chain.update(force_delay_s=float(period * rng.uniform(0.002, 0.006) * rng.choice([-1, 1])),
                         force_ppm=float(rng.uniform(30, 100) * rng.choice([-1, 1])))
            fmt = ["csv-si", "csv-export"][rng.integers(2)]
            words = refusal = [r"delay", r"\blag", r"latenc", r"align", r"skew", r"clock", r"sync", r"\blead",
                               r"before the (force|blow|impact)", r"causal"]
        elif defect == "massgrams":
            mass = sysd["mass"] * 1000.0
            words = refusal = [r"\bmass\b", r"impulse", r"momentum", r"\bgram", r"\bkg\b", r"\bunits?\b"]
        elif defect == "labexport":
            fmt = "csv-lab"
            refusal = [r"header", r"column", r"\bline\b", r"format", r"parse", r"\bread\b", r"unit"]
        elif defect == "mat73":
            fmt = "mat73"
        elif defect == "pendulum":
            sysd = draw.base_system(rng, None, "linear")
            k, Lp = _pendulum(rng, sysd)
        levels = [1.0, float(rng.uniform(0.55, 0.75))]
        files, meta = _captures(rng, cid, out, sysd, 2, sensor=sensor, chain=chain, fmt=fmt, levels=levels)
        if defect == "pendulum":
            damp = {"v": float(sysd["laws"][0]["c"][1])}
            stiff = {"x": k, "x^3": -k / (6 * Lp ** 2), "x^5": k / (120 * Lp ** 4)}
        else:
            damp, stiff = draw.truth_terms(sysd)
        return {"files": {"fit": files[0], "held": files[1]}, "truth": {"mass": sysd["mass"], "damping": damp,
                "stiffness": stiff}, "given_mass": mass or sysd["mass"], "system": sysd, "meta": meta,
                "defect": defect, "warn_words": words, "refusal_ok": refusal}
    return make


def grow_selfexcited(rng, cid, out):
    """A self-excited oscillator (a galloping or friction-driven part: negative linear damping, -0.3 to
    -0.8 % of critical, and x^2 v damping that holds a limit cycle at 40-70 % of the blow's amplitude): the
    true model grows from small amplitudes. README: such a model is flagged and `identify` exits 1."""
    sysd = draw.base_system(rng, None, ["linear", "hardening"][rng.integers(2)])
    L = sysd["laws"][0]
    k, c, X, V = _strength(sysd)
    z = rng.uniform(0.003, 0.008)
    c1 = 2 * z * np.sqrt(k * sysd["mass"])
    a = X * rng.uniform(0.4, 0.7) / 2  # van der Pol: limit cycle at about 2 a
    L["c"] = {1: -c1}
    L["cx2v"] = c1 / a ** 2
    sysd["zeta"] = float(z * 3)  # record length: the approach to the limit cycle
    files, meta = _captures(rng, cid, out, sysd, 1, fmt="csv-si", levels=[1.0], snr=(40.0, 55.0))
    damp, stiff = draw.truth_terms(sysd)
    return {"files": files, "given_mass": sysd["mass"], "truth": {"mass": sysd["mass"], "damping": damp,
            "stiffness": stiff}, "system": sysd, "meta": meta}


# ----------------------------------------------------------------------------- campaign
def campaign_30(rng, cid, out):
    """A day's session: 30 captures of one hardening mount in one folder as the bench logger wrote them
    (semicolons, decimal commas, g or m/s^2, all named .csv), the linear stiffness following the hall's
    temperature (down 2-4 % by mid-session, back by the end), one aborted capture (header only) and the
    logger's notes file. Per-record truth."""
    sysd = draw.base_system(rng, None, "hardening")
    k1 = sysd["laws"][0]["k"][1]
    amp = rng.uniform(0.02, 0.04)
    n = 30
    ks = [k1 * (1 - amp * np.sin(np.pi * c / (n - 1))) for c in range(n)]
    folder = os.path.join(out, cid)
    os.makedirs(folder, exist_ok=True)
    files, meta = [], []
    for c in range(n):
        laws = [dict(sysd["laws"][0], k={**sysd["laws"][0]["k"], 1: ks[c]})]
        f, m = _captures(rng, os.path.join(cid, f"cap{c:03d}"), out, sysd, 1, chain={"gain": 1.0, "ppm": 0.0},
                         fmt="csv-export", system_fn=lambda _c, laws=laws: physics.System([sysd["mass"]], laws),
                         levels=[float(rng.uniform(0.6, 1.0))], max_samples=12000, snr=(40.0, 55.0))
        name = f[0]
        if not name.endswith(".csv"):
            name = os.path.splitext(name)[0] + ".csv"
            os.replace(os.path.join(folder, f[0]), os.path.join(folder, name))
        files.append(name)
        meta.append(m)
    with open(os.path.join(folder, "cap030.csv"), "w") as fh:
        fh.write("Time [ms];Force [N];Acceleration [m/s^2]\n")
    with open(os.path.join(folder, "notes.txt"), "w") as fh:
        fh.write("hall 19.5 C at start, heating on at 10:00, off at 14:00\n")
    damp, stiff = draw.truth_terms(sysd)
    truths = [{"mass": sysd["mass"], "damping": damp, "stiffness": {**stiff, "x": ks[c]}} for c in range(n)]
    return {"folder": cid, "files": files, "broken": "cap030.csv", "truths": truths, "truth": truths[0],
            "system": sysd, "meta": meta, "k1": ks}


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


def mdof_case(n_mass, coupling=None, drive="notfirst", sensor="acc", heavy=False, dampmode=False, gyro=False):
    """A chain of ``n_mass`` masses to the ground (``gyro``: two coordinates of one rotor instead).
    ``coupling``: ``"link1"`` a cubic spring on the link between masses 0 and 1 (15-40 % of its linear force at
    the level-1 stretch), ``"ground"`` a cubic spring from mass 0 to the ground (same share: not a coupling
    term in physical coordinates, docs/multi-dof.md: `none` with a model that predicts), None linear.
    ``drive``: the struck mass, ``notfirst`` (any but the first column), ``mid`` or ``last``; the columns are
    written in mass order, so the driving point is never the first column. ``heavy``: one mass 5-10 x the
    others. ``dampmode``: the link between masses 0 and 1 carries a dashpot 10-25 x the others
    (non-proportional damping, one mode much more damped)."""
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
            d = {"notfirst": int(rng.integers(1, n_mass)), "mid": n_mass // 2, "last": n_mass - 1}[drive]
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
            if coupling == "link1":
                stretch = float(np.abs(xp[1] - xp[0]).max())
                laws[1]["k"] = {1: ks[1], 3: ks[1] * rng.uniform(0.15, 0.4) / stretch ** 2}
            else:
                stretch = float(np.abs(xp[0]).max())
                laws[0]["k"] = {1: ks[0], 3: ks[0] * rng.uniform(0.15, 0.4) / stretch ** 2}
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
        for c, s in enumerate(draw.sessions(rng, 4, snr=(40.0, 55.0))):
            s["names"] = names
            p, tip = draw.hammer(rng, sysd, f_hi, levels[c], width_frac=rng.uniform(0.05, 0.15), tip=tip, fs=fs)
            t, ch = draw.record(rng, system, [p], fs, pre, post, s, sensor=sensor)
            noise.append(s["noise_nrmse_ch"])
            path = formats.write(os.path.join(out, f"{cid}-{c}"), fmt, t, ch, rng)
            files.append(os.path.basename(path))
        effect = _coupling_effect(ms, laws, d, p, fs, post, names, sensor) if coupling else {}
        return {"files": {"train": files[:3], "held": files[3]}, "driving_point": names[d], "columns": names,
                "coupling_effect_nrmse": effect, "freqs_hz": fr, "masses": ms, "laws": laws, "fs": fs,
                "coupling": coupling, "gyro": gyro, "noise_nrmse": noise, "sensor": sensor}
    return make


CASES = [
    ("null-pendulum", "diagnose", null_pendulum, True),
    ("null-heavydamp", "diagnose", null_heavydamp, True),
    ("null-xtalk", "diagnose", null_xtalk, True),
    ("null-dispquant", "diagnose", null_dispquant, True),
    ("cat-coulomblow", "diagnose", cat_coulomb_low, True),
    ("cat-stopdamped", "diagnose", cat_stop_damped, True),
    ("cat-dampedmode", "diagnose", cat_dampedmode, True),
    ("hid-basemotion", "diagnose", hid_basemotion, True),
    ("hid-kdrift", "diagnose", hid_kdrift, True),
    ("chain-softsat", "diagnose", chain_softsat, True),
    ("chain-mountres", "diagnose", chain_mountres, True),
    ("chain-massgrams", "diagnose", chain_massgrams, True),
    ("id-dispquant", "ident", ident_case("dispquant"), True),
    ("id-mountres", "ident", ident_case("mountres"), True),
    ("id-clockskew", "ident", ident_case("clockskew"), True),
    ("id-massgrams", "ident", ident_case("massgrams"), True),
    ("id-labexport", "ident", ident_case("labexport"), True),
    ("id-mat73", "ident", ident_case("mat73"), True),
    ("id-pendulum", "ident", ident_case("pendulum"), True),
    ("grow-selfexcited", "grow", grow_selfexcited, True),
    ("camp-30", "campaign", campaign_30, True),
    ("mdof-2lin-drive2", "mdof", mdof_case(2), True),
    ("mdof-3mid-link", "mdof", mdof_case(3, "link1", drive="mid"), True),
    ("mdof-3lin-heavy", "mdof", mdof_case(3, None, drive="last", heavy=True), True),
    ("mdof-2vel-link", "mdof", mdof_case(2, "link1", sensor="vel"), True),
    ("mdof-gyro", "mdof", mdof_case(2, None, gyro=True), True),
    ("mdof-2ground", "mdof", mdof_case(2, "ground"), True),
    ("mdof-2dampmode", "mdof", mdof_case(2, None, dampmode=True), False),
]
