"""Diagnosis cases of the second blind scorecard: nulls and hidden effects at two strengths.

Each case is a set of captures of one structure (``captures``, in time order) with the truth
(``hidden``, ``strength``, ``expect``: the verdicts that are right, ``near``: look-alikes
that are physically defensible, ``symptom``: a symptom kind that must be reported).
"""

from __future__ import annotations

import copy
import math

from cases import RATES, _loguni, base_system, blow, chain

# name: (catalogued?, expected causes, near causes, symptom)
EFFECTS = {
    "sensor_highpass": (True, {"sensor_highpass"}, set(), None),
    "quadratic_drag": (True, {"quadratic_damping"}, set(), None),
    "smooth_friction": (True, {"coulomb_friction"}, set(), None),
    "contact_gap": (True, {"clearance"}, {"smooth_stiffening"}, None),
    "coupled_mode": (True, {"second_mode"}, set(), None),
    "dahl_hysteresis": (False, {"unexplained"}, {"coulomb_friction"}, None),
    "stiffness_drift": (False, {"unexplained"}, set(), None),
    "sensor_resonance": (False, {"unexplained"}, {"second_mode"}, None),
    "base_motion": (False, {"unexplained", "second_mode"}, set(), "base_motion"),
    "double_hit": (False, {"none"}, {"unexplained"}, "double_hit"),
    "force_gain": (False, {"unexplained"}, {"none"}, "impulse_mass"),
    "analog_saturation": (False, {"unexplained"}, {"none"}, "clipping"),
    "adc_overload": (False, {"unexplained", "refused"}, {"none"}, "clipping"),
}

# strengths: weak / strong (see _hide)
STRENGTHS = {
    "sensor_highpass": (0.025, 0.10),     # corner / f1
    "quadratic_drag": (0.01, 0.05),       # drag at V over k1 A
    "smooth_friction": (0.002, 0.01),     # fc over k1 A
    "contact_gap": (0.5, 3.0),            # contact stiffness over k1 (gap 0.5 A)
    "coupled_mode": (0.05, 0.25),         # m2 / m
    "dahl_hysteresis": (0.005, 0.02),     # fc over k1 A
    "stiffness_drift": (0.01, 0.04),      # k1 change per capture
    "sensor_resonance": (12.0, 4.0),      # f_r / f1
    "base_motion": (10.0, 2.0),           # base mass / m
    "double_hit": (None, 0.35),
    "force_gain": (None, 1.3),
    "analog_saturation": (None, 0.6),
    "adc_overload": (None, 0.75),
}


def _structure(rng, kind):
    m = _loguni(rng, 0.05, 50.0)
    f = _loguni(rng, 6.0, 60.0) if kind != "sensor_highpass" else float(rng.uniform(12.0, 25.0))
    zeta = _loguni(rng, 0.002, 0.01)
    amp = _loguni(rng, 5e-4, 5e-3)
    sys, (k1, A, V) = base_system(m, f, zeta, amp)
    shift = float(rng.uniform(-0.04, 0.08))  # softening or hardening backbone, % frequency shift
    sys["stiffness"]["x^3"] = shift / 0.375 * k1 / A ** 2
    return sys, f, zeta, (k1, A, V)


def _hide(sys, name, s, f, scales, rng):
    k1, A, V = scales
    sen = {}
    if name == "sensor_highpass":
        sen["highpass_hz"] = s * f
    elif name == "quadratic_drag":
        sys["damping"]["abs(v)*v"] = s * k1 * A / V ** 2
    elif name == "smooth_friction":
        sys["friction"] = {"fc": s * k1 * A, "vs": 0.003 * V}
    elif name == "contact_gap":
        sys["contact"] = {"gap": 0.5 * A, "k": s * k1}
    elif name == "coupled_mode":
        m2 = s * sys["mass"]
        f2 = 3.1 * f
        k = m2 * (2 * math.pi * f2) ** 2
        sys["mode2"] = {"mass": m2, "k": k, "c": 2 * 0.01 * math.sqrt(k * m2)}
    elif name == "dahl_hysteresis":
        fc = s * k1 * A
        sys["dahl"] = {"fc": fc, "sigma": fc / (0.1 * A)}
    elif name == "sensor_resonance":
        sen["resonance_hz"] = s * f
        sen["resonance_zeta"] = 0.02
    elif name == "base_motion":
        mb = s * sys["mass"]
        kb = (mb + sys["mass"]) * (2 * math.pi * 0.25 * f) ** 2
        sys["base"] = {"mass": mb, "k": kb, "c": 2 * 0.03 * math.sqrt(kb * mb)}
    if sen:
        sys["sensor"] = sen


