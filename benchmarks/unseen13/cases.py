"""The case kinds of the thirteenth scorecard; every number is drawn per seed (``draw.py``).

``CASES``: (id, manifest section, maker, in the quick set). A maker writes its records into the data folder
and returns the case's manifest entry: the truth the scorer judges against and the case's CPU limit per
command (``limit_cpu_s``). The kinds are new against unseen1-12 (written before the station was run on any of
them):

- diagnose (one DOF, mass given): nulls at scales and rates no set had (20-80 g at 96-102.4 kHz, 250-900 kg
  at 1 kHz, a 27-32 dB record), catalogued terms at such scales (quadratic damping on a 20-80 g part at
  96-102.4 kHz, ``abs(x)*x`` stiffening on a 250-900 kg machine at 1 kHz), a stiffness that steps down between
  the captures (the mount warming between blows, constant inside each record), a charge amplifier overdriven by
  the blow that settles back with a time constant of a few periods, a whipping cable's triboelectric glitches
  on the response channel, an accelerometer replaced mid-test with the old sensitivity kept, a hammer that
  rebounds in two of the four blows (both pulses in the force channel), a 12-bit DAQ ranged for a blow 3-6 x
  larger on a heavy machine, a fixture that is not rigid (a second mode of the structure on it), free decays
  without a force channel;
- identify + validate at those scales and noise and on non-polynomial terms the libraries hold (``abs(v)*v``,
  ``abs(x)*x``), alone and combined with the extreme scales;
- growth: self-excited records (Rayleigh ``v^3`` and van der Pol ``x^2*v`` with a negative linear damping) at
  250-900 kg / 1 kHz and 20-80 g / 96-102.4 kHz, and a negative damping alone at 28-33 dB;
- multi-channel (2-3 response channels, no mass given): a 250-2500 kg two-mass chain at 1 kHz, a cubic link at
  33-37 dB, a three-mass grams chain at 20-51 kHz, a grams chain with a cubic link;
- bad inputs and the first run: ``badinputs.py``.
The id's first word is the judgement's rule (``judge.py``).
"""

from __future__ import annotations

import os

import numpy as np

import draw
import formats
import physics

FORMATS = ["csv-si", "csv-export", "uff58", "mat"]
MICRO = dict(m_rng=(0.02, 0.08), f_rng=(120.0, 500.0), x_rng=(4e-6, 4e-5))
TONNE = dict(m_rng=(250.0, 900.0), f_rng=(2.0, 6.0), x_rng=(1.5e-3, 1e-2))
MIDDLE = dict(m_rng=(0.3, 20.0), f_rng=(8.0, 80.0), x_rng=(2e-4, 2e-3))
FAST = (96000, 102400)  # a 100 kHz class DAQ (the rates draw.RATES holds in this range)
SLOW = (1000, 1024)
IDENT_LIMIT = 300  # CPU s per identify / validate command
DIAG_LIMIT = 300  # CPU s per one-DOF diagnose of 4 captures


