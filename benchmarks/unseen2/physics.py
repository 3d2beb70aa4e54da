"""Ground-truth mechanics of the second blind scorecard (written without eddi or simulated_rig).

One struck mass ``m`` (coordinate ``x``, absolute) on a structure described as data
(a JSON-able dict, see :func:`internal_force`), optionally with

* a second mass ``m2`` hung on the first by a linear spring (a coupled second mode),
* a base of mass ``M`` on a soft spring to the ground that the oscillator stands on
  (rigid-body motion of the fixture; the oscillator's forces act on ``r = x - x_b``),
* a Dahl hysteretic friction element (state ``z`` [N], ``z' = sigma (r' - |r'| z / Fc)``).

The equations are integrated by ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10, absolute
tolerances scaled per state) piecewise between the edges of the hammer pulses, so a kink
in the force never sits inside a step. The absolute acceleration of the struck mass is
returned exactly (from the right-hand side at the output times), along with ``x`` and ``v``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

RTOL = 1e-10


def hammer_force(t, hits):
    """Hammer force [N] at times ``t`` [s].

    ``hits`` is a list of dicts ``{"t0": s, "dur": s, "peak": N, "shape": "haversine" |
    "halfsine"}``; pulses add.
    """
    t = np.asarray(t, dtype=float)
    f = np.zeros_like(t)
    for h in hits:
        u = (t - h["t0"]) / h["dur"]
        inside = (u > 0) & (u < 1)
        s = np.sin(np.pi * u[inside])
        f[inside] += h["peak"] * (s * s if h["shape"] == "haversine" else s)
    return f


def _force_at(t, hits):
    """Scalar :func:`hammer_force`."""
    f = 0.0
    for h in hits:
        u = (t - h["t0"]) / h["dur"]
        if 0.0 < u < 1.0:
            s = math.sin(math.pi * u)
            f += h["peak"] * (s * s if h["shape"] == "haversine" else s)
    return f


def hammer_impulse(hits):
    """Exact impulse [N s] of the pulses."""
    return sum(h["peak"] * h["dur"] * (0.5 if h["shape"] == "haversine" else 2.0 / math.pi) for h in hits)


def _poly_terms(terms, x, v):
    out = 0.0
    for name, c in terms.items():
        if name == "v":
            out += c * v
        elif name == "x":
            out += c * x
        elif name == "x^2":
            out += c * x * x
        elif name == "x^3":
            out += c * x ** 3
        elif name == "x^5":
            out += c * x ** 5
        elif name == "x^2*v":
            out += c * x * x * v
        elif name == "v^3":
            out += c * v ** 3
        elif name == "abs(v)*v":
            out += c * abs(v) * v
        elif name == "abs(x)*x":
            out += c * abs(x) * x
        else:
            raise ValueError(f"unknown term {name}")
    return out


def internal_force(sys, r, rd, z=0.0):
    """Force [N] the structure exerts against the struck mass at relative state ``(r, rd)``.

    ``sys`` keys: ``damping`` and ``stiffness`` (term -> coefficient, SI; terms among v,
    x^2*v, v^3, abs(v)*v and x, x^2, x^3, x^5, abs(x)*x), optional ``friction``
    ``{"fc": N, "vs": m/s}`` (``fc tanh(v / vs)``), ``contact`` ``{"gap": m, "k": N/m}``
    (a spring engaging beyond ``|x| > gap``, both sides), ``dahl`` (its force is the state ``z``).
    """
    f = _poly_terms(sys.get("damping", {}), r, rd) + _poly_terms(sys.get("stiffness", {}), r, rd)
    fr = sys.get("friction")
    if fr:
        f += fr["fc"] * math.tanh(rd / fr["vs"])
    ct = sys.get("contact")
    if ct:
        over = abs(r) - ct["gap"]
        if over > 0:
            f += ct["k"] * over * (1.0 if r > 0 else -1.0)
    if sys.get("dahl"):
        f += z
    return f


class Layout:
    """Indices of the state vector for a system."""

    def __init__(self, sys):
        self.n = 2
        self.z = self.m2 = self.base = None
        if sys.get("dahl"):
            self.z, self.n = self.n, self.n + 1
        if sys.get("mode2"):
            self.m2, self.n = self.n, self.n + 2
        if sys.get("base"):
            self.base, self.n = self.n, self.n + 2
        sen = sys.get("sensor") or {}
        self.res = self.hp = None
        if sen.get("resonance_hz"):
            self.res, self.n = self.n, self.n + 2
        if sen.get("highpass_hz"):
            self.hp, self.n = self.n, self.n + 1

    def sensed(self, sys, y, acc):
        """Accelerometer output before gain, noise and ADC: the absolute acceleration through
        the sensor's mounting resonance (second order, unit DC gain) and its first-order AC
        coupling (IEPE), whichever the system has."""
        sen = sys.get("sensor") or {}
        u = y[self.res] if self.res is not None else acc
        if self.hp is not None:
            u = u - 2 * math.pi * sen["highpass_hz"] * y[self.hp]
        return u


def rhs_factory(sys, hits):
    """Right-hand side ``dy/dt`` and the absolute acceleration of the struck mass."""
    lay = Layout(sys)
    m = sys["mass"]
    drift = sys.get("k_scale", 1.0)

    def parts(t, y):
        x, v = y[0], y[1]
        xb = vb = 0.0
        if lay.base is not None:
            xb, vb = y[lay.base], y[lay.base + 1]
        r, rd = x - xb, v - vb
        z = y[lay.z] if lay.z is not None else 0.0
        fint = internal_force(sys, r, rd, z)
        if drift != 1.0:
            fint += (drift - 1.0) * sys["stiffness"]["x"] * r
        fext = _force_at(t, hits)
        dy = np.zeros(lay.n)
        dy[0] = v
        fcoup = 0.0
        if lay.m2 is not None:
            md = sys["mode2"]
            x2, v2 = y[lay.m2], y[lay.m2 + 1]
            fcoup = md["k"] * (x - x2) + md["c"] * (v - v2)
            dy[lay.m2] = v2
            dy[lay.m2 + 1] = fcoup / md["mass"]
        acc = (fext - fint - fcoup) / m
        dy[1] = acc
        if lay.z is not None:
            d = sys["dahl"]
            dy[lay.z] = d["sigma"] * (rd - abs(rd) * z / d["fc"])
        if lay.base is not None:
            b = sys["base"]
            dy[lay.base] = vb
            dy[lay.base + 1] = (fint - b["k"] * xb - b["c"] * vb) / b["mass"]
        sen = sys.get("sensor") or {}
        u = acc
        if lay.res is not None:
            wr = 2 * math.pi * sen["resonance_hz"]
            yr, yrd = y[lay.res], y[lay.res + 1]
            dy[lay.res] = yrd
            dy[lay.res + 1] = wr * wr * (acc - yr) - 2 * sen.get("resonance_zeta", 0.02) * wr * yrd
            u = yr
        if lay.hp is not None:
            dy[lay.hp] = u - 2 * math.pi * sen["highpass_hz"] * y[lay.hp]
        return dy

    return parts, lay


def simulate(sys, hits, t_out):
    """Integrate from rest at the first pulse's start; return ``x, v, a, s`` at ``t_out``: the
    struck mass's absolute displacement [m], velocity [m/s], acceleration [m/s^2] and what the
    accelerometer's element senses [m/s^2] (see :meth:`Layout.sensed`).

    Before the first pulse everything is at rest (zeros).
    """
    rhs, lay = rhs_factory(sys, hits)
    t_out = np.asarray(t_out, dtype=float)
    t_start = min(h["t0"] for h in hits)
    edges = sorted({t_start} | {h["t0"] for h in hits} | {h["t0"] + h["dur"] for h in hits})
    edges = [e for e in edges if e < t_out[-1]] + [float(t_out[-1])]
    impulse = hammer_impulse(hits)
    k1 = sys["stiffness"].get("x", 1.0)
    w = math.sqrt(abs(k1) / sys["mass"]) or 1.0
    vs = impulse / sys["mass"]
    scale = np.full(lay.n, vs / w)
    scale[1] = vs
    if lay.z is not None:
        scale[lay.z] = sys["dahl"]["fc"]
    if lay.m2 is not None:
        scale[lay.m2 + 1] = vs
    if lay.base is not None:
        scale[lay.base + 1] = vs
    if lay.res is not None:
        scale[lay.res] = vs * w
        scale[lay.res + 1] = vs * w * 2 * math.pi * sys["sensor"]["resonance_hz"]
    if lay.hp is not None:
        scale[lay.hp] = vs
    atol = 1e-11 * scale
    y = np.zeros(lay.n)
    xs = np.zeros((lay.n, t_out.size))
    pulse_min = min(h["dur"] for h in hits)
    for a, b in zip(edges[:-1], edges[1:]):
        in_pulse = any(h["t0"] <= a < h["t0"] + h["dur"] for h in hits)
        sol = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=RTOL, atol=atol, dense_output=True,
                        max_step=(pulse_min / 20 if in_pulse else np.inf))
        if not sol.success:
            raise RuntimeError(f"solve_ivp failed: {sol.message}")
        sel = (t_out >= a) & (t_out <= b)
        if sel.any():
            xs[:, sel] = sol.sol(t_out[sel])
        y = sol.y[:, -1]
    acc = np.zeros(t_out.size)
    sensed = np.zeros(t_out.size)
    live = t_out >= t_start
    for i in np.nonzero(live)[0]:
        acc[i] = rhs(t_out[i], xs[:, i])[1]
        sensed[i] = lay.sensed(sys, xs[:, i], acc[i])
    return xs[0], xs[1], acc, sensed
