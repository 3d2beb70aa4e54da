"""Random draws of the thirteenth scorecard (unseen12's; rates to 102.4 kHz, the chain's settling offset and cable
spikes, the terms abs(v)*v, v^3 and abs(x)*x): systems, hammers, sessions.

Every draw comes from ``rng`` (seeded per case by ``generate.py``). Nothing imported from the station.
"""

from __future__ import annotations

import numpy as np

import formats
import physics

RATES = [256, 400, 500, 512, 1000, 1024, 1280, 2000, 2048, 2500, 2560, 4000, 4096, 5000, 5120, 8000, 8192,
         10000, 10240, 12800, 16384, 20000, 25600, 32768, 40000, 48000, 51200, 96000, 100000, 102400]
SCALES = {  # mass [kg], natural frequency [Hz], reference displacement [m]
    "feather": ((0.0008, 0.004), (150.0, 900.0), (3e-6, 4e-5)),
    "heavy": ((5000.0, 40000.0), (0.8, 4.0), (3e-3, 2e-2)),
    "grams": ((0.004, 0.15), (25.0, 180.0), (2e-5, 4e-4)),
    "kilograms": ((0.4, 25.0), (6.0, 70.0), (2e-4, 3e-3)),
    "tonnes": ((80.0, 4000.0), (1.5, 12.0), (1e-3, 1.2e-2)),
}
SHAPES = {"steel": (1.0, 1.0), "plastic": (2.0, 2.0), "rubber": (1.5, 3.5)}


def loguni(rng, lo, hi):
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def base_system(rng, scale=None, kind="hardening"):
    """A single-DOF system inside the station's default libraries; returns a dict (JSON-able)."""
    scale = scale or ["grams", "kilograms", "tonnes"][rng.integers(3)]
    (m0, m1), (f0, f1), (x0, x1) = SCALES[scale]
    m, fn, X = loguni(rng, m0, m1), loguni(rng, f0, f1), loguni(rng, x0, x1)
    k = m * (2 * np.pi * fn) ** 2
    zeta = loguni(rng, 0.004, 0.025)
    c = 2 * zeta * np.sqrt(k * m)
    kk = {1: k}
    cx2v = 0.0
    if kind == "hardening":
        kk[3] = k * rng.uniform(0.06, 0.3) / X ** 2
    elif kind == "softening":
        kk[3] = -k * rng.uniform(0.04, 0.1) / X ** 2
    elif kind == "softstiff":  # softening at small stretch, stiffening at large (tangent stiffness > 0)
        kk[3] = -k * rng.uniform(0.15, 0.3) / X ** 2
        kk[5] = k * rng.uniform(0.08, 0.2) / X ** 4
    elif kind == "asym":
        kk[2] = k * rng.uniform(0.08, 0.2) * rng.choice([-1, 1]) / X
        kk[3] = k * rng.uniform(0.03, 0.15) / X ** 2
    if kind in ("asym", "nldamp") or rng.random() < 0.3:
        cx2v = c * rng.uniform(0.5, 2.0) / X ** 2
    return {"scale": scale, "mass": m, "fn_hz": fn, "X_ref": X, "zeta": zeta,
            "laws": [{"law": "poly", "i": 0, "k": kk, "c": {1: c}, "cx2v": cx2v}]}


def truth_terms(sysd):
    """The station's term names and SI coefficients of the polynomial law (damping, stiffness)."""
    L = sysd["laws"][0]
    stiff = {("x" if int(p) == 1 else f"x^{int(p)}"): float(v) for p, v in L["k"].items()}
    if L.get("kabs"):
        stiff["abs(x)*x"] = float(L["kabs"])
    damp = {"v": float(L["c"][1])}
    if L.get("cx2v"):
        damp["x^2*v"] = float(L["cx2v"])
    for p, name in ((2, "abs(v)*v"), (3, "v^3")):
        if L["c"].get(p):
            damp[name] = float(L["c"][p])
    return damp, stiff


