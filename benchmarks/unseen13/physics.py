"""Mechanics of the thirteenth blind scorecard (unseen12's; the poly law takes ``kabs``, a term ``kabs |s| s``): lumped
masses, scipy.

Nothing here imports the station. One equation per mass,

    M x'' + C x' + K x + f_nl(x, x', t) = b F(t) + f_base(t)

integrated with ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10) in segments split at the edges of
every hammer pulse, sampled at the DAQ's sample times (point samples of the true state). The laws
(``f_nl``) are dictionaries so the manifest can store them:

- ``{"law": "poly", "i": 0, "j": -1, "k": {1: k1, 3: k3}, "c": {1: c1}, "cx2v": b}``: a spring and
  dashpot between mass i and mass j (``-1`` the ground), polynomial in the stretch, plus ``b s^2 s'``;
- ``{"law": "coulomb", "i": 0, "fc": N, "veps": m/s}``: smoothed dry friction ``fc tanh(v / veps)``;
- ``{"law": "gap", "i": 0, "gap": m, "kc": N/m, "cc": N s/m}``: two-sided contact beyond a gap;
- ``{"law": "drag", "i": 0, "cq": N s^2/m^2}``: quadratic drag ``cq v |v|``;
- ``{"law": "parametric", "i": 0, "k": N/m, "eps": -, "f_hz": Hz, "phase": rad}``: a stiffness modulated
  in time ``k eps sin(2 pi f t + phase) x`` (a rotating part nearby, a pumped support);
- ``{"law": "tone", "i": 0, "amp": N, "f_hz": Hz, "phase": rad}``: an unmeasured harmonic force on the
  mass (a machine on the same floor), running before, during and after the blow;
- ``{"law": "stop", "i": 0, "gap": m, "kc": N/m}``: a one-sided stop, a spring ``kc (x - gap)`` that
  only pushes back when ``x > gap`` (a preloaded bumper on one side);
- ``{"law": "dbdrag", "i": 0, "cq": N s^2/m^2, "vdb": m/s}``: velocity-squared damping with a dead band,
  ``cq sign(v) max(|v| - vdb, 0)^2`` (a fluid damper whose valve opens above a speed).

Tenth set:

- ``{"law": "fracpow", "i": 0, "cp": N (s/m)^p, "p": -, "veps": m/s}``: fractional-power damping
  ``cp sign(v) |v|^p`` (p = 0.5: a squeeze film, a porous liner), smoothed below ``veps``;
- ``{"law": "hertz", "i": 0, "kh": N/m^1.5}``: a Hertzian contact stiffness ``kh sign(x) |x|^1.5`` (a preloaded
  ball joint: its force grows with the power 3/2, not a polynomial);
- ``{"law": "weight", "i": 0, "w": N}``: a constant force on the mass (its weight and a payload on a vertical
  mount), so that the motion happens about a deflected equilibrium (the records start there).

Eleventh set:

- ``{"law": "maxwell", "i": 0, "k2": N/m, "c2": N s/m}``: a Maxwell branch (a spring ``k2`` in series with a
  dashpot ``c2``) in parallel with the main spring, the standard linear solid of a viscoelastic mount (an
  elastomer): its force ``z`` is an extra state, ``z' = k2 v - (k2 / c2) z``; linear, but its stiffness and
  loss depend on frequency and the free response has a slow creep pole besides the oscillation;
- ``{"law": "kramp", "i": 0, "k": N/m, "eps": -, "t0": s, "T": s}``: a stiffness that drifts slowly through
  the record, ``k eps (t - t0) / T x`` (a mount warming or cooling while the blows are taken).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp


def pulse(t, t0, width, peak, shape=(1.0, 1.0)):
    """Hammer pulse ``peak * c * s^p (1 - s)^q`` on ``s = (t - t0) / width`` in [0, 1] (normalised to peak)."""
    p, q = shape
    s = np.clip((np.asarray(t, float) - t0) / width, 0.0, 1.0)
    smax = p / (p + q)
    return peak * (s ** p * (1 - s) ** q) / (smax ** p * (1 - smax) ** q)


def pulse_area(width, shape=(1.0, 1.0), n=4001):
    s = np.linspace(0, 1, n)
    return width * np.trapezoid(pulse(s, 0.0, 1.0, 1.0, shape), s)


class System:
    """Masses, linear matrices and nonlinear laws; ``force(t)`` from a list of pulses."""

    def __init__(self, masses, laws, drive=0):
        self.m = np.asarray(masses, float)
        self.n = len(self.m)
        self.laws = laws
        self.drive = drive
        self.maxwell = [L for L in laws if L["law"] == "maxwell"]
        self.z = None  # the Maxwell branches' forces (extra states), set by simulate before internal()

    def internal(self, x, v, t):
        f = np.zeros(self.n)
        for L in self.laws:
            i = L["i"]
            kind = L["law"]
            if kind == "poly":
                j = L.get("j", -1)
                s = x[i] - (x[j] if j >= 0 else 0.0)
                sd = v[i] - (v[j] if j >= 0 else 0.0)
                g = sum(float(c) * s ** int(p) for p, c in L.get("k", {}).items())
                g += sum(float(c) * sd * abs(sd) ** (int(p) - 1) if int(p) % 2 == 0 else float(c) * sd ** int(p)
                         for p, c in L.get("c", {}).items())
                g += L.get("cx2v", 0.0) * s * s * sd
                g += L.get("kabs", 0.0) * s * abs(s)  # thirteenth set: a smooth stiffening abs(x) x
                f[i] += g
                if j >= 0:
                    f[j] -= g
            elif kind == "coulomb":
                f[i] += L["fc"] * np.tanh(v[i] / L["veps"])
            elif kind == "gap":
                over = abs(x[i]) - L["gap"]
                if over > 0:
                    f[i] += np.sign(x[i]) * L["kc"] * over + L["cc"] * v[i]
            elif kind == "drag":
                f[i] += L["cq"] * v[i] * abs(v[i])
            elif kind == "parametric":
                f[i] += L["k"] * L["eps"] * np.sin(2 * np.pi * L["f_hz"] * t + L["phase"]) * x[i]
            elif kind == "stop":
                over = x[i] - L["gap"]
                if over > 0:
                    f[i] += L["kc"] * over + L.get("cc", 0.0) * v[i]
            elif kind == "sine":
                f[i] += L["k"] * L["L"] * np.sin(x[i] / L["L"])
            elif kind == "gyro":
                j = L["j"]
                f[i] += L["g"] * v[j]
                f[j] -= L["g"] * v[i]
            elif kind == "base":
                u = ud = 0.0
                for a, fh, ph in L["comps"]:
                    w = 2 * np.pi * fh
                    u += a * np.sin(w * t + ph)
                    ud += a * w * np.cos(w * t + ph)
                f[i] -= L["k"] * u + L["c"] * ud
            elif kind == "dbdrag":
                ex = abs(v[i]) - L["vdb"]
                if ex > 0:
                    f[i] += np.sign(v[i]) * L["cq"] * ex * ex
            elif kind == "bilin":  # a spring whose stiffness depends on the direction of motion
                f[i] += L["k"] * (1.0 + L["eps"] * np.tanh(v[i] / L["veps"])) * x[i]
            elif kind == "fracpow":
                vv = v[i]
                f[i] += L["cp"] * np.sign(vv) * (abs(vv) + L["veps"]) ** L["p"] * np.tanh(abs(vv) / L["veps"])
            elif kind == "hertz":
                f[i] += L["kh"] * np.sign(x[i]) * abs(x[i]) ** 1.5
            elif kind == "maxwell":
                f[i] += self.z[self.maxwell.index(L)]
            elif kind == "kramp":
                f[i] += L["k"] * L["eps"] * (t - L["t0"]) / L["T"] * x[i]
            elif kind == "weight":
                f[i] += L["w"]
            elif kind == "tone":
                f[i] -= L["amp"] * np.sin(2 * np.pi * L["f_hz"] * t + L["phase"])
            else:
                raise ValueError(kind)
        return f


def simulate(system, pulses, t_samples, y0=None):
    """Integrate from rest (or ``y0``) at ``t_samples[0]``; return x, v, a (n x N) at the samples and the
    applied force at the samples. ``pulses``: list of (t0, width, peak, shape)."""
    n = system.n

    def force(t):
        return sum(float(pulse(t, *p)) for p in pulses)

    ne = len(system.maxwell)

    def rhs(t, y):
        x, v, z = y[:n], y[n:2 * n], y[2 * n:]
        system.z = z
        fx = -system.internal(x, v, t)
        fx[system.drive] += force(t)
        zd = [L["k2"] * v[L["i"]] - L["k2"] / L["c2"] * z[q] for q, L in enumerate(system.maxwell)]
        return np.concatenate([v, fx / system.m, zd])

    edges = sorted({float(t_samples[0]), float(t_samples[-1])}
                   | {float(e) for p in pulses for e in (p[0], p[0] + p[1]) if t_samples[0] < e < t_samples[-1]})
    y = np.zeros(2 * n + ne) if y0 is None else np.concatenate([np.asarray(y0, float), np.zeros(ne)])
    out = np.zeros((2 * n + ne, len(t_samples)))
    scale = max(np.abs(y).max(), 1e-12)
    for a, b in zip(edges[:-1], edges[1:]):
        sel = (t_samples >= a) & (t_samples <= b) if b == edges[-1] else (t_samples >= a) & (t_samples < b)
        width = min((p[1] for p in pulses), default=b - a)
        in_pulse = any(p[0] <= a < p[0] + p[1] for p in pulses)
        sol = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=1e-10, atol=1e-13 * max(scale, 1e-9),
                        t_eval=t_samples[sel], max_step=(width / 20 if in_pulse else np.inf), dense_output=True)
        if not sol.success:
            raise RuntimeError(sol.message)
        out[:, sel] = sol.y
        y = sol.sol(b)
        scale = max(scale, np.abs(y).max())
    x, v, zs = out[:n], out[n:2 * n], out[2 * n:]
    acc = np.zeros_like(x)
    fvec = np.array([force(t) for t in t_samples])
    for k, t in enumerate(t_samples):
        system.z = zs[:, k]
        fx = -system.internal(x[:, k], v[:, k], t)
        fx[system.drive] += fvec[k]
        acc[:, k] = fx / system.m
    return x, v, acc, fvec


def linear_freqs(masses, K):
    """Undamped natural frequencies [Hz] of M x'' + K x = 0 (M diagonal)."""
    w2 = np.linalg.eigvals(np.diag(1 / np.asarray(masses, float)) @ K).real
    return sorted(np.sqrt(np.abs(w2)) / (2 * np.pi))


if __name__ == "__main__":  # self-check: a linear oscillator against its impulse response
    m, k, c = 0.37, 5.1e4, 2.0
    sysl = System([m], [{"law": "poly", "i": 0, "k": {1: k}, "c": {1: c}}])
    wd = np.sqrt(k / m - (c / 2 / m) ** 2)
    width = 1e-5
    t = np.linspace(0, 0.2, 4001)
    x, v, a, f = simulate(sysl, [(0.0, width, 1.0, (1.0, 1.0))], t)
    imp = pulse_area(width)
    ref = imp / (m * wd) * np.exp(-c / 2 / m * (t - width / 2)) * np.sin(wd * (t - width / 2))
    sel = t > 2 * width
    print(f"linear impulse response: max error / peak = {np.abs(x[0, sel] - ref[sel]).max() / np.abs(ref).max():.2e}")
