"""How fast a model can oscillate over a range of states: the simulator's and the refinement's step choices.

:func:`max_angular_frequency` bounds the local angular frequency from the sum of the terms'
``|c|`` (and the effects); :func:`local_angular_frequency` reads it from the tangent stiffness
``|dK/dx|`` and damping ``|dB/dv|`` on a grid of the range (alternating-sign polynomials inflate
the bound several times). :mod:`eddi.simulate` picks its sub-steps and dense grids with them,
:mod:`eddi.refine_grid` the refinement's blocks and steps. The grid's force and gradient run in
one compiled pass a range (:func:`_tangent_max`, session 16; :mod:`eddi.kernels`), the same
numbers bit for bit as the numpy code it replaced (:func:`_local_frequency_numpy`).
"""

from __future__ import annotations

import math

import numpy as np

from eddi.kernels import Kernels
from eddi.model import EquationOfMotion
from eddi.terms import parse_term


def max_angular_frequency(eom: EquationOfMotion, x_scale: float = 0.0, v_scale: float = 0.0) -> float:
    """Largest local angular frequency [rad/s] the model reaches for ``|x| <= x_scale``.

    Uses the tangent stiffness ``|dK/dx|`` and the tangent damping ``|dB/dv| / m`` of every
    term at the given scales; the second mode's own frequency is included.
    """
    k_tan = 0.0
    c_tan = 0.0
    xs = max(abs(x_scale), 0.0)
    vs = max(abs(v_scale), 0.0)
    for text, c in eom.stiffness.items():
        t = parse_term(text)
        deg = t.x_degree
        if deg >= 1:
            k_tan += abs(c) * deg * (xs ** (deg - 1) if deg > 1 else 1.0)
    for text, c in eom.damping.items():
        t = parse_term(text)
        dv = t.v_degree
        dx = t.x_degree
        if dv >= 1:
            c_tan += abs(c) * dv * (vs ** (dv - 1) if dv > 1 else 1.0) * (xs**dx if dx else 1.0)
    omega2 = 0.0
    for e in eom.effects:
        p = e.params
        if e.name == "clearance":
            k_tan += abs(p["stiffness_n_per_m"])
        elif e.name == "asymmetric_stiffness":
            k_tan += abs(p["k2"]) * 2 * xs + abs(p["k4"]) * 4 * xs**3
        elif e.name == "second_mode":
            k_tan += abs(p["coupling_n_per_m"])
            omega2 = (abs(p["stiffness_n_per_m"]) + abs(p["coupling_n_per_m"])) / p["mass_kg"]
            c_tan = max(c_tan, 0.0)
        elif e.name == "quadratic_damping":
            c_tan += abs(p["coefficient"]) * 2 * vs
        elif e.name == "hysteresis":
            k_tan += abs(p["yield_force_n"]) / p["yield_displacement_m"]
        elif e.name == "coulomb_friction":
            c_tan += abs(p["force_n"]) / p["velocity_scale"] * 0.0  # smoothed; not a rate limit
    omega = math.sqrt(k_tan / eom.mass) if k_tan > 0 else 0.0
    omega = max(omega, math.sqrt(omega2), c_tan / eom.mass)
    return omega


def local_angular_frequency(eom: EquationOfMotion, x_amp: float, v_amp: float) -> float:
    """Largest local angular frequency [rad/s] of ``eom`` over ``|x| <= x_amp``, ``|v| <= v_amp``.

    From the tangent stiffness ``|dK/dx|`` and tangent damping ``|dB/dv|`` evaluated on a grid
    of the range (not the sum of ``|c|`` bounds of :func:`max_angular_frequency`, which
    alternating-sign polynomials inflate several times); models with effects, or without a
    range, use that bound. :func:`local_angular_frequencies` of one range.
    """
    return float(local_angular_frequencies(eom, [x_amp], [v_amp])[0])


#: Points of :func:`local_angular_frequencies`' grid along each range.
LOCAL_FREQUENCY_POINTS = 257


