"""Free response and its parameter sensitivities in one RK4 pass (forward sensitivity equations).

For ``m x'' + R(x, v) = 0`` with ``R = sum_j c_j phi_j(x, v)`` (the polynomial terms of
:mod:`eddi.terms`), the sensitivities ``s = dx/dq`` to a parameter ``q`` obey

    s' = s_v,    m s_v' = -(R_x s + R_v s_v) - dR/dq,

with ``dR/dc_j = phi_j`` for a coefficient and ``0`` for the initial state (``s(0) = 1``
for ``q = x0``, ``s_v(0) = 1`` for ``q = v0``). Integrating them with the state gives the
Jacobian of the simulated response with respect to every coefficient and the initial state
exactly (to the integrator's accuracy), at about twice the cost of one simulation, where a
forward-difference Jacobian costs one simulation per parameter. The output-error
refinement (:mod:`eddi.refine`) uses it for its Levenberg-Marquardt steps and its
confidence intervals.

Only models without effects (:class:`eddi.model.Effect`) are handled here (the
refinement falls back to finite differences for the others).
"""

from __future__ import annotations

import math

import numpy as np

from eddi.kernels import Kernels
from eddi.model import EquationOfMotion
from eddi.terms import exponent_table


def _rhs(x, v, sx, sv, exps, coefs, inv_m, pw, dsx, dsv, use_abs):  # pragma: no cover - compiled
    """Acceleration of the state, and the sensitivities' rates into dsx, dsv.

    ``pw``: work array (4, deg + 1) for the powers of x, v, |x|, |v| (rows 2, 3 stay at 1
    unless ``use_abs``: some term has a power of ``|x|`` or ``|v|``).
    """
    ax = abs(x)
    av = abs(v)
    sgx = 1.0 if x > 0 else (-1.0 if x < 0 else 0.0)
    sgv = 1.0 if v > 0 else (-1.0 if v < 0 else 0.0)
    pw[0, 0] = 1.0
    pw[1, 0] = 1.0
    pw[2, 0] = 1.0
    pw[3, 0] = 1.0
    for k in range(1, pw.shape[1]):
        pw[0, k] = pw[0, k - 1] * x
        pw[1, k] = pw[1, k - 1] * v
    if use_abs:  # the powers of |x|, |v| only for the terms that have them (same values)
        for k in range(1, pw.shape[1]):
            pw[2, k] = pw[2, k - 1] * ax
            pw[3, k] = pw[3, k - 1] * av
    nt = exps.shape[0]
    npar = sx.shape[0]
    r = 0.0
    rx = 0.0
    rv = 0.0
    for j in range(nt):
        px, pv, pax, pav = exps[j, 0], exps[j, 1], exps[j, 2], exps[j, 3]
        fx = pw[0, px]
        fv = pw[1, pv]
        if use_abs:  # (else rows 2, 3 are 1: the products would be the same numbers)
            fx *= pw[2, pax]
            fv *= pw[3, pav]
        if exps[j, 4] % 2 == 1:
            fx *= sgx
        if exps[j, 5] % 2 == 1:
            fv *= sgv
        phi = fx * fv
        r += coefs[j] * phi
        if npar == 0:  # the response alone: no derivative of the force is needed
            continue
        dx = 0.0
        dv = 0.0
        if px >= 1:
            dx = px * pw[0, px - 1]
            if use_abs:
                dx *= pw[2, pax]
        if pv >= 1:
            dv = pv * pw[1, pv - 1]
            if use_abs:
                dv *= pw[3, pav]
        if use_abs:  # (pax, pav are 0 without it)
            if pax >= 1:
                dx += pax * pw[0, px] * pw[2, pax - 1] * sgx
            if pav >= 1:
                dv += pav * pw[1, pv] * pw[3, pav - 1] * sgv
        if exps[j, 4] % 2 == 1:
            dx *= sgx
        if exps[j, 5] % 2 == 1:
            dv *= sgv
        rx += coefs[j] * dx * fv
        rv += coefs[j] * fx * dv
        dsv[j] = -phi * inv_m  # the coefficient's own term
    for k in range(npar):
        dsx[k] = sv[k]
        if k >= nt:
            dsv[k] = 0.0
        dsv[k] -= (rx * sx[k] + rv * sv[k]) * inv_m
    return -r * inv_m


