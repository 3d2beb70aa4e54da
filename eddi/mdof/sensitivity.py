"""Forward sensitivities of an :class:`~eddi.mdof.model.MdofModel`'s simulated response.

The output-error polish (:mod:`eddi.mdof.refine`) needs the Jacobian of the simulated
displacement with respect to the model's parameters. By finite differences that is one
simulation per parameter per Jacobian (77 % of a three-mass ``station diagnose``). Here the
variational equations are integrated alongside the state, with the same fixed-step RK4 and the
same stage states as :func:`eddi.mdof.simulate.simulate_mdof` (the single-DOF analogue is
:mod:`eddi.sensitivity`). For an explicit Runge-Kutta method that is forward-mode
differentiation of the discrete scheme itself, so the result is the exact derivative of what
``simulate_mdof`` returns (to rounding), not an approximation of the ODE's one.

The ODE parameters ``theta`` are every term's coefficient (in :func:`~eddi.mdof.simulate.term_table`
order) and every coordinate's inverse mass::

    v_i' = inv_m_i (u_i F(t) - sum_j [eq_j = i] coef_j T_j(x, v))
    S_x' = S_v,   S_v' = A_x S_x + A_v S_v + d(v')/d theta

with ``A_x``, ``A_v`` the Jacobian of the acceleration in ``x`` and ``v``. Per RK stage the
cost is one pass over the terms (their gradients) and a ``n x 2n`` by ``2n x n_theta`` product:
on a three-mass model with ~20 terms about a sixth of the flops of the ~20 finite-difference
simulations it replaces.
"""

from __future__ import annotations

import numba
import numpy as np

from eddi.mdof.model import MdofModel
from eddi.mdof.simulate import step_count, term_table


@numba.njit(cache=True)
def _ipow(z, p):  # pragma: no cover - compiled
    out = 1.0
    for _ in range(p):
        out *= z
    return out


@numba.njit(cache=True)
def _accel_sens(x, v, sx, sv, f, eq, coef, fvar, fpow, fabs, inv_m, u, dptr, didx, dval,
                a, sa, jx, jv, vals, ders):  # pragma: no cover - compiled
    """Acceleration ``a`` (n,) and its derivative ``sa`` (n_dir, n) along the directions (``theta``
    rows ``dptr``/``didx``/``dval``, compressed) at one stage. Term ``j`` is the product of its
    factors ``z^fpow |z|^fabs``, ``z`` variable ``fvar`` (x_0..x_n-1 then v_0..v_n-1; -1 ends)."""
    n = x.shape[0]
    n_terms = eq.shape[0]
    n_dir = sa.shape[0]
    for i in range(n):
        a[i] = u[i] * f
        for k in range(n):
            jx[i, k] = 0.0
            jv[i, k] = 0.0
    for th in range(n_dir):
        for i in range(n):
            sa[th, i] = 0.0
    for j in range(n_terms):
        nf = 0
        t = 1.0
        for m in range(fvar.shape[1]):
            var = fvar[j, m]
            if var < 0:
                break
            z = x[var] if var < n else v[var - n]
            p = fpow[j, m]
            q = fabs[j, m]
            az = abs(z)
            zp = _ipow(z, p)
            aq = _ipow(az, q)
            der = 0.0
            if p > 0:
                der += p * _ipow(z, p - 1) * aq
            if q > 0:
                sg = 1.0 if z > 0 else (-1.0 if z < 0 else 0.0)
                der += zp * q * _ipow(az, q - 1) * sg
            vals[m] = zp * aq
            ders[m] = der
            t *= vals[m]
            nf += 1
        i = eq[j]
        c = coef[j]
        a[i] -= c * t
        for r in range(dptr[j], dptr[j + 1]):
            sa[didx[r], i] -= dval[r] * t
        for m in range(nf):
            g = ders[m]
            for m2 in range(nf):
                if m2 != m:
                    g *= vals[m2]
            var = fvar[j, m]
            if var < n:
                jx[i, var] -= c * g
            else:
                jv[i, var - n] -= c * g
    for th in range(n_dir):
        for i in range(n):
            s = sa[th, i]
            for k in range(n):
                s += jx[i, k] * sx[th, k] + jv[i, k] * sv[th, k]
            sa[th, i] = s
    for i in range(n):
        raw = a[i]
        a[i] = raw * inv_m[i]
        for th in range(n_dir):
            sa[th, i] *= inv_m[i]
        for r in range(dptr[n_terms + i], dptr[n_terms + i + 1]):
            sa[didx[r], i] += dval[r] * raw


