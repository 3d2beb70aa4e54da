"""A hysteretic (Bouc-Wen) restoring force: the operator, and simulation of a model that has one.

The ``hysteresis`` effect of :mod:`eddi.model` is a Bouc-Wen element with ``beta = gamma = 1/2``
(Masing-like: unloading is elastic, loading softens towards the yield force)::

    F_h = F_y z,   dz = (dx / d_y) (1 - |z|^n (beta sign(dx z) + gamma))

``F_y`` the yield force [N], ``d_y`` the yield displacement [m] (initial slope ``F_y / d_y``),
``n`` the sharpness (large ``n``: a Jenkins element, an elastic spring in series with a dry
slider; small ``n``: a smooth transition, as in a bolted joint's micro-slip). ``z`` is
dimensionless, ``|z| <= 1``. The law is rate independent: ``z`` depends on the path of ``x``
only, not on how fast it is traversed, so :func:`bouc_wen_z` computes it from a sampled
displacement alone (the diagnosis regressor, and :func:`eddi.model.effect_force` on a time
series). :func:`simulate_hysteretic` integrates ``x, v, z`` by RK4 on the grid of
:func:`eddi.simulate.simulate` (which calls it for such a model). Its kernels are built ahead of
time with the simulator's (:mod:`eddi.kernels`), else compiled by numba at first use: the
diagnosis tries the Bouc-Wen candidate every time, so with the built module it imports no numba.
"""

from __future__ import annotations

import math

import numpy as np

from eddi.errors import ModelError
from eddi.kernels import Kernels
from eddi.simulate import (  # noqa: F401 - the kernel calls _internal with these constants
    _E_COULOMB, _E_GAP, _E_HAS_CLEAR, _E_HAS_MODE, _E_K2, _E_K4, _E_KC, _E_KCM, _E_QUAD, _E_VS,
    _internal,
)

#: Largest change of ``|z|`` per integration step of the operator.
_DZ_STEP = 0.02


def _bw_rate(z, dx_sign, n_exp):  # pragma: no cover - compiled
    """``dz / d(x / d_y)`` for a motion of sign ``dx_sign``."""
    s = 1.0 if dx_sign * z > 0.0 else (-1.0 if dx_sign * z < 0.0 else 0.0)
    return 1.0 - abs(z) ** n_exp * (0.5 * s + 0.5)


def _bw_path(x, dy, n_exp, out):  # pragma: no cover - compiled
    z = 0.0
    out[0] = 0.0
    for i in range(1, x.shape[0]):
        du = (x[i] - x[i - 1]) / dy
        # at most 400 steps: beyond |du| ~ 8 the element has yielded (z at +-1) whatever the
        # path, and a yield displacement driven towards 0 by a search would otherwise cost
        # |du| / 0.02 steps per sample (a calibration null hung on it)
        steps = min(int(abs(du) / 0.02) + 1, 400)
        h = du / steps
        sg = 1.0 if h > 0 else -1.0
        for _ in range(steps):
            if sg * z < 0.0 and sg * (z + 0.5 * h) <= 0.0:
                # unloading (elastic): both rates are exactly 1, the step is z + h (no power)
                z = z + h
                continue
            k1 = _bw_rate(z, sg, n_exp)
            k2 = _bw_rate(z + 0.5 * h * k1, sg, n_exp)
            zn = z + h * k2
            if zn > 1.0:
                zn = 1.0
            elif zn < -1.0:
                zn = -1.0
            if zn == z:
                # saturated: the same step from the same z gives the same z (every later step of
                # this sample too)
                break
            z = zn
        out[i] = z