def system(rng, m_rng, f_rng, x_rng, z_rng=(0.004, 0.025), kind="linear", scale="custom"):
    """A single-DOF system of mass, frequency, damping ratio and reference amplitude drawn log-uniformly.
    ``kind``: linear, hardening, softening, drag (``abs(v)*v`` dissipating 0.8-2.5 x the linear dashpot's energy
    per cycle at the reference amplitude), absx (``abs(x)*x`` adding 10-30 % to the stiffness there),
    rayleigh / vdp (a negative linear damping and a ``v^3`` / ``x^2*v`` term whose limit cycle sits at the
    reference amplitude)."""
    m, fn, X = draw.loguni(rng, *m_rng), draw.loguni(rng, *f_rng), draw.loguni(rng, *x_rng)
    zeta = draw.loguni(rng, *z_rng)
    w = 2 * np.pi * fn
    k = m * w ** 2
    c = 2 * zeta * np.sqrt(k * m)
    kk, cc, law = {1: k}, {1: c}, {}
    if kind == "hardening":
        kk[3] = k * rng.uniform(0.06, 0.3) / X ** 2
    elif kind == "softening":
        kk[3] = -k * rng.uniform(0.04, 0.1) / X ** 2
    elif kind == "drag":  # energy per cycle: drag (8/3) cq w^2 X^3 against the dashpot's pi c w X^2
        cc[2] = rng.uniform(0.8, 2.5) * 3 * np.pi * c / (8 * w * X)
    elif kind == "absx":
        law["kabs"] = k * rng.uniform(0.1, 0.3) / X
    elif kind == "rayleigh":  # mean power c1 V^2 / 2 + c3 3 V^4 / 8 = 0 at V = w X
        cc[1] = -c
        cc[3] = 4 * c / (3 * (w * X) ** 2)
    elif kind == "linneg":  # a negative damping alone (flutter, a friction-driven squeal): exponential growth
        cc[1] = -c
    elif kind == "vdp":  # mean power c1 V^2 / 2 + c2 X^2 V^2 / 8 = 0 at X
        cc[1] = -c
        law["cx2v"] = 4 * c / X ** 2
    return {"scale": scale, "mass": m, "fn_hz": fn, "X_ref": X, "zeta": zeta,
            "laws": [{"law": "poly", "i": 0, "k": kk, "c": cc, "cx2v": law.get("cx2v", 0.0), **law}]}


def _rate(rng, lo, hi):
    ok = [r for r in draw.RATES if lo <= r <= hi]
    return int(ok[rng.integers(len(ok))])


def _captures(rng, cid, out, sysd, n, chain=None, fmt=None, levels=None, system_fn=None, snr=(36.0, 56.0),
              max_samples=60000, chain_fn=None, fs=None, two=True, post_fn=None):
    """n captures of one single-DOF system over two sessions; returns (files, meta). ``system_fn(c, pre,
    post)``: capture c's system; ``chain_fn(c, fs, pre, post)``: capture c's chain options on top of ``chain``."""
    fs = fs or draw.pick_rate(rng, sysd["fn_hz"])
    pre, post = draw.timing(rng, sysd["fn_hz"], abs(sysd["zeta"]), fs, max_samples=max_samples)
    fmt = fmt or FORMATS[rng.integers(len(FORMATS))]
    levels = levels or list(rng.uniform(0.45, 1.0, n))
    tip = None
    files, meta = [], []
    for c, s in enumerate(draw.sessions(rng, n, snr=snr, two=two)):
        s.update(chain or {})
        s.update(chain_fn(c, fs, pre, post) if chain_fn else {})
        sysm = system_fn(c, pre, post) if system_fn else physics.System([sysd["mass"]], sysd["laws"])
        p, tip = draw.hammer(rng, sysd, sysd["fn_hz"], levels[c], tip=tip, fs=fs)
        t, ch = draw.record(rng, sysm, [p], fs, pre, post, s)
        if post_fn:
            t, ch = post_fn(t, ch, p)
        files.append(os.path.basename(formats.write(os.path.join(out, f"{cid}-{c}"), fmt, t, ch, rng)))
        meta.append({"level": float(levels[c]), "session": s})
    return files, {"fs": fs, "pre_s": pre, "post_s": post, "fmt": fmt, "tip": tip, "sensor": "acc",
                   "captures": meta}


def _entry(files, sysd, meta, hidden, expect, **kw):
    return {"files": files, "given_mass": sysd["mass"], "hidden": hidden, "expect": expect, "system": sysd,
            "meta": meta, "limit_cpu_s": DIAG_LIMIT, **kw}


def _kind(rng, kinds):
    return kinds[rng.integers(len(kinds))]


# ----------------------------------------------------------------------------- diagnose: nulls -> `none`
def null_micro(rng, cid, out):
    """A 20-80 g part at 120-500 Hz sampled at 96-102.4 kHz (200-850 samples a period), linear or hardening."""
    sysd = system(rng, **MICRO, z_rng=(0.004, 0.02), kind=_kind(rng, ["linear", "hardening"]), scale="micro")
    files, meta = _captures(rng, cid, out, sysd, 4, fs=_rate(rng, *FAST), fmt=_kind(rng, ["csv-si", "mat"]))
    return _entry(files, sysd, meta, None, ["none"])