@numba.njit(cache=True)
def _stage_state(x, v, sx, sv, dx, dv, dsx, dsv, c, xt, vt, sxt, svt):  # pragma: no cover - compiled
    """An RK stage's state: ``(x, v, S_x, S_v) + c * (dx, dv, dS_x, dS_v)`` (the last stage's slopes)."""
    for k in range(x.shape[0]):
        xt[k] = x[k] + c * dx[k]
        vt[k] = v[k] + c * dv[k]
        for th in range(sx.shape[0]):
            sxt[th, k] = sx[th, k] + c * dsx[th, k]
            svt[th, k] = sv[th, k] + c * dsv[th, k]


@numba.njit(cache=True)
def _rk4_sens(force, dt, substeps, x0, v0, eq, coef, fvar, fpow, fabs, inv_m, u, dptr, didx, dval,
              xs, sxs):  # pragma: no cover - compiled
    """RK4 of the state and its derivatives along ``dirs``; ``xs`` (n, n_out), ``sxs`` (n_dir, n, n_out).
    Returns the first output index after a blow-up, or -1.

    Stage ``s`` (2..4) is evaluated at ``state + c_s * slopes of stage s-1`` (:func:`_stage_state`,
    ``c`` = h/2, h/2, h); its velocities ``v_s`` and ``S_v,s`` are the stage's ``x``-slopes."""
    n_out = xs.shape[1]
    n = x0.shape[0]
    n_theta = sxs.shape[0]
    x = x0.copy()
    v = v0.copy()
    sx = np.zeros((n_theta, n))
    sv = np.zeros((n_theta, n))
    h = dt / substeps
    a1 = np.empty(n); a2 = np.empty(n); a3 = np.empty(n); a4 = np.empty(n)
    s1 = np.empty((n_theta, n)); s2 = np.empty((n_theta, n)); s3 = np.empty((n_theta, n))
    s4 = np.empty((n_theta, n))
    x2 = np.empty(n); x3 = np.empty(n); x4 = np.empty(n)
    v2 = np.empty(n); v3 = np.empty(n); v4 = np.empty(n)
    sx2 = np.empty((n_theta, n)); sx3 = np.empty((n_theta, n)); sx4 = np.empty((n_theta, n))
    sv2 = np.empty((n_theta, n)); sv3 = np.empty((n_theta, n)); sv4 = np.empty((n_theta, n))
    jx = np.empty((n, n)); jv = np.empty((n, n))
    vals = np.empty(max(1, fvar.shape[1])); ders = np.empty(max(1, fvar.shape[1]))
    nf = force.shape[0]
    for i in range(n_out):
        f0 = force[i] if i < nf else 0.0
        f1 = force[i + 1] if i + 1 < nf else 0.0
        for k in range(n):
            xs[k, i] = x[k]
            for th in range(n_theta):
                sxs[th, k, i] = sx[th, k]
        if i == n_out - 1:
            break
        for s in range(substeps):
            fa = f0 + (f1 - f0) * s / substeps
            fm = f0 + (f1 - f0) * (s + 0.5) / substeps
            fb = f0 + (f1 - f0) * (s + 1.0) / substeps
            _accel_sens(x, v, sx, sv, fa, eq, coef, fvar, fpow, fabs, inv_m, u, dptr, didx, dval,
                        a1, s1, jx, jv, vals, ders)
            _stage_state(x, v, sx, sv, v, a1, sv, s1, 0.5 * h, x2, v2, sx2, sv2)
            _accel_sens(x2, v2, sx2, sv2, fm, eq, coef, fvar, fpow, fabs, inv_m, u, dptr, didx, dval,
                        a2, s2, jx, jv, vals, ders)
            _stage_state(x, v, sx, sv, v2, a2, sv2, s2, 0.5 * h, x3, v3, sx3, sv3)
            _accel_sens(x3, v3, sx3, sv3, fm, eq, coef, fvar, fpow, fabs, inv_m, u, dptr, didx, dval,
                        a3, s3, jx, jv, vals, ders)
            _stage_state(x, v, sx, sv, v3, a3, sv3, s3, h, x4, v4, sx4, sv4)
            _accel_sens(x4, v4, sx4, sv4, fb, eq, coef, fvar, fpow, fabs, inv_m, u, dptr, didx, dval,
                        a4, s4, jx, jv, vals, ders)
            for k in range(n):
                x[k] += h / 6.0 * (v[k] + 2 * v2[k] + 2 * v3[k] + v4[k])
                v[k] += h / 6.0 * (a1[k] + 2 * a2[k] + 2 * a3[k] + a4[k])
                for th in range(n_theta):
                    sx[th, k] += h / 6.0 * (sv[th, k] + 2 * sv2[th, k] + 2 * sv3[th, k] + sv4[th, k])
                    sv[th, k] += h / 6.0 * (s1[th, k] + 2 * s2[th, k] + 2 * s3[th, k] + s4[th, k])
        for k in range(n):
            if not (abs(x[k]) < 1e30 and abs(v[k]) < 1e30):
                return i + 1
    return -1