# -- the exact operator -------------------------------------------------------------------------
# Along a monotone stretch of the path (no reversal) the law is an autonomous ODE in
# u = x / d_y: unloading (sign(du z) < 0) is elastic, dz/du = 1; loading dz/du = 1 - |z|^n.
# With G(z) = int_0^z dw / (1 - w^n) (increasing, G -> inf as z -> 1), loading from z0 >= 0 by
# du >= 0 ends at z = G^-1(G(z0) + du): z at a sample depends only on x there and at the last
# reversal, and on z at that reversal. G is tabulated per exponent on a uniform grid of
# r = -log(1 - z) (cubic Hermite with its exact derivative (1 - z) / (1 - z^n); a power series
# below the first node) and inverted by bisection + Newton on the same cubic, so G^-1(G(z)) = z
# to rounding. Accuracy: ~1e-10 in z (n >= 1; ~1e-7 for 0.3 <= n < 1 near z = 0), where the
# RK2 operator above (steps of 0.02 in u) is ~1e-4 off.

#: Node spacing in ``r = -log(1 - z)`` of the exact operator's table, and its last node (beyond
#: it ``1 - z`` < 1e-16 and ``dr/dG`` is ``n`` to that precision).
_R_STEP = 0.02
_R_END = 37.0
_R_CELLS = 1850


def _bw_small(z, n_exp):  # pragma: no cover - compiled
    """G(z) by its power series sum z^(nk+1) / (nk+1) (used below the first node, z < 0.02)."""
    q = z ** n_exp
    term = 1.0
    total = 1.0
    for k in range(1, 600):
        term *= q
        c = term / (n_exp * k + 1.0)
        total += c
        if c < 1e-17 * total:
            break
    return z * total


def _bw_g(r, n_exp):  # pragma: no cover - compiled
    """dG/dr = (1 - z) / (1 - z^n) at r = -log(1 - z)."""
    e = math.exp(-r)
    return e / -math.expm1(n_exp * math.log1p(-e))


def _bw_table(n_exp, h, tab_g0, tab_d):  # pragma: no cover - compiled
    """G and dG/dr at the nodes r_k = k h (k >= 1; node 0 unused: the series covers r < h)."""
    # Gauss-Legendre, 3 points per cell
    a = 0.5 * math.sqrt(0.6)
    m = tab_g0.shape[0]
    tab_g0[0] = 0.0
    tab_d[0] = 1.0
    r1 = h
    tab_g0[1] = _bw_small(-math.expm1(-r1), n_exp)
    tab_d[1] = _bw_g(r1, n_exp)
    for k in range(1, m - 1):
        r0 = k * h
        c = r0 + 0.5 * h
        s = (5.0 * _bw_g(c - a * h, n_exp) + 8.0 * _bw_g(c, n_exp) + 5.0 * _bw_g(c + a * h, n_exp)) / 18.0
        tab_g0[k + 1] = tab_g0[k] + h * s
        tab_d[k + 1] = _bw_g((k + 1) * h, n_exp)


def _bw_G(zz, n_exp, h, tab_g0, tab_d):  # pragma: no cover - compiled
    """G(zz) for 0 <= zz < 1."""
    r = -math.log1p(-zz)
    m = tab_g0.shape[0]
    if r < h:
        return _bw_small(zz, n_exp)
    last = (m - 1) * h
    if r >= last:
        return tab_g0[m - 1] + (r - last) / n_exp
    k = int(r / h)
    if k >= m - 1:
        k = m - 2
    t = (r - k * h) / h
    t2 = t * t
    t3 = t2 * t
    return ((2.0 * t3 - 3.0 * t2 + 1.0) * tab_g0[k] + (t3 - 2.0 * t2 + t) * h * tab_d[k]
            + (-2.0 * t3 + 3.0 * t2) * tab_g0[k + 1] + (t3 - t2) * h * tab_d[k + 1])


