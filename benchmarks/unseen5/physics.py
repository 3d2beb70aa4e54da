"""Lumped-mass mechanics of the fifth blind scorecard (its own; nothing from eddi/station/simulated_rig).

``M x'' + C x' + K x + f_nl(t, x, v, z) = b F(t)``, with internal states ``z`` for hysteretic
elements. Integrated with ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10, absolute tolerances
of 1e-11 of the displacement scale), in pieces split at the hammer pulse's edges, evaluated on a
fine grid laid on the DAQ's true clock; the acceleration is the equation of motion on that grid.

Nonlinear laws (``nl`` entries, tuples):

- ``("poly", i, j, coef, p, q)``: ``coef d^p dv^q`` on mass i (reaction on j; j = -1 the ground),
  ``d = x_i - x_j``, ``dv = v_i - v_j``.
- ``("drag", i, coef)``: ``coef |v_i| v_i`` (quadratic drag).
- ``("coulomb", i, force, vscale)``: ``force tanh(v_i / vscale)`` (dry friction, smoothed).
- ``("gap2", i, j, k, g, c)``: two-sided contact beyond a gap: ``k sign(d) max(|d| - g, 0)`` plus a
  contact dashpot ``c dv`` while in contact (a clearance when j = -1, a rattling mass when j is a
  loose mass).
- ``("bw", i, fy, uy, beta, gamma)``: a Bouc-Wen element (exponent 1), force ``fy z``,
  ``z' = (v - beta |v| z - gamma v |z|) / uy`` (one internal state each).

    python physics.py      # a linear oscillator against its closed-form impulse response
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp


def pulse(t, t0, width, peak, shape):
    """Hammer force [N]: ``peak * g(s)`` on ``s = (t - t0) / width`` in (0, 1).

    shape (p, q): ``g(s) = s^p (1 - s)^q / max`` (p = q: symmetric; q > p: a soft tip's slow
    release).
    """
    p, q = shape
    s = (np.asarray(t, float) - t0) / width
    smax = p / (p + q)
    norm = smax ** p * (1 - smax) ** q
    inside = (s > 0) & (s < 1)
    sc = np.clip(s, 0.0, 1.0)
    return np.where(inside, peak * sc ** p * (1 - sc) ** q / norm, 0.0)


class System:
    """A lumped system as data: ``M``, ``K``, ``C`` (n x n), ``b`` (n,), ``nl`` (see module doc)."""

    def __init__(self, spec):
        self.M = np.atleast_2d(np.asarray(spec["M"], float))
        self.K = np.atleast_2d(np.asarray(spec["K"], float))
        self.C = np.atleast_2d(np.asarray(spec["C"], float))
        self.n = len(self.M)
        self.b = np.asarray(spec.get("b", [1.0] + [0.0] * (self.n - 1)), float)
        self.nl = [tuple(e) for e in spec.get("nl", [])]
        self.nz = sum(1 for e in self.nl if e[0] == "bw")
        self.Minv = np.linalg.inv(self.M)

    def forces(self, x, v, z):
        """Nonlinear forces on each mass [N] and dz/dt; x, v: (..., n), z: (..., nz)."""
        f = np.zeros(np.shape(x))
        dz = np.zeros(np.shape(x)[:-1] + (self.nz,))
        iz = 0
        for e in self.nl:
            kind, i = e[0], e[1]
            if kind == "poly":
                _, _, j, coef, p, q = e
                d = x[..., i] - (x[..., j] if j >= 0 else 0.0)
                dv = v[..., i] - (v[..., j] if j >= 0 else 0.0)
                val = coef * d ** p * dv ** q
                f[..., i] += val
                if j >= 0:
                    f[..., j] -= val
            elif kind == "drag":
                f[..., i] += e[2] * np.abs(v[..., i]) * v[..., i]
            elif kind == "coulomb":
                f[..., i] += e[2] * np.tanh(v[..., i] / e[3])
            elif kind == "gap2":
                _, _, j, k, g, c = e
                d = x[..., i] - (x[..., j] if j >= 0 else 0.0)
                dv = v[..., i] - (v[..., j] if j >= 0 else 0.0)
                pen = np.maximum(np.abs(d) - g, 0.0)
                val = k * np.sign(d) * pen + np.where(pen > 0, c * dv, 0.0)
                f[..., i] += val
                if j >= 0:
                    f[..., j] -= val
            elif kind == "bw":
                _, _, fy, uy, beta, gamma = e
                zz = z[..., iz]
                vi = v[..., i]
                f[..., i] += fy * zz
                dz[..., iz] = (vi - beta * np.abs(vi) * zz - gamma * vi * np.abs(zz)) / uy
                iz += 1
        return f, dz

    def rhs(self, t, y, force_fn):
        n = self.n
        x, v, z = y[:n], y[n:2 * n], y[2 * n:]
        fnl, dz = self.forces(x, v, z)
        a = self.Minv @ (self.b * force_fn(t) - self.C @ v - self.K @ x - fnl)
        return np.concatenate([v, a, dz])

    def linear_frequencies(self):
        """Undamped natural frequencies [Hz] of the linear part (M, K)."""
        w2 = np.linalg.eigvals(self.Minv @ self.K).real
        return np.sort(np.sqrt(np.abs(w2))) / (2 * np.pi)


def simulate(system, t_grid, t0, width, peak, shape, x_scale, y0=None):
    """Displacement, velocity, acceleration (len(t) x n each) and the force on t_grid [s]."""
    n, nz = system.n, system.nz
    w = 2 * np.pi * max(system.linear_frequencies().max(), 0.5)
    atol = np.concatenate([np.full(n, 1e-11 * x_scale), np.full(n, 1e-11 * x_scale * w),
                           np.full(nz, 1e-9)])
    force_fn = lambda t: float(pulse(t, t0, width, peak, shape))  # noqa: E731
    y = np.zeros(2 * n + nz) if y0 is None else np.asarray(y0, float)
    edges = sorted({t_grid[0], min(max(t_grid[0], t0), t_grid[-1]),
                    min(max(t_grid[0], t0 + width), t_grid[-1]), t_grid[-1]})
    out = np.zeros((len(t_grid), 2 * n + nz))
    for a, b in zip(edges[:-1], edges[1:]):
        if b <= a:
            continue
        sel = (t_grid >= a) & (t_grid <= b)
        in_pulse = a >= t0 - 1e-15 and b <= t0 + width + 1e-15
        sol = solve_ivp(system.rhs, (a, b), y, method="DOP853", rtol=1e-10, atol=atol,
                        dense_output=True, max_step=width / 40 if in_pulse else np.inf,
                        args=(force_fn,))
        if not sol.success:
            raise RuntimeError(sol.message)
        out[sel] = sol.sol(t_grid[sel]).T
        y = sol.y[:, -1]
    x, v, z = out[:, :n], out[:, n:2 * n], out[:, 2 * n:]
    fgrid = pulse(t_grid, t0, width, peak, shape)
    fnl, _ = system.forces(x, v, z)
    acc = (fgrid[:, None] * system.b[None, :] - v @ system.C.T - x @ system.K.T - fnl) @ system.Minv.T
    return x, v, acc, fgrid


def _check():
    """Free decay after an impulse-like pulse vs the closed form (error relative to the peak)."""
    m, fn, zeta = 0.7, 31.0, 0.008
    w = 2 * np.pi * fn
    s = System({"M": [[m]], "K": [[m * w * w]], "C": [[2 * zeta * m * w]]})
    t = np.linspace(0, 0.5, 50001)
    width, peak, shape = 2e-5, 1000.0, (1.0, 1.0)
    t0 = 0.01
    x, _, _, _ = simulate(s, t, t0, width, peak, shape, 1e-4)
    # impulse of s(1-s)/0.25 over the width: peak * width * (1/6) / 0.25
    imp = peak * width * (1 / 6) / 0.25
    wd = w * np.sqrt(1 - zeta ** 2)
    tau = t - (t0 + width / 2)
    h = np.where(tau > 0, imp * np.exp(-zeta * w * tau) * np.sin(wd * tau) / (m * wd), 0.0)
    late = t > t0 + 10 * width
    err = np.max(np.abs(h[late] - x[late, 0])) / np.max(np.abs(h))
    print(f"linear oscillator vs impulse response: max error {err:.2e} of the peak")
    return err


if __name__ == "__main__":
    _check()