def _rk4_sens(deg, dt, substeps, x0, v0, inv_m, exps, coefs, n, out_x, out_v, out_a, sens_x, sens_v, sens_a):  # pragma: no cover
    nt = exps.shape[0]
    npar = sens_x.shape[1]  # nt + 2, or 0 for the response alone
    sx = np.zeros(npar)
    sv = np.zeros(npar)
    if npar > 0:
        sx[nt] = 1.0
        sv[nt + 1] = 1.0
    pw = np.ones((4, deg + 1))
    use_abs = False
    for j in range(nt):
        if exps[j, 2] > 0 or exps[j, 3] > 0:
            use_abs = True
    k1x = np.zeros(npar)
    k1v = np.zeros(npar)
    k2x = np.zeros(npar)
    k2v = np.zeros(npar)
    k3x = np.zeros(npar)
    k3v = np.zeros(npar)
    k4x = np.zeros(npar)
    k4v = np.zeros(npar)
    tx = np.zeros(npar)
    tv = np.zeros(npar)
    x = x0
    v = v0
    for i in range(n):
        a = _rhs(x, v, sx, sv, exps, coefs, inv_m, pw, k1x, k1v, use_abs)
        out_x[i] = x
        out_v[i] = v
        out_a[i] = a
        for k in range(npar):
            sens_x[i, k] = sx[k]
            sens_v[i, k] = sv[k]
            sens_a[i, k] = k1v[k]
        if i == n - 1:
            break
        m = substeps[i] if i < substeps.shape[0] else substeps[substeps.shape[0] - 1]
        h = dt / m
        for s in range(m):
            a1 = a
            if s > 0:  # at s == 0, k1 is the output sample's evaluation above
                a1 = _rhs(x, v, sx, sv, exps, coefs, inv_m, pw, k1x, k1v, use_abs)
            for k in range(npar):
                tx[k] = sx[k] + 0.5 * h * k1x[k]
                tv[k] = sv[k] + 0.5 * h * k1v[k]
            x2 = x + 0.5 * h * v
            v2 = v + 0.5 * h * a1
            a2 = _rhs(x2, v2, tx, tv, exps, coefs, inv_m, pw, k2x, k2v, use_abs)
            for k in range(npar):
                tx[k] = sx[k] + 0.5 * h * k2x[k]
                tv[k] = sv[k] + 0.5 * h * k2v[k]
            x3 = x + 0.5 * h * v2
            v3 = v + 0.5 * h * a2
            a3 = _rhs(x3, v3, tx, tv, exps, coefs, inv_m, pw, k3x, k3v, use_abs)
            for k in range(npar):
                tx[k] = sx[k] + h * k3x[k]
                tv[k] = sv[k] + h * k3v[k]
            x4 = x + h * v3
            v4 = v + h * a3
            a4 = _rhs(x4, v4, tx, tv, exps, coefs, inv_m, pw, k4x, k4v, use_abs)
            x = x + h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
            v = v + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
            for k in range(npar):
                sx[k] += h / 6.0 * (k1x[k] + 2.0 * k2x[k] + 2.0 * k3x[k] + k4x[k])
                sv[k] += h / 6.0 * (k1v[k] + 2.0 * k2v[k] + 2.0 * k3v[k] + k4v[k])
        if not (math.isfinite(x) and math.isfinite(v)) or abs(x) > 1e12 or abs(v) > 1e15:
            return i + 1
    return -1


def free_response_sensitivities(eom: EquationOfMotion, dt: float, n: int, x0: float, v0: float,
                                substeps: int | np.ndarray,
                                jacobian: bool = True) -> tuple[np.ndarray, np.ndarray, bool]:
    """Free response of ``eom`` and its Jacobian with respect to coefficients and initial state.

    Parameters
    ----------
    eom : EquationOfMotion
        Without effects; its damping then stiffness terms, in their order, are the
        coefficient parameters.
    dt : float
        Output interval [s].
    n : int
        Output samples (the first is the initial state).
    x0, v0 : float
        Initial state.
    substeps : int or ndarray of int, shape (n - 1,)
        RK4 steps per output interval (one number, or one per interval: fewer where the
        response has decayed and moves slower).
    jacobian : bool
        False: the response alone (the same integration as :func:`eddi.simulate.simulate`
        for these models, with the terms' powers formed by multiplication).

    Returns
    -------
    response : ndarray, shape (n, 3)
        ``x, v, a`` at the output times.
    jacobian : ndarray, shape (3, n, n_terms + 2) (``n_terms + 2`` is 0 without ``jacobian``)
        ``d(x, v, a) / d(c_1..c_nt, x0, v0)``; NaN after a divergence.
    diverged : bool
    """
    if eom.effects:
        raise ValueError("sensitivities are implemented for models without effects")
    exps = exponent_table(eom.damping_terms() + eom.stiffness_terms())
    coefs = np.array(list(eom.damping.values()) + list(eom.stiffness.values()), dtype=float)
    npar = coefs.size + 2 if jacobian else 0
    # the kernel writes every sample up to a divergence (returned: the first it did not
    # write); only those after it are filled (NaN): no pass over the whole Jacobian first
    resp = np.empty((3, n))
    jac = np.empty((3, n, npar))
    deg = int(exps[:, :4].max()) if exps.size else 0
    steps = np.maximum(np.atleast_1d(np.asarray(substeps, dtype=np.int64)), 1)
    div = _KERNELS._rk4_sens(deg, float(dt), steps, float(x0), float(v0), 1.0 / eom.mass, exps, coefs, int(n),
                    resp[0], resp[1], resp[2], jac[0], jac[1], jac[2])
    if div >= 0:
        resp[:, div:] = np.nan
        jac[:, div:] = np.nan
    return resp.T, jac, bool(div >= 0)


#: The compiled kernels (:mod:`eddi.kernels`: built ahead of time, else numba's JIT).
_KERNELS = Kernels(globals(), {
    "_rk4_sens": ["i8(i8, f8, i8[::1], f8, f8, f8, i8[:, ::1], f8[::1], i8, f8[::1], f8[::1], f8[::1], f8[:, ::1], f8[:, ::1], f8[:, ::1])"],
}, callees=("_rhs",))