def local_angular_frequencies(eom: EquationOfMotion, x_amps, v_amps) -> np.ndarray:
    """:func:`local_angular_frequency` at several ranges ``(x_amps[i], v_amps[i])``.

    The same numbers bit for bit as before session 16 (``tests/eddi/test_local_frequency.py``):
    the force of :func:`_polynomial_force` on the six lines (``K`` along ``x`` at ``v = 0,
    +-v_amp``, ``B`` along ``v`` at ``x = 0, +-x_amp``, 257 points each, ``np.linspace``'s grid)
    and ``np.gradient``'s arithmetic, in one compiled pass per range (:func:`_tangent_max`). It
    runs ~20 times per identification (the validation's segments, the refinement's 12 amplitude
    levels) and ~100 per diagnosis fit: the numpy version was ~30 small array operations a range.
    """
    xa = np.array(x_amps, dtype=float).reshape(-1)
    va = np.array(v_amps, dtype=float).reshape(-1)
    out = np.empty(xa.size)
    ranged = (xa > 0) & (va > 0)
    if eom.effects or not ranged.all():
        for i in range(xa.size):  # the bound, where there is no range to grid (or effects)
            if eom.effects or not ranged[i]:
                out[i] = max_angular_frequency(eom, float(xa[i]), float(va[i]))
        if eom.effects or not ranged.any():
            return out
    terms = {**eom.damping, **eom.stiffness}  # _polynomial_force's terms and order
    exps = np.array([parse_term(text).exponents for text in terms], dtype=np.int64).reshape(-1, 6)
    coefs = np.array(list(terms.values()), dtype=float)
    n = LOCAL_FREQUENCY_POINTS
    tan = np.empty(2)
    for i in np.flatnonzero(ranged):
        a, b = float(xa[i]), float(va[i])
        if not (TINY_RANGE <= a < math.inf and TINY_RANGE <= b < math.inf):
            out[i] = _local_frequency_numpy(eom, a, b)  # spacings whose products underflow to 0
            continue
        _KERNELS._tangent_max(exps, coefs, _linspace(a, n), _linspace(b, n), a, b, tan)
        out[i] = max(math.sqrt(float(tan[0]) / eom.mass), float(tan[1]) / eom.mass)
    return out


#: Below this range the grid's spacings (range / 128) multiply to a subnormal or 0, which the
#: compiled kernel would divide by (an exception there, inf / NaN in numpy): numpy answers.
TINY_RANGE = 1e-140


def _local_frequency_numpy(eom: EquationOfMotion, x_amp: float, v_amp: float) -> float:
    """:func:`local_angular_frequency` of a model without effects as numpy computed it before
    session 16 (the compiled :func:`_tangent_max` gives the same numbers)."""
    n = LOCAL_FREQUENCY_POINTS
    xs = np.linspace(-x_amp, x_amp, n)
    vs = np.linspace(-v_amp, v_amp, n)
    xx = np.empty(6 * n)
    vv = np.empty(6 * n)
    for i, xv in enumerate((0.0, x_amp, -x_amp)):
        xx[i * n:(i + 1) * n] = xs
        xx[(3 + i) * n:(4 + i) * n] = xv
        vv[i * n:(i + 1) * n] = xv * v_amp / x_amp
        vv[(3 + i) * n:(4 + i) * n] = vs
    with np.errstate(all="ignore"):
        f = _polynomial_force(eom, xx, vv).reshape(6, n)
        k_tan = float(np.max(np.abs(np.gradient(f[:3], xs, axis=1))))
        c_tan = float(np.max(np.abs(np.gradient(f[3:], vs, axis=1))))
    return max(math.sqrt(k_tan / eom.mass), c_tan / eom.mass)


def _linspace(a: float, n: int) -> np.ndarray:
    """``np.linspace(-a, a, n)`` with numpy's arithmetic (its ~10 us of argument handling spared)."""
    step = (a - (-a)) / (n - 1)
    if step == 0.0:  # numpy's path for subnormal ranges
        return np.linspace(-a, a, n)
    y = np.arange(0, n, dtype=float)
    y *= step
    y += -a
    y[-1] = a
    return y