def simulate_sensitivities(model: MdofModel, t: np.ndarray, force: np.ndarray | None, *,
                           x0: np.ndarray | None = None, v0: np.ndarray | None = None,
                           x_scale: float | np.ndarray | None = None, directions: np.ndarray | None = None,
                           states: np.ndarray | None = None, coarsen: int = 1) -> tuple[np.ndarray, np.ndarray, bool]:
    """Coordinates and their derivatives in ``theta`` (module docstring) on the uniform grid ``t``.

    Same sub-steps (:func:`~eddi.mdof.simulate.step_count` of ``x_scale`` or ``states``), force
    interpolation and initial state as :func:`~eddi.mdof.simulate.simulate_mdof` (whose ``x`` the first output equals).
    ``coarsen``: that many times fewer sub-steps (rounded up; at least one): ``h * omega`` up to
    ``coarsen`` times the simulation's 0.05, RK4's error about ``coarsen^4`` times its own (for a
    Jacobian that steers a least squares, not for a prediction: :data:`eddi.mdof.refine.JACOBIAN_COARSEN`).

    Returns
    -------
    x : ndarray, shape (n_coords, n), [m]
    dx : ndarray, shape (n_dir, n_coords, n)
        Derivative along each column of ``directions`` (n_theta, n_dir): by default the
        identity, ``d x / d coef_j`` [m per coefficient unit] then ``d x / d inv_m_i`` [m kg].
    diverged : bool
    """
    t = np.asarray(t, float)
    dt = float((t[-1] - t[0]) / (t.size - 1))
    n = model.n_coords
    f = np.zeros(t.size) if force is None else np.ascontiguousarray(force, dtype=float)
    x0a = np.zeros(n) if x0 is None else np.asarray(x0, float).reshape(n).copy()
    v0a = np.zeros(n) if v0 is None else np.asarray(v0, float).reshape(n).copy()
    substeps = max(1, -(-step_count(model, dt, x_scale, states) // max(1, int(coarsen))))
    eq, coef, exps = term_table(model)
    xs = np.full((n, t.size), np.nan)
    dirs = np.eye(eq.size + n) if directions is None else np.ascontiguousarray(directions, dtype=float)
    if dirs.shape[0] != eq.size + n:
        raise ValueError(f"directions: expected {eq.size + n} rows (terms and masses), got {dirs.shape[0]}")
    dx = np.full((dirs.shape[1], n, t.size), np.nan)
    fvar, fpow, fabs = _factors(exps)
    nz = [np.nonzero(row)[0] for row in dirs]
    dptr = np.concatenate([[0], np.cumsum([z.size for z in nz])]).astype(np.int64)
    didx = np.concatenate([z for z in nz] + [np.zeros(0, np.int64)]).astype(np.int64)
    dval = np.concatenate([row[z] for row, z in zip(dirs, nz)] + [np.zeros(0)])
    div = _rk4_sens(f, dt, int(substeps), x0a, v0a, eq, coef, fvar, fpow, fabs, 1.0 / np.asarray(model.mass, float),
                    np.asarray(model.input, float), dptr, didx, dval, xs, dx)
    return xs, dx, bool(div >= 0)


def _factors(exps: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each term's factors (variable, power, power of the magnitude) from the exponent table
    ``(k, 4, n)`` of :func:`~eddi.mdof.simulate.term_table`; rows padded with variable -1."""
    n_terms, _four, n = exps.shape
    rows = []
    for j in range(n_terms):
        rows.append([(w * n + k, int(exps[j, w, k]), int(exps[j, 2 + w, k]))
                     for w in range(2) for k in range(n) if exps[j, w, k] > 0 or exps[j, 2 + w, k] > 0])
    width = max([len(r) for r in rows] + [1])
    out = np.full((3, n_terms, width), -1, dtype=np.int64)
    for j, r in enumerate(rows):
        for m, f in enumerate(r):
            out[:, j, m] = f
    return out[0], np.maximum(out[1], 0), np.maximum(out[2], 0)


def theta(model: MdofModel) -> np.ndarray:
    """The ODE parameters of the module docstring: the coefficients then the inverse masses."""
    return np.concatenate([term_table(model)[1], 1.0 / np.asarray(model.mass, float)])


def predict_sensitivities(model: MdofModel, record, directions: np.ndarray | None = None, coarsen: int = 1
                          ) -> tuple[np.ndarray, np.ndarray, bool]:
    """:func:`eddi.mdof.validate.predict_channels`'s ``y_sim`` and its derivatives in ``theta``
    (``coarsen``: :func:`simulate_sensitivities`).

    The high-pass, the window and the shapes are linear, so the derivative goes through them as
    the displacement does.

    Returns
    -------
    y_sim : ndarray, shape (n_channels, k), [m]
    dy : ndarray, shape (n_dir, n_channels, k)
        Along ``directions`` (:func:`simulate_sensitivities`).
    diverged : bool
    """
    from eddi.mdof.signals import highpass

    from eddi.mdof.validate import simulation_start

    phi = model.phi
    w0, w1 = record.window
    n = record.t.size
    rate = 1.0 / float(record.t[1] - record.t[0])
    st = simulation_start(model, record)
    s = st.sample
    xs, dx, div = simulate_sensitivities(model, record.t[s:], st.force, x0=st.x0, v0=st.v0, states=st.states,
                                         directions=directions, coarsen=coarsen)
    n_theta = dx.shape[0]
    if div or not (np.all(np.isfinite(xs)) and np.all(np.isfinite(dx))):
        return (np.full((phi.shape[0], w1 - w0), np.nan), np.zeros((n_theta, phi.shape[0], w1 - w0)), True)
    q = np.zeros((1 + n_theta, model.n_coords, n))
    q[0, :, s:] = xs
    q[1:, :, s:] = dx
    q = highpass(q, rate, record.highpass_hz, times=2)[:, :, w0:w1]
    y = np.einsum("cj,tjk->tck", phi, q)
    return y[0], y[1:], False