def null_tonne(rng, cid, out):
    """A 250-900 kg machine on its mounts at 2-6 Hz sampled at 1-1.024 kHz, softening or hardening; a logger's
    export."""
    sysd = system(rng, **TONNE, z_rng=(0.01, 0.04), kind=_kind(rng, ["softening", "hardening"]), scale="tonne")
    files, meta = _captures(rng, cid, out, sysd, 4, fs=_rate(rng, *SLOW), fmt="csv-export")
    return _entry(files, sysd, meta, None, ["none"])


def null_noisy(rng, cid, out):
    """A hardening structure measured 27-32 dB above the noise (a low-sensitivity accelerometer)."""
    sysd = system(rng, **MIDDLE, z_rng=(0.005, 0.02), kind="hardening")
    files, meta = _captures(rng, cid, out, sysd, 4, snr=(27.0, 32.0), levels=list(rng.uniform(0.6, 1.0, 4)))
    return _entry(files, sysd, meta, None, ["none"])


# ----------------------------------------------------------------------------- diagnose: catalogued
def cat_dragmicro(rng, cid, out):
    """Quadratic (velocity-squared) damping on a 20-80 g part at 96-102.4 kHz, the blows at 30-100 %."""
    sysd = system(rng, **MICRO, z_rng=(0.002, 0.008), kind="drag", scale="micro")
    files, meta = _captures(rng, cid, out, sysd, 4, fs=_rate(rng, *FAST), levels=[1.0, 0.3, 0.65, 0.45],
                            fmt=_kind(rng, ["csv-si", "mat"]))
    return _entry(files, sysd, meta, "quadratic_damping", ["quadratic_damping", "amplitude_damping"])


# ----------------------------------------------------------------------------- diagnose: outside the catalogue
def hid_kstep(rng, cid, out):
    """The mount warms between the blows (not inside them): capture c's linear stiffness is k (1 - D c / 3),
    D 4-8 % over the four captures (a 2-4 % frequency step), a hardening structure."""
    sysd = system(rng, **MIDDLE, z_rng=(0.004, 0.02), kind="hardening")
    D = float(rng.uniform(0.04, 0.08))
    sysd["k_step_total"] = D
    L0 = sysd["laws"][0]

    def system_fn(c, pre, post):
        law = dict(L0, k={**L0["k"], 1: L0["k"][1] * (1 - D * c / 3)})
        return physics.System([sysd["mass"]], [law])
    files, meta = _captures(rng, cid, out, sysd, 4, system_fn=system_fn, snr=(42.0, 56.0))
    return _entry(files, sysd, meta, "stiffness_step_between_captures", ["unexplained"])


def chain_settle(rng, cid, out):
    """A charge amplifier overdriven by the blow: its output carries an offset of 8-20 % of the response's peak
    that settles back exponentially with a time constant of 2-8 periods; linear or hardening. A first-order
    AC coupling gives such a tail too, so ``sensor_highpass`` is accepted as its documented equivalent."""
    sysd = system(rng, **MIDDLE, z_rng=(0.004, 0.015), kind=_kind(rng, ["linear", "hardening"]))
    T = 1.0 / sysd["fn_hz"]
    files, meta = _captures(rng, cid, out, sysd, 4, chain_fn=lambda c, fs, pre, post: {
        "settle": (float(rng.uniform(0.08, 0.2) * rng.choice([-1, 1])), float(rng.uniform(2.0, 8.0) * T))})
    return _entry(files, sysd, meta, "amplifier_settling", ["unexplained", "sensor_highpass"])