def diagnose_cases(rng, quick):
    """Nulls (6 captures each: two sessions) and hidden effects (3 captures)."""
    out = []
    n_null = 2 if quick else 6
    for i in range(n_null):
        out.append(_case(rng, f"null-{i}", None, None, 6, quick))
    for name in EFFECTS:
        weak, strong = STRENGTHS[name]
        levels = [("strong", strong)] if quick else [("weak", weak), ("strong", strong)]
        for tag, s in levels:
            if s is None:
                continue
            if quick and name not in QUICK_EFFECTS:
                continue
            out.append(_case(rng, f"{name}-{tag}", name, s, 3, quick, tag))
    return out


QUICK_EFFECTS = ("sensor_highpass", "quadratic_drag", "smooth_friction", "coupled_mode", "dahl_hysteresis",
                 "stiffness_drift", "base_motion", "force_gain")


def _case(rng, cid, name, s, n_caps, quick, tag=None):
    sys, f, zeta, scales = _structure(rng, name)
    null_sys = copy.deepcopy(sys)
    if name:
        _hide(sys, name, s, f, scales, rng)
    fs = _pick_rate(rng, f, quick)
    t_max = 3.0 if quick else 6.0
    duration = float(min(max(math.log(30) / (2 * math.pi * f * zeta), 1.5), t_max))
    snr = float(rng.uniform(32, 55))
    bits = 24 if rng.uniform() < 0.7 else 16
    # blow levels in time order; not monotone, so a drift between captures is not an amplitude effect
    levels = [0.8, 0.6, 1.0] if n_caps == 3 else [0.8, 0.6, 1.0, 0.7, 0.95, 0.85]
    caps = []
    session_ppm = [float(rng.uniform(-150, 150)), float(rng.uniform(-150, 150))]
    for j, lev in enumerate(levels):
        pre = float(rng.uniform(0.05, 0.25))
        t0 = pre + float(rng.uniform(0, 1.0 / fs))
        extra = {}
        if name == "force_gain":
            extra["force_gain"] = s
        if name == "analog_saturation":
            extra["clip_analog"] = s
        if name == "adc_overload":
            extra["clip_adc"] = s
        ch = chain(rng, fs, duration + pre, snr, bits, **extra)
        ch["ppm"] = session_ppm[j // 3] + float(rng.uniform(-2, 2))
        if j >= 3:  # the second session's DAQ stamps the rate it measured for itself (within 5 ppm)
            ch["stamp_ppm"] = session_ppm[1] + float(rng.uniform(-5, 5))
        cap_sys = sys
        if name == "stiffness_drift":
            cap_sys = copy.deepcopy(sys)
            cap_sys["k_scale"] = 1.0 + s * j
        double = {"delay": 0.15, "ratio": s} if name == "double_hit" else None
        hits = blow(sys, f, scales[1], t0, lev * float(rng.uniform(0.93, 1.07)), fs,
                    shape=("halfsine" if rng.uniform() < 0.5 else "haversine"), double=double)
        caps.append({"file": f"{cid}-c{j}.csv", "hits": hits, "chain": ch, "system": cap_sys, "session": j // 3})
    cat, expect, near, symptom = EFFECTS[name] if name else (None, {"none"}, set(), None)
    return {"id": cid, "kind": "diagnose", "hidden": name, "strength_tag": tag, "strength": s,
            "catalogued": cat, "expect": sorted(expect), "near": sorted(near), "symptom": symptom,
            "mass": sys["mass"], "f1_hz": f, "zeta": zeta, "fs": fs, "snr_db": snr, "bits": bits,
            "system": sys, "null_system": null_sys, "captures": caps}


def _pick_rate(rng, f, quick):
    ok = [r for r in RATES if r >= 50 * f and (not quick or r <= 10000)]
    return int(ok[int(rng.integers(0, min(3, len(ok))))]) if ok else 10000