def _bw_Z(s, n_exp, h, tab_g0, tab_d, k0):  # pragma: no cover - compiled
    """G^-1(s) for s >= 0 (1 at s = inf), and the table cell it fell in (``k0``: a guess)."""
    m = tab_g0.shape[0]
    if s <= tab_g0[1]:
        # below the first node: Newton on the series from z = s (G convex, G(z) >= z)
        z = s
        for _ in range(60):
            q = z ** n_exp
            dz = (_bw_small(z, n_exp) - s) * (1.0 - q)
            z -= dz
            if abs(dz) <= 1e-17 + 1e-15 * z:
                break
        return z, 1
    if s >= tab_g0[m - 1]:
        return -math.expm1(-((m - 1) * h + (s - tab_g0[m - 1]) * n_exp)), m - 2
    # the cell: from the guess (the last one along a stretch, where s grows), else bisection
    lo = k0 if 1 <= k0 <= m - 2 else 1
    if tab_g0[lo] > s:
        lo = 1
    walk = 0
    while walk < 4 and tab_g0[lo + 1] <= s:
        lo += 1
        walk += 1
    if tab_g0[lo + 1] <= s:
        hi = m - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if tab_g0[mid] <= s:
                lo = mid
            else:
                hi = mid
    g0 = tab_g0[lo]
    g1 = tab_g0[lo + 1]
    d0 = h * tab_d[lo]
    d1 = h * tab_d[lo + 1]
    t = (s - g0) / (g1 - g0)
    for _ in range(6):
        t2 = t * t
        t3 = t2 * t
        f = ((2.0 * t3 - 3.0 * t2 + 1.0) * g0 + (t3 - 2.0 * t2 + t) * d0
             + (-2.0 * t3 + 3.0 * t2) * g1 + (t3 - t2) * d1 - s)
        df = (6.0 * t2 - 6.0 * t) * g0 + (3.0 * t2 - 4.0 * t + 1.0) * d0 + (6.0 * t - 6.0 * t2) * g1 \
            + (3.0 * t2 - 2.0 * t) * d1
        step = f / df
        t -= step
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
        if abs(step) < 1e-8:  # quadratic convergence: t is then exact to rounding
            break
    return -math.expm1(-(lo + t) * h), lo


def _bw_branch(xi, xb, zb, gb, sg, dy, n_exp, h, tab_g0, tab_d, k0):  # pragma: no cover - compiled
    """z at ``xi`` on the monotone stretch of sign ``sg`` that left ``xb`` with ``z = zb``
    (``gb``: G(sg zb) when sg zb >= 0), and the table cell used (``k0``: a guess)."""
    du = sg * (xi - xb) / dy
    zz = sg * zb
    if zz < 0.0:
        if du <= -zz:
            return sg * (zz + du), k0  # elastic unloading
        z, k = _bw_Z(du + zz, n_exp, h, tab_g0, tab_d, k0)
        return sg * z, k
    if zz >= 1.0:
        return sg, k0
    z, k = _bw_Z(gb + du, n_exp, h, tab_g0, tab_d, k0)
    return sg * z, k


def _bw_exact(x, dy, n_exp, need, h, tab_g0, tab_d, out):  # pragma: no cover - compiled
    """z (from 0 at sample 0) at the samples ``need`` (increasing) of the path ``x``."""
    m = need.shape[0]
    j = 0
    sg = 0.0
    xb = x[0]
    zb = 0.0
    gb = 0.0
    k = 1
    while j < m and need[j] == 0:
        out[j] = 0.0
        j += 1
    for i in range(1, x.shape[0]):
        if j >= m:
            break
        d = x[i] - x[i - 1]
        s = 1.0 if d > 0.0 else (-1.0 if d < 0.0 else sg)
        if s != sg:
            # a reversal at sample i - 1: z there ends the last stretch and starts the next
            if sg != 0.0:
                zb, k = _bw_branch(x[i - 1], xb, zb, gb, sg, dy, n_exp, h, tab_g0, tab_d, k)
            xb = x[i - 1]
            sg = s
            zz = sg * zb
            gb = _bw_G(zz, n_exp, h, tab_g0, tab_d) if 0.0 <= zz < 1.0 else 0.0
            k = int(-math.log1p(-zz) / h) if 0.0 <= zz < 1.0 else 1
        if need[j] == i:
            if sg != 0.0:
                out[j], k = _bw_branch(x[i], xb, zb, gb, sg, dy, n_exp, h, tab_g0, tab_d, k)
            else:
                out[j] = 0.0
            j += 1