def pick_rate(rng, fn_hz_max):
    ok = [r for r in RATES if 25 * fn_hz_max <= r <= 150 * fn_hz_max and r >= 500]
    if not ok:
        ok = [min([r for r in RATES if r >= 500], key=lambda r: abs(np.log(r / (40 * fn_hz_max))))]
    return int(ok[rng.integers(len(ok))])


def timing(rng, fn, zeta, fs, max_samples=90000):
    """Pre-trigger and post-trigger durations [s]: decay to ~3 % within the sample budget."""
    post = np.log(30.0) / (zeta * 2 * np.pi * fn) * rng.uniform(0.9, 1.4)
    pre = rng.uniform(0.05, 0.2) * post if rng.random() < 0.5 else rng.uniform(0.01, 0.1)
    total = pre + post
    if total * fs > max_samples:
        s = max_samples / (total * fs)
        pre, post = pre * s, post * s
    return float(pre), float(post)


def hammer(rng, sysd, fn_low, level, width_frac=None, tip=None, fs=None):
    """Pulse (t0, width, peak, shape) giving a free response near ``level * X_ref`` (linear pilot).

    The pulse lasts at least 6 samples at ``fs``: the records are point samples (no anti-alias filter
    is modelled), so a lab's choice of tip that its DAQ resolves is assumed (a blow of one or two
    samples would lose its impulse, which no station can recover)."""
    tip = tip or list(SHAPES)[rng.integers(3)]
    shape = SHAPES[tip]
    width = (width_frac or rng.uniform(0.04, 0.18)) / fn_low
    if fs:
        width = max(width, 6.0 / fs)
    impulse = sysd["mass"] * 2 * np.pi * sysd["fn_hz"] * sysd["X_ref"] * level
    peak = impulse / physics.pulse_area(width, shape)
    return [0.0, float(width), float(peak), list(shape)], tip