def chain_cablewhip(rng, cid, out):
    """The accelerometer's cable whips against the structure: 10-24 short bipolar glitches (3-10 samples, 10-30 %
    of the response's peak) in the first 40 % of each ring-down; linear or softening."""
    sysd = system(rng, **MIDDLE, z_rng=(0.004, 0.02), kind=_kind(rng, ["linear", "softening"]))

    def spikes(c, fs, pre, post):
        n = int(rng.integers(10, 25))
        return {"spikes": [(float(q), float(rng.uniform(0.1, 0.3) * rng.choice([-1, 1])), int(rng.integers(3, 11)))
                           for q in np.sort(rng.uniform(0.01, 0.4, n))]}
    files, meta = _captures(rng, cid, out, sysd, 4, chain_fn=spikes, fmt=_kind(rng, ["csv-si", "csv-export"]))
    return _entry(files, sysd, meta, "cable_whip", ["unexplained"])


def chain_gainstep(rng, cid, out):
    """The accelerometer was replaced between the second and third blow and the lab kept the first one's
    sensitivity: the last two captures read 6-12 % high or low (a linear or hardening structure)."""
    sysd = system(rng, **MIDDLE, z_rng=(0.004, 0.02), kind=_kind(rng, ["linear", "hardening"]))
    err = float(rng.uniform(0.06, 0.12) * rng.choice([-1, 1]))
    sysd["gain_error"] = err
    files, meta = _captures(rng, cid, out, sysd, 4, two=False,
                            chain_fn=lambda c, fs, pre, post: {"gain": 1.0 + (err if c >= 2 else 0.0)})
    return _entry(files, sysd, meta, "sensitivity_step", ["unexplained"])


def chain_doublehit(rng, cid, out):
    """The hammer rebounds in two of the four blows: a second pulse of 8-25 % of the first, 1-4 ms after it,
    recorded by the force channel like the first (a linear or softening 5-60 Hz structure)."""
    sysd = system(rng, **dict(MIDDLE, f_rng=(5.0, 60.0)), z_rng=(0.004, 0.02), kind=_kind(rng, ["linear", "softening"]))
    fs = draw.pick_rate(rng, sysd["fn_hz"])
    pre, post = draw.timing(rng, sysd["fn_hz"], sysd["zeta"], fs, max_samples=60000)
    fmt = FORMATS[rng.integers(len(FORMATS))]
    levels = list(rng.uniform(0.5, 1.0, 4))
    bounced = sorted(rng.choice(4, 2, replace=False).tolist())
    tip, files, meta = None, [], []
    for c, s in enumerate(draw.sessions(rng, 4, snr=(38.0, 56.0))):
        p, tip = draw.hammer(rng, sysd, sysd["fn_hz"], levels[c], tip=tip, fs=fs)
        pulses = [p]
        if c in bounced:
            gap = max(float(rng.uniform(1e-3, 4e-3)), 1.5 * p[1])
            pulses.append([p[0] + gap, p[1], p[2] * float(rng.uniform(0.08, 0.25)), p[3]])
        t, ch = draw.record(rng, physics.System([sysd["mass"]], sysd["laws"]), pulses, fs, pre, post, s)
        files.append(os.path.basename(formats.write(os.path.join(out, f"{cid}-{c}"), fmt, t, ch, rng)))
        meta.append({"level": float(levels[c]), "session": s, "pulses": pulses})
    meta = {"fs": fs, "pre_s": pre, "post_s": post, "fmt": fmt, "tip": tip, "sensor": "acc", "captures": meta,
            "bounced": bounced}
    return _entry(files, sysd, meta, "double_hit", ["unexplained"])


def chain_adc12(rng, cid, out):
    """A 12-bit DAQ whose response range was set for a blow 3-6 times larger (9-10 effective bits on the ring-down,
    the tail a few quanta), 45-56 dB analogue noise; a 250-900 kg machine at 1-1.024 kHz, softening or hardening."""
    sysd = system(rng, **TONNE, z_rng=(0.01, 0.03), kind=_kind(rng, ["softening", "hardening"]), scale="tonne")
    files, meta = _captures(rng, cid, out, sysd, 4, fs=_rate(rng, *SLOW), snr=(45.0, 56.0),
                            chain={"bits": 12, "range_x": (3.0, 6.0)}, fmt=_kind(rng, ["csv-si", "csv-export"]))
    return _entry(files, sysd, meta, "adc12_quantisation", ["unexplained"])