def _rk4_hyst(force, dt, substeps, state0, inv_m, exps, coefs, eff, fy, dy, n_exp, out):  # pragma: no cover
    n = out.shape[0]
    x = state0[0]
    v = state0[1]
    z = state0[2]
    h = dt / substeps
    nf = force.shape[0]
    diverged = -1
    k_h = fy / dy
    for i in range(n):
        f_i = force[i] if i < nf else 0.0
        a = (f_i - _internal(x, v, 0.0, exps, coefs, eff) - fy * z) * inv_m
        out[i, 0] = x
        out[i, 1] = v
        out[i, 2] = a
        out[i, 3] = z
        if i == n - 1:
            break
        f_next = force[i + 1] if i + 1 < nf else 0.0
        for s in range(substeps):
            fa = f_i + (f_next - f_i) * (s / substeps)
            fm = f_i + (f_next - f_i) * ((s + 0.5) / substeps)
            fb = f_i + (f_next - f_i) * ((s + 1.0) / substeps)
            a1 = (fa - _internal(x, v, 0.0, exps, coefs, eff) - fy * z) * inv_m
            z1 = v / dy * _bw_rate(z, v, n_exp)
            x2 = x + 0.5 * h * v
            v2 = v + 0.5 * h * a1
            zz2 = z + 0.5 * h * z1
            a2 = (fm - _internal(x2, v2, 0.0, exps, coefs, eff) - fy * zz2) * inv_m
            z2 = v2 / dy * _bw_rate(zz2, v2, n_exp)
            x3 = x + 0.5 * h * v2
            v3 = v + 0.5 * h * a2
            zz3 = z + 0.5 * h * z2
            a3 = (fm - _internal(x3, v3, 0.0, exps, coefs, eff) - fy * zz3) * inv_m
            z3 = v3 / dy * _bw_rate(zz3, v3, n_exp)
            x4 = x + h * v3
            v4 = v + h * a3
            zz4 = z + h * z3
            a4 = (fb - _internal(x4, v4, 0.0, exps, coefs, eff) - fy * zz4) * inv_m
            z4 = v4 / dy * _bw_rate(zz4, v4, n_exp)
            x = x + h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
            v = v + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
            z = z + h / 6.0 * (z1 + 2.0 * z2 + 2.0 * z3 + z4)
            if z > 1.0:  # the exact solution never leaves [-1, 1]; a coarse step may
                z = 1.0
            elif z < -1.0:
                z = -1.0
        if not (math.isfinite(x) and math.isfinite(v)) or abs(x) > 1e12 or abs(v) > 1e15 or k_h < 0:
            diverged = i + 1
            break
    if diverged >= 0:
        for j in range(diverged, n):
            out[j, 0] = np.nan
            out[j, 1] = np.nan
            out[j, 2] = np.nan
            out[j, 3] = np.nan
    return diverged