def record(rng, system, pulses, fs, pre, post, session, sensor="acc", extra=None, y0=None):
    """Simulate and measure one capture. ``session``: dict(ppm, gain, snr_db, bits, hp_hz, gain_drift,
    clip_frac). Returns (t_stamped, channels dict) with response channels per mass (``sensor`` kind)."""
    n_pre, n_post = int(round(pre * fs)), int(round(post * fs))
    k = np.arange(-n_pre, n_post)
    jitter = rng.uniform(0.0, 1.0 / fs)  # the blow starts between samples
    t_true = k / (fs * (1 + 1e-6 * session["ppm"])) - jitter
    if session.get("jitter_frac"):  # a cheap DAQ: each sample taken off its stamped instant (rms, periods)
        t_true = t_true + rng.normal(0.0, session["jitter_frac"] / fs, len(k))
    pl = [tuple(p[:3]) + (tuple(p[3]),) for p in pulses]
    x, v, a, f = physics.simulate(system, pl, t_true, y0=y0)
    if session.get("force_delay_s") is not None or session.get("force_ppm"):
        # the force on a second DAQ (an analyser of its own): its clock force_ppm off the response DAQ's and a
        # trigger latency (its sample k taken at the response DAQ's instant k + delay); the response is the
        # time reference, so the free response is exact and only the blow is misplaced and stretched
        t_f = t_true * (1 + 1e-6 * session.get("force_ppm", 0.0)) + session.get("force_delay_s", 0.0)
        f = np.array([sum(float(physics.pulse(tt, *p)) for p in pl) for tt in t_f])
    truth = {"acc": a, "vel": v, "disp": x}[sensor]
    fclip = session.get("force_clip")  # an absolute level [N]: the force channel's ADC range
    chans = {"force": formats.measure(f, fs, rng, snr_db=session["snr_db"] + 10, bits=session["bits"],
                                      range_x=rng.uniform(1.3, 2.5), peak=np.abs(f).max(), clip=fclip,
                                      aa=session.get("aa") if session.get("aa_force") else None)}
    names = session.get("names") or [sensor]
    after = k > int(2 * max(p[1] for p in pulses) * fs) + 1
    for i, name in enumerate(names):
        y = truth[i] if not session.get("sensors") else {"acc": a, "vel": v, "disp": x}[session["sensors"][i]][i]
        peak = np.abs(y[after]).max()
        clip = session.get("clip_frac") and session["clip_frac"] * peak
        hum = session.get("hum_db") and (peak * 10 ** (-session["hum_db"] / 20), session["hum_hz"],
                                         rng.uniform(0, 2 * np.pi))
        step = session.get("step_frac") and (peak * session["step_frac"],
                                             n_pre + int(session["step_at"] * n_post))
        # the nrmse white noise alone gives against the clean response after the blow (the judge's allowance)
        nn = float(peak * 10 ** (-session["snr_db"] / 20) / np.sqrt(np.mean(y[after] ** 2)))
        if session.get("lsb_frac"):  # a coarse converter's own noise (uniform, lsb / sqrt(12))
            nn = float(np.hypot(nn, session["lsb_frac"] * peak / np.sqrt(12) / np.sqrt(np.mean(y[after] ** 2))))
        session["noise_nrmse"] = max(session.get("noise_nrmse", 0.0), nn)
        session.setdefault("noise_nrmse_ch", {})[name] = nn
        rx = session.get("range_x") or (1.4, 2.8)
        mount = session.get("mount_hz") and (session["mount_hz"], session["mount_zeta"])
        # cross-talk: the hammer channel's signal leaks into the conditioner, scaled to the response's peak
        xt = session.get("xtalk_frac") and f / max(np.abs(f).max(), 1e-300) * peak * session["xtalk_frac"]
        sat = session.get("sat_x") and session["sat_x"] * peak
        lsb = session.get("lsb_frac") and session["lsb_frac"] * peak
        chans[name] = formats.measure(y, fs, rng, snr_db=session["snr_db"], bits=session["bits"],
                                      range_x=rng.uniform(*rx), gain=session["gain"],
                                      gain_drift=session.get("gain_drift", 0.0), hp_hz=session.get("hp_hz", 0.0),
                                      clip=clip or None, peak=peak, hum=hum or None, step=step or None,
                                      mount=mount or None, xtalk=xt if isinstance(xt, np.ndarray) else None,
                                      sat=sat or None, lsb=lsb or None, aa=session.get("aa"),
                                      hp2_hz=session.get("hp2_hz", 0.0),
                                      settle=session.get("settle") and (peak * session["settle"][0],
                                                                        session["settle"][1], n_pre),
                                      spikes=session.get("spikes") and [(n_pre + int(q * n_post), peak * amp, w)
                                                                        for q, amp, w in session["spikes"]],
                                      drift=session.get("drift") and (peak * session["drift"][0],
                                                                      peak * session["drift"][1]),
                                      dropout=_dropouts(rng, session.get("dropouts"), n_pre, n_post,
                                                       session.get("dropout_value", 0.0)))
    return k / fs, chans


def _dropouts(rng, count, n_pre, n_post, value=0.0):
    """``count`` dropouts of 1-3 samples in the first half of the ring-down (eleventh set), as (start, length,
    the value the decoder outputs: 0, or NaN when the software marks them)."""
    if not count:
        return None
    starts = rng.choice(np.arange(n_pre + n_post // 50, n_pre + n_post // 2), int(count), replace=False)
    return [(int(s), int(rng.integers(1, 4)), float(value)) for s in sorted(starts)]


def sessions(rng, n_captures, snr=(32.0, 58.0), two=True):
    """One DAQ and one calibrated accelerometer over two sessions (re-mounted, clock drifting)."""
    ppm = rng.uniform(-50, 50)
    gain = 1 + rng.uniform(-0.01, 0.01)
    snr_db = rng.uniform(*snr)
    bits = int(rng.choice([16, 24]))
    out = []
    split = n_captures // 2 if two else n_captures
    s2 = {"ppm": ppm + rng.uniform(-2, 2), "gain": gain * (1 + rng.uniform(-0.003, 0.003))}
    for c in range(n_captures):
        s = {"ppm": ppm, "gain": gain} if c < split else dict(s2)
        s.update(snr_db=snr_db + rng.uniform(-1.5, 1.5), bits=bits)
        out.append(s)
    return out
