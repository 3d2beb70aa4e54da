"""Mechanics of the third blind scorecard: scipy ``solve_ivp`` on lumped masses (no project code).

Every system is a function ``rhs(t, y, F) -> dy`` over a state ``y = [x_1..x_n, v_1..v_n]`` plus
optional extra states; ``simulate`` integrates it piecewise (the hammer pulse, then the free
response) with DOP853 on a fine grid and returns displacement, velocity and acceleration of every
mass. Units: SI (m, m/s, m/s^2, N, kg, s).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp


@dataclass(frozen=True)
class Pulse:
    """Hammer force: a haversine of ``peak`` [N] lasting ``width`` [s] from ``t0`` [s]."""

    peak: float
    width: float
    t0: float

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        s = (t - self.t0) / self.width
        on = (s >= 0) & (s <= 1)
        return np.where(on, self.peak * np.sin(np.pi * np.clip(s, 0, 1)) ** 2, 0.0)


@dataclass(frozen=True)
class System:
    """A chain of masses with per-mass and between-mass force laws.

    ``masses`` [kg]; ``ground[i](x_i, v_i, t) -> force`` restoring force of mass i to ground [N];
    ``links[(i, j)](d, w, t) -> force`` between masses i and j (``d = x_i - x_j``, ``w = v_i - v_j``)
    acting +f on j and -f on i; ``struck``: index of the mass the hammer hits.
    """

    masses: tuple
    ground: tuple
    links: dict = field(default_factory=dict)
    struck: int = 0

    @property
    def n(self):
        return len(self.masses)

    def accel(self, t, x, v, force):
        """Accelerations [m/s^2]; ``x, v`` of shape (n,) or (n, samples) (then ``t, force`` per sample)."""
        n = self.n
        f = np.zeros(np.shape(x), dtype=float)
        for i in range(n):
            f[i] -= self.ground[i](x[i], v[i], t)
        for (i, j), law in self.links.items():
            g = law(x[i] - x[j], v[i] - v[j], t)
            f[i] -= g
            f[j] += g
        f[self.struck] = f[self.struck] + force
        m = np.asarray(self.masses, dtype=float)
        return f / (m if f.ndim == 1 else m[:, None])

    def rhs(self, pulse):
        n = self.n

        def fun(t, y):
            x, v = y[:n], y[n:2 * n]
            return np.concatenate([v, self.accel(t, x, v, float(pulse(t)))])
        return fun


def simulate(system, pulse, duration, dt_fine, y0=None, t_start=0.0, rtol=1e-10):
    """Integrate ``system`` hit by ``pulse`` from ``t_start`` to ``duration`` on a grid of ``dt_fine``.

    Returns ``t, x, v, a, f`` (``x, v, a`` of shape (n, samples), ``f`` the force [N]). Integrated
    in pieces between the pulse's edges (the solver never steps across a kink of the force), with
    dense output evaluated on the grid; absolute tolerances scaled per state after the first piece.
    """
    n = system.n
    t = t_start + np.arange(int(round((duration - t_start) / dt_fine))) * dt_fine
    y = np.zeros(2 * n) if y0 is None else np.asarray(y0, dtype=float)
    inner = [e for e in (pulse.t0, pulse.t0 + pulse.width) if t_start < e < t[-1]]
    edges = [t_start, *inner, t[-1]]
    ys = np.zeros((2 * n, t.size))
    fun = system.rhs(pulse)
    atol = 1e-15
    for a, b in zip(edges[:-1], edges[1:]):
        in_pulse = a >= pulse.t0 and b <= pulse.t0 + pulse.width
        if not in_pulse and not np.any(y) and b <= pulse.t0:
            continue                                    # at rest before the blow
        sol = solve_ivp(fun, (a, b), y, method="DOP853", dense_output=True, rtol=rtol, atol=atol,
                        max_step=pulse.width / 16 if in_pulse else np.inf,
                        first_step=min(pulse.width / 64, (b - a) / 4))
        if not sol.success:
            raise RuntimeError(sol.message)
        sel = (t >= a) & (t <= b)
        if sel.any():
            ys[:, sel] = sol.sol(t[sel])
        y = sol.y[:, -1]
        peak = np.max(np.abs(sol.y), axis=1)
        group = np.repeat([peak[:n].max(), peak[n:2 * n].max()], n)   # displacements, velocities
        atol = np.maximum(group, 1e-300) * 1e-11 if peak.max() > 0 else 1e-15
    x, v = ys[:n], ys[n:]
    f = pulse(t)
    a = system.accel(t, x, v, f)
    return t, x, v, a, f


# ---- force laws ---------------------------------------------------------------------------------

def poly_spring(k=0.0, k2=0.0, k3=0.0, c=0.0, c3=0.0, cq=0.0, kxa=0.0):
    """``k x + k2 x^2 + k3 x^3 + kxa x|x| + c v + c3 v^3 + cq |v| v`` [N]."""
    def law(x, v, t):
        return k * x + k2 * x * x + k3 * x ** 3 + kxa * x * abs(x) + c * v + c3 * v ** 3 + cq * abs(v) * v
    return law


def friction(fc, vs):
    """Smooth dry friction ``fc tanh(v / vs)`` [N]."""
    def law(x, v, t):
        return fc * np.tanh(np.asarray(v) / vs)
    return law


def add(*laws):
    def law(x, v, t):
        return sum(lw(x, v, t) for lw in laws)
    return law


def preloaded_backlash(k_in, k_out, d):
    """Two springs preloaded against each other: stiffness ``k_in`` within ``|x| < d`` (both engaged),
    ``k_out`` beyond (one has lifted off). A softening knee; smoothed over 2 % of ``d``."""
    w = 0.02 * d

    def law(x, v, t):
        s = 0.5 * (1 + np.tanh((np.abs(x) - d) / w))       # 0 inside, 1 outside
        inside = k_in * x
        outside = np.sign(x) * (k_in * d + k_out * (np.abs(x) - d))
        return (1 - s) * inside + s * outside
    return law


def drifting_spring(k0, rate_per_s, c):
    """Linear spring whose stiffness drifts in time (warming): ``k0 (1 + rate t) x + c v``."""
    def law(x, v, t):
        return k0 * (1 + rate_per_s * t) * x + c * v
    return law


def contact(k_c, gap, c_c):
    """A rattling contact: ``k_c (|d| - gap)^1.5`` (Hertz) beyond the gap, with a Hunt-Crossley loss
    ``c_c pen^1.5 w`` that never pulls the parts together."""
    def law(d, w, t):
        pen = np.maximum(np.abs(d) - gap, 0.0)
        elastic = k_c * pen ** 1.5
        total = elastic * (1 + c_c * w * np.sign(d))
        return np.sign(d) * np.maximum(total, 0.0)
    return law


def free_mode_frequencies(masses, kmat):
    """Linear natural frequencies [Hz] of ``M q'' + K q = 0`` (for checking cases)."""
    m = np.diag(masses)
    w2 = np.linalg.eigvals(np.linalg.solve(m, kmat))
    return np.sort(np.sqrt(np.abs(w2.real))) / (2 * np.pi)


def check_against_convolution():
    """Linear 1-DOF: compare with the convolution integral of the impulse response (returns max rel error)."""
    m, k, c = 2.0, 2.0e4, 4.0
    pulse = Pulse(100.0, 1e-3, 0.01)
    sys1 = System((m,), (poly_spring(k=k, c=c),))
    dt = 2e-5
    t, x, v, a, f = simulate(sys1, pulse, 0.5, dt)
    wn = np.sqrt(k / m)
    z = c / (2 * np.sqrt(k * m))
    wd = wn * np.sqrt(1 - z * z)
    h = np.exp(-z * wn * t) * np.sin(wd * t) / (m * wd)
    xc = np.convolve(f, h)[: t.size] * dt
    return float(np.max(np.abs(xc - x[0])) / np.max(np.abs(x[0])))


if __name__ == "__main__":
    print("linear 1-DOF vs convolution: max rel error", check_against_convolution())
