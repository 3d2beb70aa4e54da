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
:func:`eddi.simulate.simulate` (which calls it for such a model). Its kernels are compiled by
numba at first use (cached on disk), not ahead of time.
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


def bouc_wen_z(x: np.ndarray, yield_displacement: float, exponent: float) -> np.ndarray:
    """The Bouc-Wen variable ``z`` (``|z| <= 1``) along a sampled displacement path, from ``z = 0``.

    Parameters
    ----------
    x : ndarray, shape (n,), [m]
        Displacement, in time order.
    yield_displacement : float, [m]
    exponent : float
        Sharpness ``n`` (> 0).

    Returns
    -------
    ndarray, shape (n,)
    """
    if not (yield_displacement > 0 and exponent > 0):
        raise ModelError("hysteresis needs yield_displacement_m > 0 and exponent > 0")
    x = np.ascontiguousarray(x, dtype=float)
    out = np.zeros(x.size)
    if x.size:
        _KERNELS._bw_path(x, float(yield_displacement), float(exponent), out)
    return out


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
    "_rk4_hyst": ["i8(f8[::1], f8, i8, f8[::1], f8, i8[:, ::1], f8[::1], f8[::1], f8, f8, f8, f8[:, ::1])"],
}, callees=("_bw_rate", "_internal"))