def chain_fixture(rng, cid, out):
    """The structure sits on a fixture that is not rigid: a fixture of 0.5-1.5 x the structure's mass on its own
    spring, the system's second mode 3-6 x the first; the lab gives the structure's mass and measures on it.
    The measured signal holds two modes, so ``second_mode`` is the documented name."""
    for _ in range(200):
        sysd = system(rng, **dict(MIDDLE, f_rng=(8.0, 40.0)), z_rng=(0.004, 0.015),
                      kind=_kind(rng, ["linear", "hardening"]))
        m, k = sysd["mass"], sysd["laws"][0]["k"][1]
        mf = m * float(rng.uniform(0.5, 1.5))
        kf = mf * (2 * np.pi * sysd["fn_hz"] * float(rng.uniform(3.0, 6.0))) ** 2
        K = np.array([[k, -k], [-k, k + kf]])
        fr = physics.linear_freqs([m, mf], K)
        if 3.0 <= fr[1] / fr[0] <= 6.5 and all(abs(fr[1] / fr[0] - q) > 0.15 for q in (3.0, 4.0, 5.0, 6.0)):
            break
    zf = float(draw.loguni(rng, 0.01, 0.03))
    laws = [dict(sysd["laws"][0], j=1), {"law": "poly", "i": 1, "j": -1, "k": {1: kf},
                                         "c": {1: 2 * zf * np.sqrt(kf * mf)}}]
    sysd.update(fixture_mass=mf, fixture_k=kf, modes_hz=fr, f_top=fr[1])
    fs = draw.pick_rate(rng, fr[1])
    files, meta = _captures(rng, cid, out, sysd, 4, fs=fs,
                            system_fn=lambda c, pre, post: physics.System([m, mf], laws))
    return _entry(files, sysd, meta, "fixture_mode", ["second_mode", "unexplained"])


def null_noforce(rng, cid, out):
    """Free decays without a force channel (the hammer's cable not plugged in, or a release test): ``t,acc``
    only, each record starting 2-20 ms after the blow; a hardening or softening 0.3-20 kg structure, 20-2500 Hz
    rates. docs/diagnosis.md: captures are diagnosed with or without a force channel."""
    sysd = system(rng, **MIDDLE, z_rng=(0.004, 0.02), kind=_kind(rng, ["hardening", "softening"]))
    files, meta = _captures(rng, cid, out, sysd, 4, fmt="csv-si", levels=list(rng.uniform(0.5, 1.0, 4)),
                            post_fn=lambda t, ch, p: _cut_after_blow(rng, t, ch, p))
    return _entry(files, sysd, meta, None, ["none"])


def _cut_after_blow(rng, t, ch, p):
    """The record from 2-20 ms after the blow's end, without the force channel."""
    start = p[0] + p[1] + float(rng.uniform(0.002, 0.02))
    keep = t >= start
    return t[keep], {k: v[keep] for k, v in ch.items() if k != "force"}


def cat_absxtonne(rng, cid, out):
    """A smooth stiffening ``abs(x)*x`` (10-30 % of the stiffness at the reference amplitude) on a 250-900 kg
    machine at 2-6 Hz, sampled at 1-1.024 kHz, the blows at 35-100 %."""
    sysd = system(rng, **TONNE, z_rng=(0.01, 0.03), kind="absx", scale="tonne")
    files, meta = _captures(rng, cid, out, sysd, 4, fs=_rate(rng, *SLOW), levels=[1.0, 0.35, 0.7, 0.5],
                            fmt=_kind(rng, ["csv-export", "csv-si"]))
    return _entry(files, sysd, meta, "smooth_stiffening", ["smooth_stiffening"])


