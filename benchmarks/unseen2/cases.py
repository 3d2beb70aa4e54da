"""Cases of the second blind scorecard, drawn from a seed (systems, chains, hidden effects).

Every case is a JSON-able dict; ``generate.py`` simulates its records and writes them with the
truth into ``manifest.json``. Nonlinear strengths are set relative to the linear spring force
at the typical amplitude ``A`` (the peak displacement an impulse ``J`` gives a linear
oscillator, ``A = J / (m w)``), so they mean the same thing at every mass and frequency.
"""

from __future__ import annotations

import math


RATES = (2000, 5000, 10000, 20000, 50000)


def _loguni(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def base_system(m, f, zeta, amp):
    """Linear oscillator ``m``, ``f`` [Hz], damping ratio ``zeta``; ``amp`` the typical
    amplitude [m]. Returns the system dict and its scales ``(k1, A, V)``."""
    k1 = m * (2 * math.pi * f) ** 2
    c = 2 * zeta * math.sqrt(k1 * m)
    sys = {"mass": m, "damping": {"v": c}, "stiffness": {"x": k1}}
    return sys, (k1, amp, amp * 2 * math.pi * f)


def blow(sys, f, amp, t0, level, fs, shape="haversine", double=None):
    """Hammer pulses for a blow of ``level`` times the impulse that gives amplitude ``amp``."""
    m = sys["mass"]
    impulse = level * amp * m * 2 * math.pi * f
    dur = max(0.04 / f, 6.0 / fs)
    dur = min(dur, 0.2 / f)
    peak = impulse / (dur * (0.5 if shape == "haversine" else 2 / math.pi))
    hits = [{"t0": t0, "dur": dur, "peak": peak, "shape": shape}]
    if double:
        hits.append({"t0": t0 + double["delay"] / f, "dur": dur, "peak": peak * double["ratio"], "shape": shape})
    return hits


def chain(rng, fs, duration, snr, bits=24, **extra):
    """A DAQ chain with this lab's habits: clock error, offsets, a little gain drift."""
    c = {"fs": fs, "duration": duration, "ppm": float(rng.uniform(-150, 150)), "bits": bits, "snr_db": snr,
         "offset": float(rng.uniform(-3e-3, 3e-3)), "force_offset": float(rng.uniform(-2e-3, 2e-3)),
         "drift": float(rng.uniform(-2e-3, 2e-3)), "range": float(rng.uniform(1.3, 3.0))}
    c.update(extra)
    return c


def _duration(f, zeta, cycles_max=80, t_max=6.0, t_min=1.5):
    """Long enough to decay to ~2 % (or ``cycles_max`` cycles), within [t_min, t_max] s."""
    t_decay = math.log(50) / (2 * math.pi * f * max(zeta, 1e-4))
    return float(min(max(min(t_decay, cycles_max / f), t_min), t_max))


# ----------------------------------------------------------------------------- identify


def identify_cases(rng, quick):
    """Systems for ``station identify`` (true-library and default-library runs)."""
    specs = [
        # id, m, f, zeta, nonlinear spec, fs, bits, snr, extras
        ("lin-light", 2.0, 8.0, 0.002, {}, 2000, 16, 50, {"duration": 12.0}),
        ("lin-heavy", 0.3, 30.0, 0.08, {}, 10000, 24, 45, {}),
        ("hard-cubic", 0.1, 40.0, 0.005, {"x^3": 0.4}, 20000, 24, 40, {}),
        ("soft-cubic", 1.0, 12.0, 0.004, {"x^3": -0.12}, 5000, 16, 40, {}),
        ("quad-drag", 0.5, 20.0, 0.001, {"abs(v)*v": 0.03}, 5000, 24, 45, {}),
        ("smooth-coulomb", 5.0, 6.0, 0.002, {"friction": 0.01}, 2000, 24, 45, {}),
        ("x-abs-x", 0.2, 50.0, 0.003, {"abs(x)*x": 0.25}, 20000, 24, 40, {"hum": 3e-3}),
        ("van-der-pol", 0.1, 25.0, -0.01, {"vdp": 2.0}, 5000, 24, 45, {"duration": 3.0}),
        ("heavy-50kg", 50.0, 2.5, 0.01, {"x^3": 0.15}, 2000, 16, 40, {"hum": 3e-3, "duration": 20.0}),
        ("light-50g", 0.05, 280.0, 0.003, {"x^3": 0.15}, 50000, 24, 45, {"duration": 1.0}),
        ("few-cycles", 0.8, 15.0, 0.12, {"x^3": 0.5}, 5000, 24, 40, {}),
        ("asym-quad", 0.4, 18.0, 0.004, {"x^2": 0.15, "x^3": 0.2}, 5000, 24, 40, {}),
        ("cubic-damp-vel", 0.25, 35.0, 0.002, {"v^3": 0.02}, 10000, 24, 45, {"quantity": "vel"}),
        ("double-hit", 0.6, 60.0, 0.004, {"x^3": 0.2}, 2000, 24, 40, {"double": {"delay": 0.12, "ratio": 0.35}}),
        ("free-decay", 0.15, 22.0, 0.003, {"x^3": 0.3}, 10000, 24, 45, {"cut_after_hit": 0.01}),
    ]
    if quick:
        specs = [s for s in specs if s[0] not in ("cubic-damp-vel", "double-hit", "free-decay")]
    out = []
    for sid, m0, f0, zeta, nl, fs, bits, snr, ex in specs:
        m = m0 * float(rng.uniform(0.9, 1.1))
        f = f0 * float(rng.uniform(0.93, 1.07))
        amp = _loguni(rng, 5e-4, 5e-3)
        sys, (k1, A, V) = base_system(m, f, abs(zeta), amp)
        dmp, stf = ["v"], ["x"]
        for term, s in nl.items():
            if term in ("x^3",):
                sys["stiffness"][term] = s * k1 / A ** 2
                stf.append(term)
            elif term == "x^2":
                sys["stiffness"][term] = s * k1 / A
                stf.append(term)
            elif term == "abs(x)*x":
                sys["stiffness"][term] = s * k1 / A
                stf.append(term)
            elif term == "abs(v)*v":
                sys["damping"][term] = s * k1 * A / V ** 2
                dmp.append(term)
            elif term == "v^3":
                sys["damping"][term] = s * k1 * A / V ** 3
                dmp.append(term)
            elif term == "friction":
                sys["friction"] = {"fc": s * k1 * A, "vs": 0.003 * V}
                dmp.append("sign(v)")
            elif term == "vdp":
                # m x'' + (-c0 + c2 x^2) v + k x: limit cycle at 2 sqrt(c0 / c2) = s A
                c0 = sys["damping"]["v"]
                sys["damping"] = {"v": -c0, "x^2*v": 4 * c0 / (s * A) ** 2}
                dmp.append("x^2*v")
        ch = dict(ex)
        duration = ch.pop("duration", _duration(f, abs(zeta)))
        double = ch.pop("double", None)
        truth = {"damping": dict(sys["damping"]), "stiffness": dict(sys["stiffness"])}
        if "friction" in sys:
            truth["damping"]["sign(v)"] = sys["friction"]["fc"]
        records = []
        for role, level in (("train", 1.0), ("heldout", 0.7)):
            pre = float(rng.uniform(0.05, 0.3)) if "cut_after_hit" not in ch else 0.02
            t0 = pre + float(rng.uniform(0, 1.0 / fs))
            records.append({
                "file": f"id-{sid}-{role}.csv", "role": role,
                "hits": blow(sys, f, A, t0, level * float(rng.uniform(0.95, 1.05)), fs,
                             shape=("halfsine" if rng.uniform() < 0.5 else "haversine"), double=double),
                "chain": chain(rng, fs, duration + pre, snr, bits, **ch),
            })
            if role == "train":  # a calibrated sensor on the fit record: the 95 % intervals are judged
                records[-1]["chain"]["drift"] = 0.0  # against the truth and the clock error alone
        out.append({"id": f"id-{sid}", "kind": "identify", "system": sys, "mass": m, "f1_hz": f,
                    "amplitude_m": A, "library": {"damping": dmp, "stiffness": stf}, "truth": truth,
                    "unstable": zeta < 0, "records": records})
    return out