def bouc_wen_z(x: np.ndarray, yield_displacement: float, exponent: float,
               at: np.ndarray | None = None) -> np.ndarray:
    """The Bouc-Wen variable ``z`` (``|z| <= 1``) along a sampled displacement path, from ``z = 0``.

    Exact along the piecewise-linear path through the samples (each monotone stretch solved in
    closed form through the tabulated ``G(z) = int dz / (1 - z^n)``, see the kernel notes): the
    result does not depend on how finely a stretch is sampled, so only the samples asked for
    and the reversals are evaluated.

    Parameters
    ----------
    x : ndarray, shape (n,), [m]
        Displacement, in time order.
    yield_displacement : float, [m]
    exponent : float
        Sharpness ``n`` (> 0).
    at : ndarray of int, shape (k,), optional
        Increasing sample indices to return ``z`` at (default: every sample).

    Returns
    -------
    ndarray, shape (n,) or (k,)
    """
    if not (yield_displacement > 0 and exponent > 0):
        raise ModelError("hysteresis needs yield_displacement_m > 0 and exponent > 0")
    x = np.ascontiguousarray(x, dtype=float)
    need = np.arange(x.size, dtype=np.int64) if at is None else np.ascontiguousarray(at, dtype=np.int64)
    if need.size and (need[0] < 0 or need[-1] >= x.size or np.any(np.diff(need) <= 0)):
        raise ModelError("bouc_wen_z: 'at' must be increasing sample indices of x")
    out = np.zeros(need.size)
    if need.size:
        g0, d = _table(float(exponent))
        _KERNELS._bw_exact(x, float(yield_displacement), float(exponent), need, _R_STEP, g0, d, out)
    return out


def bouc_wen_z_rk2(x: np.ndarray, yield_displacement: float, exponent: float) -> np.ndarray:
    """:func:`bouc_wen_z` by the earlier operator: RK2 steps of at most 0.02 in ``x / d_y``
    (at most 400 per sample), ~1e-4 off the exact path; kept to compare with."""
    if not (yield_displacement > 0 and exponent > 0):
        raise ModelError("hysteresis needs yield_displacement_m > 0 and exponent > 0")
    x = np.ascontiguousarray(x, dtype=float)
    out = np.zeros(x.size)
    if x.size:
        _KERNELS._bw_path(x, float(yield_displacement), float(exponent), out)
    return out


#: Tables of the exact operator by exponent (the grid's few exponents are reused; a search's
#: are not): at most 64 kept, 30 kB each.
_TABLES: dict[float, tuple[np.ndarray, np.ndarray]] = {}


def _table(n_exp: float) -> tuple[np.ndarray, np.ndarray]:
    got = _TABLES.get(n_exp)
    if got is None:
        g0, d = np.empty(_R_CELLS + 1), np.empty(_R_CELLS + 1)
        _KERNELS._bw_table(n_exp, _R_STEP, g0, d)
        got = _TABLES[n_exp] = (g0, d)
        if len(_TABLES) > 64:
            _TABLES.pop(next(iter(_TABLES)))
    return got


def simulate_hysteretic(eom, f: np.ndarray, dt: float, n: int, x0: float, v0: float, substeps: int,
                        exps: np.ndarray, coefs: np.ndarray, eff: np.ndarray) -> tuple[np.ndarray, int]:
    """RK4 of a model with a ``hysteresis`` effect (called by :func:`eddi.simulate.simulate`).

    Returns the output ``(n, 4)`` array (``x, v, a, z``) and the first diverged sample (-1: none).
    """
    p = eom.effect("hysteresis").params
    if eom.effect("second_mode") is not None:
        raise ModelError("a model cannot have both hysteresis and a second_mode effect")
    out = np.empty((n, 4))
    state0 = np.array([float(x0), float(v0), 0.0])
    div = _KERNELS._rk4_hyst(f, dt, int(substeps), state0, 1.0 / eom.mass, exps, coefs, eff,
                             float(p["yield_force_n"]), float(p["yield_displacement_m"]), float(p["exponent"]), out)
    return out, int(div)


_KERNELS = Kernels(globals(), {
    "_bw_path": ["void(f8[::1], f8, f8, f8[::1])"],
    "_bw_table": ["void(f8, f8, f8[::1], f8[::1])"],
    "_bw_exact": ["void(f8[::1], f8, f8, i8[::1], f8, f8[::1], f8[::1], f8[::1])"],
    "_rk4_hyst": ["i8(f8[::1], f8, i8, f8[::1], f8, i8[:, ::1], f8[::1], f8[::1], f8, f8, f8, f8[:, ::1])"],
}, callees=("_bw_rate", "_internal", "_bw_small", "_bw_g", "_bw_G", "_bw_Z", "_bw_branch"))