# ----------------------------------------------------------------------------- identification
IDENT = {
    "micro": "20-80 g at 120-500 Hz, 96-102.4 kHz, hardening or softening, any of the four layouts",
    "tonne": "250-900 kg at 2-6 Hz, 1-1.024 kHz, 1-4 % damping, hardening or softening, a logger's export",
    "noisy": "a cubic structure at 27-32 dB",
    "drag": "v, abs(v)*v and a linear or cubic spring (the true terms given)",
    "absx": "x, abs(x)*x and a dashpot (the true terms given)",
    "dragtonne": "v, abs(v)*v on 250-900 kg at 2-6 Hz, 1-1.024 kHz",
    "absxmicro": "x, abs(x)*x on 20-80 g at 120-500 Hz, 96-102.4 kHz",
    "noisymicro": "a cubic 20-80 g part at 96-102.4 kHz and 27-32 dB",
}


def ident_case(defect):
    """Identification with the true terms on the level-1 blow, validation on a 55-75 % blow (``score_ident``)."""
    def make(rng, cid, out):
        ranges, z_rng, fmt, fs, snr = MIDDLE, (0.004, 0.025), None, None, (36.0, 56.0)
        kind = _kind(rng, ["hardening", "softening"])
        if defect == "micro":
            ranges, fs = MICRO, _rate(rng, *FAST)
        elif defect == "tonne":
            ranges, z_rng, fmt, fs = TONNE, (0.01, 0.04), "csv-export", _rate(rng, *SLOW)
        elif defect == "noisy":
            snr = (27.0, 32.0)
        elif defect in ("drag", "absx"):
            kind = defect
        elif defect == "dragtonne":
            ranges, z_rng, fmt, fs, kind = TONNE, (0.005, 0.02), "csv-export", _rate(rng, *SLOW), "drag"
        elif defect == "absxmicro":
            ranges, fs, kind = MICRO, _rate(rng, *FAST), "absx"
        elif defect == "noisymicro":
            ranges, fs, snr = MICRO, _rate(rng, *FAST), (27.0, 32.0)
        sysd = system(rng, **ranges, z_rng=z_rng, kind=kind)
        if defect == "drag" and rng.random() < 0.5:
            sysd["laws"][0]["k"][3] = sysd["laws"][0]["k"][1] * rng.uniform(0.06, 0.2) / sysd["X_ref"] ** 2
        files, meta = _captures(rng, cid, out, sysd, 2, chain={"gain": 1.0, "ppm": 0.0}, fmt=fmt, fs=fs, snr=snr,
                                levels=[1.0, float(rng.uniform(0.55, 0.75))], two=False)
        damp, stiff = draw.truth_terms(sysd)
        return {"files": {"fit": files[0], "held": files[1]}, "truth": {"mass": sysd["mass"], "damping": damp,
                "stiffness": stiff}, "given_mass": sysd["mass"], "system": sysd, "meta": meta, "defect": defect,
                "warn_words": None, "refusal_ok": None, "args": [], "limit_cpu_s": IDENT_LIMIT}
    make.__doc__ = IDENT[defect]
    return make


# ----------------------------------------------------------------------------- growth
def grow_case(kind, ranges, rate, snr=(36.0, 56.0)):
    """A self-excited structure (``kind``: rayleigh, vdp or linneg) struck at 10-30 % of its limit cycle: the record
    grows to the limit cycle; ``identify --mass`` with the default libraries."""
    def make(rng, cid, out):
        sysd = system(rng, **ranges, z_rng=(0.004, 0.015), kind=kind)
        fs = _rate(rng, *rate) if rate else draw.pick_rate(rng, sysd["fn_hz"])
        lev = float(rng.uniform(0.1, 0.3) if kind != "linneg" else rng.uniform(0.05, 0.15))
        files, meta = _captures(rng, cid, out, sysd, 1, chain={"gain": 1.0, "ppm": 0.0}, fs=fs, fmt="csv-si",
                                levels=[lev], two=False, max_samples=60000, snr=snr)
        return {"files": files, "given_mass": sysd["mass"], "system": sysd, "meta": meta,
                "limit_cpu_s": IDENT_LIMIT}
    make.__doc__ = f"a self-excited ({kind}) record, the model grows from small amplitudes"
    return make


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