def _polynomial_force(eom: EquationOfMotion, x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """:meth:`EquationOfMotion.restoring_force` of a model without effects, on two float arrays of
    one shape, bit for bit: each term as :meth:`eddi.terms.Term.evaluate_unchecked` gives it, times
    its coefficient, the first term plus 0.0 and the others added in order, as that method sums
    them; without its checks and broadcasting (~2x faster on :func:`local_angular_frequency`'s
    1542 points; ``tests/eddi/test_local_frequency.py`` compares the two)."""
    total = None
    for text, c in {**eom.damping, **eom.stiffness}.items():
        f = c * parse_term(text).evaluate_unchecked(x, v)
        if total is None:
            f += 0.0
            total = f
        else:
            total += f
    return np.zeros(x.shape) if total is None else total


def _power_of(y, p):  # pragma: no cover - compiled
    """:func:`eddi.terms._power` of one value (``y**p``: ``y``, ``y*y``, then repeated products)."""
    if p == 1:
        return y
    out = y * y
    for _ in range(p - 2):
        out *= y
    return out


def _force_at(exps, coefs, x, v):  # pragma: no cover - compiled
    """:func:`_polynomial_force` at one point: each term's factors multiplied in
    :func:`eddi.terms._factor_product`'s order, times its coefficient, the first plus 0.0, the
    others added in order (the same operations, so the same number)."""
    total = 0.0
    for i in range(exps.shape[0]):
        have = False
        prod = 1.0
        for k in range(6):
            p = exps[i, k]
            if k >= 4:
                p = p % 2
            if p == 0:
                continue
            if k == 0:
                fac = _power_of(x, p)
            elif k == 1:
                fac = _power_of(v, p)
            elif k == 2:
                fac = _power_of(abs(x), p)
            elif k == 3:
                fac = _power_of(abs(v), p)
            else:
                y = x if k == 4 else v
                fac = 1.0 if y > 0.0 else (-1.0 if y < 0.0 else (y if y != y else 0.0))  # np.sign
            if have:
                prod *= fac
            else:
                prod = fac
                have = True
        f = coefs[i] * prod
        if i == 0:
            total = f + 0.0
        else:
            total += f
    return total


def _tangent_max(exps, coefs, xs, vs, xa, va, out):  # pragma: no cover - compiled
    """:func:`local_angular_frequencies`' largest ``|dK/dx|`` (``out[0]``, along ``x`` at
    ``v = 0, +-va``) and ``|dB/dv|`` (``out[1]``, along ``v`` at ``x = 0, +-xa``) of one range:
    the force on the six lines and ``np.gradient``'s arithmetic (first-order edges; the
    uniform formula when the spacing is constant), the maximum propagating a NaN as ``np.max``."""
    n = xs.shape[0]
    f = np.empty(n)
    for axis in range(2):
        grid = xs if axis == 0 else vs
        uniform = True
        for j in range(1, n - 1):
            if (grid[j + 1] - grid[j]) != (grid[1] - grid[0]):
                uniform = False
        best = 0.0
        nan = False
        for line in range(3):
            other = 0.0 if line == 0 else (xa if line == 1 else -xa)
            for j in range(n):
                if axis == 0:
                    f[j] = _force_at(exps, coefs, grid[j], other * va / xa)
                else:
                    f[j] = _force_at(exps, coefs, other, grid[j])
            for j in range(n):
                if j == 0:
                    g = (f[1] - f[0]) / (grid[1] - grid[0])
                elif j == n - 1:
                    g = (f[n - 1] - f[n - 2]) / (grid[n - 1] - grid[n - 2])
                elif uniform:
                    g = (f[j + 1] - f[j - 1]) / (2.0 * (grid[1] - grid[0]))
                else:
                    dx1 = grid[j] - grid[j - 1]
                    dx2 = grid[j + 1] - grid[j]
                    a = -dx2 / (dx1 * (dx1 + dx2))
                    b = (dx2 - dx1) / (dx1 * dx2)
                    c = dx1 / (dx2 * (dx1 + dx2))
                    g = a * f[j - 1] + b * f[j] + c * f[j + 1]
                g = abs(g)
                if g != g:
                    nan = True
                elif g > best:
                    best = g
        out[axis] = np.nan if nan else best


#: The compiled kernel (:mod:`eddi.kernels`: built ahead of time, else numba's JIT).
_KERNELS = Kernels(globals(), {"_tangent_max": ["void(i8[:, ::1], f8[::1], f8[::1], f8[::1], f8, f8, f8[::1])"]},
                   callees=("_power_of", "_force_at"))
