"""Simulation of an :class:`~eddi.mdof.model.MdofModel`: fixed-step RK4 compiled with numba.

As :mod:`eddi.simulate` for one coordinate: the force is sampled on the output grid and
interpolated linearly between samples; each output interval is split into sub-steps so that
``h * omega_max <= 0.05``, where ``omega_max`` bounds the stiffest equation at the expected
amplitude (:func:`auto_substeps`). ``tests/eddi/test_mdof.py`` checks the result against
``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from eddi.errors import SignalError
from eddi.mdof.model import MdofModel


@dataclass(frozen=True)
class MdofSimulation:
    """Simulated response on the output grid.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
    x, v, a : ndarray, shape (n_coords, n)
        Coordinates, rates and accelerations.
    diverged : bool
        True when the state blew up (samples after that are NaN).
    substeps : int
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    diverged: bool
    substeps: int


def term_table(model: MdofModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Flattened terms: equation index (k,), coefficient (k,), exponents (k, 4, n)."""
    eq, coef, exps = [], [], []
    for i in range(model.n_coords):
        for term, c in model.terms(i):
            eq.append(i)
            coef.append(c)
            exps.append(term.exponents)
    n = model.n_coords
    return (np.array(eq, dtype=np.int64), np.array(coef, dtype=float),
            np.array(exps, dtype=np.int64).reshape(len(eq), 4, n))


@numba.njit(cache=True)
def _accel(x, v, f, eq, coef, exps, inv_m, u, out):  # pragma: no cover - compiled
    n = x.shape[0]
    for i in range(n):
        out[i] = u[i] * f
    for j in range(eq.shape[0]):
        val = coef[j]
        for k in range(n):
            p = exps[j, 0, k]
            if p > 0:
                val *= x[k] ** p
            p = exps[j, 1, k]
            if p > 0:
                val *= v[k] ** p
            p = exps[j, 2, k]
            if p > 0:
                val *= abs(x[k]) ** p
            p = exps[j, 3, k]
            if p > 0:
                val *= abs(v[k]) ** p
        out[eq[j]] -= val
    for i in range(n):
        out[i] *= inv_m[i]


@numba.njit(cache=True)
def _rk4(force, dt, substeps, x0, v0, eq, coef, exps, inv_m, u, xs, vs, as_):  # pragma: no cover
    n_out = xs.shape[1]
    n = x0.shape[0]
    x = x0.copy()
    v = v0.copy()
    h = dt / substeps
    k1x = np.empty(n); k1v = np.empty(n); k2x = np.empty(n); k2v = np.empty(n)
    k3x = np.empty(n); k3v = np.empty(n); k4x = np.empty(n); k4v = np.empty(n)
    xt = np.empty(n); vt = np.empty(n)
    nf = force.shape[0]
    diverged = -1
    for i in range(n_out):
        f0 = force[i] if i < nf else 0.0
        f1 = force[i + 1] if i + 1 < nf else 0.0
        _accel(x, v, f0, eq, coef, exps, inv_m, u, k1v)
        for k in range(n):
            xs[k, i] = x[k]
            vs[k, i] = v[k]
            as_[k, i] = k1v[k]
        if i == n_out - 1:
            break
        for s in range(substeps):
            fa = f0 + (f1 - f0) * s / substeps
            fm = f0 + (f1 - f0) * (s + 0.5) / substeps
            fb = f0 + (f1 - f0) * (s + 1.0) / substeps
            _accel(x, v, fa, eq, coef, exps, inv_m, u, k1v)
            for k in range(n):
                k1x[k] = v[k]
                xt[k] = x[k] + 0.5 * h * k1x[k]
                vt[k] = v[k] + 0.5 * h * k1v[k]
            _accel(xt, vt, fm, eq, coef, exps, inv_m, u, k2v)
            for k in range(n):
                k2x[k] = vt[k]
                xt[k] = x[k] + 0.5 * h * k2x[k]
                vt[k] = v[k] + 0.5 * h * k2v[k]
            _accel(xt, vt, fm, eq, coef, exps, inv_m, u, k3v)
            for k in range(n):
                k3x[k] = vt[k]
                xt[k] = x[k] + h * k3x[k]
                vt[k] = v[k] + h * k3v[k]
            _accel(xt, vt, fb, eq, coef, exps, inv_m, u, k4v)
            for k in range(n):
                k4x[k] = vt[k]
                x[k] += h / 6.0 * (k1x[k] + 2 * k2x[k] + 2 * k3x[k] + k4x[k])
                v[k] += h / 6.0 * (k1v[k] + 2 * k2v[k] + 2 * k3v[k] + k4v[k])
        bad = False
        for k in range(n):
            if not (abs(x[k]) < 1e30 and abs(v[k]) < 1e30):
                bad = True
        if bad:
            diverged = i + 1
            break
    return diverged


def auto_substeps(model: MdofModel, dt: float, x_scale: float | np.ndarray | None = None) -> int:
    """Sub-steps per output interval so that ``h * omega_max <= 0.05``.

    ``omega_max^2`` bounds each equation's stiffness ``sum |k| d x^(d-1) / m`` at coordinate
    magnitude ``x_scale`` (per coordinate; default 0, the linear bound), plus the linear
    matrices' largest eigenvalue.
    """
    n = model.n_coords
    xs = np.broadcast_to(np.asarray(0.0 if x_scale is None else x_scale, float), (n,))
    w2 = 0.0
    for i in range(n):
        s = 0.0
        for term, c in model.terms(i):
            if term.depends_on_v:  # damping barely limits RK4's step
                continue
            d = term.degree
            mag = float(np.prod(xs ** term.exponents[[0, 2]].sum(axis=0))) if d > 1 else 1.0
            s += abs(c) * d * (mag / max(float(xs.max()), 1e-300) if d > 1 else 1.0)
        w2 = max(w2, s / model.mass[i])
    w = math.sqrt(w2) if w2 > 0 else 0.0
    return int(min(1000, max(1, math.ceil(dt * w / 0.05))))


def stiffness_jacobians(model: MdofModel, states: np.ndarray) -> np.ndarray:
    """``M^-1 dK/dx`` at each state: shape (k, n, n) for ``states`` (n_coords, k) [m].

    ``K`` is every term that does not depend on a rate (as :func:`auto_substeps`, damping barely
    limits RK4's step); its derivative is exact for the monomials ``x^p |x|^q``.
    """
    n = model.n_coords
    xs = np.asarray(states, float).reshape(n, -1)
    jac = np.zeros((xs.shape[1], n, n))
    for i in range(n):
        for term, c in model.terms(i):
            if term.depends_on_v:
                continue
            p, q = term.exponents[0], term.exponents[2]
            vals = [xs[k] ** int(p[k]) * np.abs(xs[k]) ** int(q[k]) for k in range(n)]
            for k in np.nonzero(p + q)[0]:
                der = np.zeros(xs.shape[1])
                if p[k] > 0:
                    der = der + p[k] * xs[k] ** int(p[k] - 1) * np.abs(xs[k]) ** int(q[k])
                if q[k] > 0:
                    der = der + q[k] * xs[k] ** int(p[k]) * np.abs(xs[k]) ** int(q[k] - 1) * np.sign(xs[k])
                others = np.prod([vals[m] for m in range(n) if m != k], axis=0) if n > 1 else 1.0
                jac[:, i, k] += c * der * others
    return jac / np.asarray(model.mass, float)[None, :, None]


def trajectory_substeps(model: MdofModel, dt: float, states: np.ndarray,
                        margin: float | None = None) -> int:
    """Sub-steps per output interval so that ``h * omega <= 0.05`` along the states met.

    ``omega^2`` is the largest spectral radius of the stiffness's Jacobian ``M^-1 dK/dx``
    (:func:`stiffness_jacobians`) over ``states`` (n_coords, k) [m] - the record's coordinates
    over the simulated span - scaled by ``margin`` (default :data:`TRAJECTORY_MARGIN`) so that a
    simulation which leaves the measured trajectory keeps the accuracy target. The coupling
    terms' contributions then cancel where they do on the trajectory; :func:`auto_substeps` adds
    their magnitudes with every coordinate at its own peak at once (opposite phases), which on
    session 13's three-mass chain asked for 43 sub-steps where the linear part needs 13.
    """
    xs = np.asarray(states, float).reshape(model.n_coords, -1)
    xs = xs[:, np.all(np.isfinite(xs), axis=0)]
    if _linear_stiffness(model):  # the Jacobian is the same matrix at every state: one is the maximum
        xs = xs[:, :1]
    m = TRAJECTORY_MARGIN if margin is None else float(margin)
    w2 = 0.0
    for chunk in range(0, max(xs.shape[1], 1), 4096):
        part = np.zeros((model.n_coords, 1)) if xs.shape[1] == 0 else xs[:, chunk:chunk + 4096]
        radius = np.max(np.abs(np.linalg.eigvals(stiffness_jacobians(model, m * part))))
        w2 = max(w2, float(radius))
    w = math.sqrt(w2) if w2 > 0 and math.isfinite(w2) else 0.0
    return int(min(1000, max(1, math.ceil(dt * w / 0.05))))


def _linear_stiffness(model: MdofModel) -> bool:
    """True when every term without a rate is linear in one coordinate (``x_k``, no ``|x|``): then
    :func:`stiffness_jacobians` is the same matrix at every state, exactly (each entry ``c * 1.0 *
    1.0``), and :func:`trajectory_substeps` needs one state, not the record's 1e4-1e5 (session 18:
    the linear lumped baselines' simulations spent ~11 ms each on those eigenvalues)."""
    return all(term.depends_on_v or (term.degree == 1 and not term.exponents[2].any())
               for i in range(model.n_coords) for term, _c in model.terms(i))


def step_count(model: MdofModel, dt: float, x_scale: float | np.ndarray | None = None,
               states: np.ndarray | None = None) -> int:
    """:func:`trajectory_substeps` on ``states`` when given, else :func:`auto_substeps` on ``x_scale``."""
    if states is not None:
        return trajectory_substeps(model, dt, states)
    return auto_substeps(model, dt, x_scale)


#: Amplitude factor on the measured states for :func:`trajectory_substeps`: the model's
#: simulation may overshoot the record (a held-out miss) by this much before the step's
#: accuracy target ``h * omega <= 0.05`` is exceeded.
TRAJECTORY_MARGIN = 1.5


def simulate_mdof(
    model: MdofModel,
    t: np.ndarray,
    force: np.ndarray | None = None,
    *,
    x0: np.ndarray | None = None,
    v0: np.ndarray | None = None,
    x_scale: float | np.ndarray | None = None,
    substeps: int | None = None,
    states: np.ndarray | None = None,
) -> MdofSimulation:
    """Integrate the model on the uniform grid ``t``.

    Parameters
    ----------
    model : MdofModel
    t : ndarray, shape (n,), [s]
    force : ndarray, shape (n,), [N], optional
        Force at the driving point (0 when None).
    x0, v0 : ndarray, shape (n_coords,), optional
        Initial state (rest by default).
    x_scale : float or ndarray, optional
        Expected peak of each coordinate, for :func:`auto_substeps`.
    substeps : int, optional
    states : ndarray, shape (n_coords, k), [m], optional
        The coordinates the simulation is expected to meet (a record's): sub-steps from
        :func:`trajectory_substeps` (which takes precedence over ``x_scale``).

    Raises
    ------
    SignalError
        Non-uniform time, force of another length.
    """
    t = np.asarray(t, float)
    if t.ndim != 1 or t.size < 2:
        raise SignalError(f"t must be 1-D with at least 2 samples, got shape {t.shape}")
    dt = float((t[-1] - t[0]) / (t.size - 1))
    if not dt > 0:
        raise SignalError("t must be increasing")
    n = model.n_coords
    f = np.zeros(t.size) if force is None else np.ascontiguousarray(force, dtype=float)
    if f.shape != t.shape:
        raise SignalError(f"force has shape {f.shape}, expected {t.shape}")
    x0a = np.zeros(n) if x0 is None else np.asarray(x0, float).reshape(n).copy()
    v0a = np.zeros(n) if v0 is None else np.asarray(v0, float).reshape(n).copy()
    if substeps is None:
        substeps = step_count(model, dt, x_scale, states)
    eq, coef, exps = term_table(model)
    xs = np.full((n, t.size), np.nan)
    vs = np.full((n, t.size), np.nan)
    as_ = np.full((n, t.size), np.nan)
    inv_m = 1.0 / np.asarray(model.mass, float)
    div = _rk4(f, dt, int(substeps), x0a, v0a, eq, coef, exps, inv_m,
               np.asarray(model.input, float), xs, vs, as_)
    return MdofSimulation(t, xs, vs, as_, bool(div >= 0), int(substeps))