def _coupling_effect(ms, laws, drive, p, fs, post, names):
    """Per channel, the nrmse between the held blow's clean response with the nonlinear terms and without them."""
    lin = [dict(L, k={q: v for q, v in L["k"].items() if int(q) == 1}) if L["law"] == "poly" else L for L in laws]
    t = np.arange(0, int(post * fs)) / fs
    pulse = [tuple(p[:3]) + (tuple(p[3]),)]
    a_nl = physics.simulate(physics.System(ms, laws, drive=drive), pulse, t)[2]
    a_li = physics.simulate(physics.System(ms, lin, drive=drive), pulse, t)[2]
    after = t > 2 * p[1]
    return {n: float(np.sqrt(np.mean((a_nl[i, after] - a_li[i, after]) ** 2) / np.mean(a_nl[i, after] ** 2)))
            for i, n in enumerate(names)}


MDOF_SCALES = {  # mass [kg], first mode [Hz], reference displacement [m], DAQ rates
    "tonne": ((250.0, 2500.0), (2.0, 8.0), (1e-3, 6e-3), (1000, 1024)),
    "kilo": ((0.5, 20.0), (8.0, 50.0), (2e-4, 2e-3), None),
    "grams": ((0.01, 0.15), (60.0, 250.0), (1e-5, 1e-4), (20000, 51200)),
}


def mdof_case(n_mass, coupling=None, scale="kilo", fmt=None, snr=(40.0, 55.0), missing_copy=False):
    """A chain of ``n_mass`` masses to the ground, struck at a mass other than the first, every mass measured with
    an accelerometer, no mass given. ``coupling``: ``"link1"`` a cubic spring on the link between masses 0 and 1
    (15-40 % of its linear force at the level-1 stretch), None linear. ``missing_copy``: the held capture also
    written as the station's CSV without its last response channel (``bad-mdofmissing.csv``, for badinputs.py;
    no draw added)."""
    def make(rng, cid, out):
        (m0, m1), (f0, f1), (x0, x1), rates = MDOF_SCALES[scale]
        for _ in range(400):
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
            fs_ok = rates is None or 25 * max(fr) <= rates[1]
            if (min(rs) > 1.35 and all(abs(r - q) > 0.12 for r in rs for q in (2.0, 3.0)) and struck >= 0.3
                    and fs_ok):
                break
        else:
            raise RuntimeError("no chain drawn")
        X = draw.loguni(rng, x0, x1)
        zeta = draw.loguni(rng, 0.005, 0.02)
        laws = [{"law": "poly", "i": i, "j": i - 1, "k": {1: kv}, "c": {1: 2 * zeta * np.sqrt(kv * ms[i])}}
                for i, kv in enumerate(ks)]
        system_ = physics.System(ms, laws, drive=d)
        f_hi = max(fr)
        if rates is None:
            fs = draw.pick_rate(rng, f_hi)
        else:
            ok = [r for r in draw.RATES if rates[0] <= r <= rates[1] and r >= 25 * f_hi]
            fs = int(ok[rng.integers(len(ok))])
        sysd = {"mass": ms[d], "fn_hz": fr[0], "X_ref": X}
        p, _ = draw.hammer(rng, sysd, f_hi, 1.0, width_frac=0.1, tip="plastic", fs=fs)
        if coupling:
            tp = np.arange(0, int(6 / fr[0] * fs)) / fs
            xp = physics.simulate(system_, [tuple(p[:3]) + (tuple(p[3]),)], tp)[0]
            share = rng.uniform(0.15, 0.4)
            stretch = float(np.abs(xp[1] - xp[0]).max())
            laws[1]["k"] = {1: ks[1], 3: ks[1] * share / stretch ** 2}
            system_ = physics.System(ms, laws, drive=d)
        labels = list(rng.choice(["deck", "frame", "motor", "plate", "cab", "boom", "arm", "base"], n_mass,
                                 replace=False))
        names = [f"acc_{lab}" for lab in labels]
        pre, post = draw.timing(rng, fr[0], zeta, fs, max_samples=30000)
        files, tip, noise = [], None, []
        levels = list(rng.uniform(0.5, 1.0, 4))
        f_ = fmt or ["csv-si", "csv-export"][rng.integers(2)]
        for c, s in enumerate(draw.sessions(rng, 4, snr=snr)):
            s["names"] = names
            p, tip = draw.hammer(rng, sysd, f_hi, levels[c], width_frac=rng.uniform(0.05, 0.15), tip=tip, fs=fs)
            t, ch = draw.record(rng, system_, [p], fs, pre, post, s)
            noise.append(s["noise_nrmse_ch"])
            files.append(os.path.basename(formats.write(os.path.join(out, f"{cid}-{c}"), f_, t, ch, rng)))
        extra = {}
        if missing_copy:
            kept = {k: v for k, v in ch.items() if k != names[-1]}
            extra["missing_copy"] = os.path.basename(formats.write(os.path.join(out, "bad-mdofmissing"), "csv-si", t,
                                                                   kept, rng))
        effect = _coupling_effect(ms, laws, d, p, fs, post, names) if coupling else {}
        return {"files": {"train": files[:3], "held": files[3]}, "all_files": files, "driving_point": names[d],
                "columns": names, "coupling_effect_nrmse": effect, "freqs_hz": fr, "masses": ms, "laws": laws,
                "fs": fs, "coupling": coupling, "gyro": False, "noise_nrmse": noise, "sensor": "acc", "fmt": f_,
                "scale": scale, **extra}
    return make


