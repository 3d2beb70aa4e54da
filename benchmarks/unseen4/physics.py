"""Lumped-mass mechanics for the fourth blind scorecard (nothing from eddi/station/simulated_rig).

``M x'' + C x' + K x + f_nl(t, x, v, z) = b F(t)`` with optional internal states ``z`` (a Maxwell
element's dashpot displacement). Integrated with ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10,
absolute tolerances scaled per state group) in pieces split at the hammer pulse's edges.

    python physics.py        # checks a linear oscillator against the convolution integral
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.signal import fftconvolve


def haversine(t, t0, width, peak):
    """Hammer force [N] at times t [s]: peak * sin^2(pi (t - t0) / width) on [t0, t0 + width]."""
    t = np.asarray(t, float)
    s = (t - t0) / width
    return np.where((s > 0) & (s < 1), peak * np.sin(np.pi * s) ** 2, 0.0)


class System:
    """A lumped system described as data.

    spec keys: ``M`` (n x n), ``K``, ``C`` (n x n), ``b`` (n, where the hammer acts), ``nl``: a list of
    tuples, each one nonlinear force law:

    - ("poly", i, j, coef, p, q): force ``coef * d^p * dv^q`` on mass i (and its reaction on j) with
      d = x_i - x_j, dv = v_i - v_j (j = -1: the ground); odd powers keep their sign.
    - ("absv", i, coef): ``coef * |v_i| v_i`` on mass i.
    - ("gap", i, k, g): ``k * max(x_i - g, 0)`` (one-sided spring beyond an offset gap g > 0).
    - ("kmod", i, dk, fm, phase): ``dk * sin(2 pi fm t + phase) * x_i`` (a stiffness varying in time).
    - ("maxwell", i, km, cm): spring km in series with dashpot cm between mass i and the ground;
      one internal state u, ``u' = km (x_i - u) / cm``, force ``km (x_i - u)``.
    """

    def __init__(self, spec):
        self.M = np.atleast_2d(np.asarray(spec["M"], float))
        self.K = np.atleast_2d(np.asarray(spec["K"], float))
        self.C = np.atleast_2d(np.asarray(spec["C"], float))
        self.b = np.asarray(spec.get("b", [1.0] + [0.0] * (len(self.M) - 1)), float)
        self.nl = [tuple(x) for x in spec.get("nl", [])]
        self.n = len(self.M)
        self.nz = sum(1 for e in self.nl if e[0] == "maxwell")
        self.Minv = np.linalg.inv(self.M)

    def forces(self, t, x, v, z):
        """Nonlinear and internal forces on each mass [N] and dz/dt (x, v, z: (..., n) arrays)."""
        f = np.zeros(np.shape(x))
        dz = np.zeros(np.shape(x)[:-1] + (self.nz,))
        iz = 0
        for e in self.nl:
            kind = e[0]
            if kind == "poly":
                _, i, j, coef, p, q = e
                d = x[..., i] - (x[..., j] if j >= 0 else 0.0)
                dv = v[..., i] - (v[..., j] if j >= 0 else 0.0)
                val = coef * d ** p * dv ** q
                f[..., i] += val
                if j >= 0:
                    f[..., j] -= val
            elif kind == "absv":
                _, i, coef = e
                f[..., i] += coef * np.abs(v[..., i]) * v[..., i]
            elif kind == "gap":
                _, i, k, g = e
                f[..., i] += k * np.maximum(x[..., i] - g, 0.0)
            elif kind == "kmod":
                _, i, dk, fm, ph = e
                f[..., i] += dk * np.sin(2 * np.pi * fm * np.asarray(t) + ph) * x[..., i]
            elif kind == "maxwell":
                _, i, km, cm = e
                fm_ = km * (x[..., i] - z[..., iz])
                f[..., i] += fm_
                dz[..., iz] = fm_ / cm
                iz += 1
        return f, dz

    def rhs(self, t, y, force_fn):
        n = self.n
        x, v, z = y[:n], y[n:2 * n], y[2 * n:]
        fnl, dz = self.forces(t, x, v, z)
        a = self.Minv @ (self.b * force_fn(t) - self.C @ v - self.K @ x - fnl)
        return np.concatenate([v, a, dz])

    def linear_frequencies(self):
        """Undamped natural frequencies [Hz] of the linear part."""
        w2 = np.linalg.eigvals(self.Minv @ self.K).real
        return np.sort(np.sqrt(np.abs(w2))) / (2 * np.pi)


def simulate(system, t_grid, t0, width, peak, x_scale):
    """Displacement, velocity, acceleration (each len(t) x n) and force on t_grid [s].

    x_scale: a typical displacement [m] (sets the absolute tolerances).
    """
    n, nz = system.n, system.nz
    fn = system.linear_frequencies()
    w = 2 * np.pi * max(fn.max(), 1e-3)
    atol = np.concatenate([np.full(n, 1e-11 * x_scale), np.full(n, 1e-11 * x_scale * w),
                           np.full(nz, 1e-11 * x_scale)])
    force_fn = lambda t: float(haversine(t, t0, width, peak))  # noqa: E731
    y = np.zeros(2 * n + nz)
    edges = sorted({t_grid[0], max(t_grid[0], t0), max(t_grid[0], t0 + width), t_grid[-1]})
    out = np.zeros((len(t_grid), 2 * n + nz))
    for a, b in zip(edges[:-1], edges[1:]):
        if b <= a:
            continue
        sel = (t_grid >= a) & (t_grid <= b)
        max_step = width / 30 if a >= t0 and b <= t0 + width + 1e-15 else np.inf
        sol = solve_ivp(system.rhs, (a, b), y, method="DOP853", rtol=1e-10, atol=atol,
                        dense_output=True, max_step=max_step, args=(force_fn,))
        if not sol.success:
            raise RuntimeError(sol.message)
        out[sel] = sol.sol(t_grid[sel]).T
        y = sol.y[:, -1]
    x, v = out[:, :n], out[:, n:2 * n]
    fgrid = haversine(t_grid, t0, width, peak)
    fnl, _ = system.forces(t_grid, x, v, out[:, 2 * n:])
    acc = (fgrid[:, None] * system.b[None, :] - v @ system.C.T - x @ system.K.T - fnl) @ system.Minv.T
    return x, v, acc, fgrid


def _check():
    m, fn, zeta = 1.3, 23.0, 0.012
    w = 2 * np.pi * fn
    sysl = System({"M": [[m]], "K": [[m * w * w]], "C": [[2 * zeta * m * w]]})
    t = np.linspace(0, 0.6, 60001)
    t0, width, peak = 0.01234, 0.004, 50.0
    x, _, _, f = simulate(sysl, t, t0, width, peak, 1e-3)
    wd = w * np.sqrt(1 - zeta ** 2)
    h = np.exp(-zeta * w * t) * np.sin(wd * t) / (m * wd)
    dt = t[1] - t[0]
    conv = fftconvolve(f, h)[:len(t)] * dt
    err = np.max(np.abs(conv - x[:, 0])) / np.max(np.abs(x))
    print(f"linear oscillator vs convolution: max error {err:.2e} of the peak")
    return err


if __name__ == "__main__":
    _check()