CASES = [
    ("mdof-2tonne-lin", "mdof", mdof_case(2, None, scale="tonne", fmt="csv-export"), True),
    ("mdof-2noisy-link", "mdof", mdof_case(2, "link1", snr=(33.0, 37.0), missing_copy=True), True),
    ("mdof-3grams-lin", "mdof", mdof_case(3, None, scale="grams"), True),
    ("mdof-2tonne-link", "mdof", mdof_case(2, "link1", scale="tonne"), False),
    ("mdof-2grams-link", "mdof", mdof_case(2, "link1", scale="grams", fmt="csv-export"), True),
    ("null-micro", "diagnose", null_micro, True),
    ("null-tonne", "diagnose", null_tonne, True),
    ("null-noisy", "diagnose", null_noisy, True),
    ("cat-dragmicro", "diagnose", cat_dragmicro, True),
    ("hid-kstep", "diagnose", hid_kstep, True),
    ("chain-settle", "diagnose", chain_settle, True),
    ("chain-cablewhip", "diagnose", chain_cablewhip, True),
    ("chain-gainstep", "diagnose", chain_gainstep, True),
    ("chain-doublehit", "diagnose", chain_doublehit, True),
    ("cat-absxtonne", "diagnose", cat_absxtonne, True),
    ("chain-adc12", "diagnose", chain_adc12, True),
    ("chain-fixture", "diagnose", chain_fixture, True),
    ("id-micro", "ident", ident_case("micro"), True),
    ("id-tonne", "ident", ident_case("tonne"), True),
    ("id-noisy", "ident", ident_case("noisy"), True),
    ("id-drag", "ident", ident_case("drag"), True),
    ("id-absx", "ident", ident_case("absx"), True),
    ("id-dragtonne", "ident", ident_case("dragtonne"), True),
    ("id-absxmicro", "ident", ident_case("absxmicro"), True),
    ("id-noisymicro", "ident", ident_case("noisymicro"), True),
    ("null-noforce", "diagnose", null_noforce, True),
    ("grow-rayleigh-tonne", "grow", grow_case("rayleigh", TONNE, SLOW), True),
    ("grow-vdp-micro", "grow", grow_case("vdp", MICRO, FAST), True),
    ("grow-linneg-noisy", "grow", grow_case("linneg", MIDDLE, None, snr=(28.0, 33.0)), True),
]
