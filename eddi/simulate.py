"""Fast simulation of an :class:`~eddi.model.EquationOfMotion`.

A fixed-step classical Runge-Kutta (RK4) integrator compiled with numba. The force is
sampled on the output grid and interpolated linearly between samples (as MATLAB's
``interp1`` in the paper's validation). Each output interval can be split into several
sub-steps; :func:`auto_substeps` picks enough of them that ``h * omega_max <= 0.1`` for the
stiffest state the model is expected to reach, which keeps RK4's relative error per cycle
well below 1e-6.

The compiled kernel evaluates terms from their exponent table (see :mod:`eddi.terms`), so
one compilation serves every model: built ahead of time (``python -m eddi.kernels``) or
compiled by numba at first use and cached on disk (:mod:`eddi.kernels`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eddi.errors import ModelError, SignalError
from eddi.kernels import Kernels
from eddi.model import EquationOfMotion
from eddi.local_frequency import _polynomial_force as _polynomial_force  # re-exported (tests)
from eddi.local_frequency import local_angular_frequencies as local_angular_frequencies  # re-exported
from eddi.local_frequency import local_angular_frequency, max_angular_frequency
from eddi.peaks import finite, last_nonzero, peak_abs
from eddi.terms import exponent_table

# Layout of the effect parameter vector handed to the kernel.
_E_COULOMB, _E_VS, _E_QUAD, _E_GAP, _E_KC, _E_K2, _E_K4 = 0, 1, 2, 3, 4, 5, 6
_E_M2, _E_K2M, _E_C2M, _E_KCM, _E_HAS_MODE, _E_HAS_CLEAR = 7, 8, 9, 10, 11, 12
_N_EFFECT = 13


@dataclass(frozen=True)
class SimulationResult:
    """Simulated response on the output grid.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
    x : ndarray, shape (n,)
        Coordinate.
    v : ndarray, shape (n,)
        Rate.
    a : ndarray, shape (n,)
        Second derivative (from the equation of motion).
    y : ndarray, shape (n,) or None
        Second-mode coordinate, when the model has a ``second_mode`` effect.
    diverged : bool
        True when the state blew up; samples after that are NaN.
    substeps : int
        RK4 sub-steps used per output interval.
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    y: np.ndarray | None
    diverged: bool
    substeps: int


def _internal(x, v, y, exps, coefs, eff):  # pragma: no cover - compiled
    total = 0.0
    for j in range(exps.shape[0]):
        val = coefs[j]
        px = exps[j, 0]
        pv = exps[j, 1]
        pax = exps[j, 2]
        pav = exps[j, 3]
        if px > 0:
            val *= x**px
        if pv > 0:
            val *= v**pv
        if pax > 0:
            val *= abs(x) ** pax
        if pav > 0:
            val *= abs(v) ** pav
        if exps[j, 4] % 2 == 1:
            val *= (x > 0) - (x < 0)
        if exps[j, 5] % 2 == 1:
            val *= (v > 0) - (v < 0)
        total += val
    if eff[_E_COULOMB] != 0.0:
        total += eff[_E_COULOMB] * math.tanh(v / eff[_E_VS])
    if eff[_E_QUAD] != 0.0:
        total += eff[_E_QUAD] * abs(v) * v
    if eff[_E_HAS_CLEAR] != 0.0:
        ax = abs(x) - eff[_E_GAP]
        if ax > 0.0:
            total += eff[_E_KC] * ax * ((x > 0) - (x < 0))
    if eff[_E_K2] != 0.0 or eff[_E_K4] != 0.0:
        x2 = x * x
        total += eff[_E_K2] * x2 + eff[_E_K4] * x2 * x2
    if eff[_E_HAS_MODE] != 0.0:
        total += eff[_E_KCM] * (x - y)
    return total


def _rk4(force, dt, substeps, state0, inv_m, exps, coefs, eff, out):  # pragma: no cover
    n = out.shape[0]
    x = state0[0]
    v = state0[1]
    y = state0[2]
    w = state0[3]
    has_mode = eff[_E_HAS_MODE] != 0.0
    m2inv = 1.0 / eff[_E_M2] if has_mode else 0.0
    k2m = eff[_E_K2M]
    c2m = eff[_E_C2M]
    kcm = eff[_E_KCM]
    h = dt / substeps
    nf = force.shape[0]
    diverged = -1
    for i in range(n):
        f_i = force[i] if i < nf else 0.0
        a = (f_i - _internal(x, v, y, exps, coefs, eff)) * inv_m
        out[i, 0] = x
        out[i, 1] = v
        out[i, 2] = a
        out[i, 3] = y
        if i == n - 1:
            break
        f_next = force[i + 1] if i + 1 < nf else 0.0
        for s in range(substeps):
            fa = f_i + (f_next - f_i) * (s / substeps)
            fm = f_i + (f_next - f_i) * ((s + 0.5) / substeps)
            fb = f_i + (f_next - f_i) * ((s + 1.0) / substeps)
            # k1
            a1 = (fa - _internal(x, v, y, exps, coefs, eff)) * inv_m
            b1 = (-c2m * w - k2m * y - kcm * (y - x)) * m2inv if has_mode else 0.0
            x2 = x + 0.5 * h * v
            v2 = v + 0.5 * h * a1
            y2 = y + 0.5 * h * w
            w2 = w + 0.5 * h * b1
            a2 = (fm - _internal(x2, v2, y2, exps, coefs, eff)) * inv_m
            b2 = (-c2m * w2 - k2m * y2 - kcm * (y2 - x2)) * m2inv if has_mode else 0.0
            x3 = x + 0.5 * h * v2
            v3 = v + 0.5 * h * a2
            y3 = y + 0.5 * h * w2
            w3 = w + 0.5 * h * b2
            a3 = (fm - _internal(x3, v3, y3, exps, coefs, eff)) * inv_m
            b3 = (-c2m * w3 - k2m * y3 - kcm * (y3 - x3)) * m2inv if has_mode else 0.0
            x4 = x + h * v3
            v4 = v + h * a3
            y4 = y + h * w3
            w4 = w + h * b3
            a4 = (fb - _internal(x4, v4, y4, exps, coefs, eff)) * inv_m
            b4 = (-c2m * w4 - k2m * y4 - kcm * (y4 - x4)) * m2inv if has_mode else 0.0
            x = x + h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
            v = v + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
            y = y + h / 6.0 * (w + 2.0 * w2 + 2.0 * w3 + w4)
            w = w + h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4)
        if not (math.isfinite(x) and math.isfinite(v)) or abs(x) > 1e12 or abs(v) > 1e15:
            diverged = i + 1
            break
    if diverged >= 0:
        for j in range(diverged, n):
            out[j, 0] = np.nan
            out[j, 1] = np.nan
            out[j, 2] = np.nan
            out[j, 3] = np.nan
    return diverged


def _effect_vector(eom: EquationOfMotion) -> np.ndarray:
    eff = np.zeros(_N_EFFECT)
    eff[_E_VS] = 1.0
    eff[_E_M2] = 1.0
    for e in eom.effects:
        p = e.params
        if e.name == "coulomb_friction":
            eff[_E_COULOMB] = p["force_n"]
            eff[_E_VS] = p["velocity_scale"]
        elif e.name == "quadratic_damping":
            eff[_E_QUAD] = p["coefficient"]
        elif e.name == "clearance":
            eff[_E_GAP] = p["gap_m"]
            eff[_E_KC] = p["stiffness_n_per_m"]
            eff[_E_HAS_CLEAR] = 1.0
        elif e.name == "asymmetric_stiffness":
            eff[_E_K2] = p["k2"]
            eff[_E_K4] = p["k4"]
        elif e.name == "hysteresis":  # its own state: eddi.hysteresis integrates it
            continue
        elif e.name == "second_mode":
            eff[_E_M2] = p["mass_kg"]
            eff[_E_K2M] = p["stiffness_n_per_m"]
            eff[_E_C2M] = p["damping_n_s_per_m"]
            eff[_E_KCM] = p["coupling_n_per_m"]
            eff[_E_HAS_MODE] = 1.0
        else:  # pragma: no cover - validated by the model
            raise ModelError(f"unknown effect {e.name!r}")
    return eff


#: Most RK4 sub-steps per output interval: 64 steps of ``omega h = 0.1`` span 6.4 rad, twice the
#: Nyquist frequency of the output grid; a model that needs more at the record's amplitudes
#: oscillates faster than the record can show (a wild fit, not the structure) and is left to
#: diverge rather than integrated with millions of steps.
MAX_SUBSTEPS = 64


def auto_substeps(eom: EquationOfMotion, dt: float, x_scale: float = 0.0, v_scale: float = 0.0,
                  h_omega: float = 0.1, max_substeps: int = MAX_SUBSTEPS) -> int:
    """Sub-steps per sample so that ``h * omega_max <= h_omega``."""
    omega = max_angular_frequency(eom, x_scale, v_scale)
    return int(min(max_substeps, max(1, math.ceil(dt * omega / h_omega))))


def simulate(
    eom: EquationOfMotion,
    t: np.ndarray | None = None,
    *,
    rate_hz: float | None = None,
    n_samples: int | None = None,
    force: np.ndarray | None = None,
    x0: float = 0.0,
    v0: float = 0.0,
    x_scale: float | None = None,
    v_scale: float | None = None,
    substeps: int | None = None,
) -> SimulationResult:
    """Simulate the equation of motion on a uniform grid.

    Give either ``t`` (uniform, increasing) or ``rate_hz`` and ``n_samples``.

    Parameters
    ----------
    eom : EquationOfMotion
    t : ndarray, shape (n,), [s], optional
        Output times (uniform). The state at ``t[0]`` is ``(x0, v0)``.
    rate_hz : float, optional
        Sample rate, when ``t`` is not given.
    n_samples : int, optional
        Number of output samples, when ``t`` is not given.
    force : ndarray, shape (m,), [N], optional
        External force sampled on the same grid; taken as 0 beyond its end.
    x0, v0 : float
        Initial state.
    x_scale, v_scale : float, optional
        Expected amplitudes, used to choose sub-steps (default: from ``x0, v0`` and the
        force, using the linear stiffness).
    substeps : int, optional
        Force a number of RK4 sub-steps per output interval.

    Returns
    -------
    SimulationResult
    """
    t, dt, n, f, substeps = _prepared(eom, t, rate_hz, n_samples, force, x0, v0, x_scale, v_scale, substeps)
    exps = exponent_table(eom.damping_terms() + eom.stiffness_terms())
    coefs = np.array(list(eom.damping.values()) + list(eom.stiffness.values()), dtype=float)
    eff = _effect_vector(eom)
    if eom.effect("hysteresis") is not None:
        from eddi.hysteresis import simulate_hysteretic

        out, div = simulate_hysteretic(eom, f, dt, n, x0, v0, substeps, exps, coefs, eff)
    else:
        out = np.empty((n, 4))
        state0 = np.array([float(x0), float(v0), 0.0, 0.0])
        div = _KERNELS._rk4(f, dt, substeps, state0, 1.0 / eom.mass, exps, coefs, eff, out)
    has_mode = eom.effect("second_mode") is not None
    return SimulationResult(
        t=t,
        x=out[:, 0].copy(),
        v=out[:, 1].copy(),
        a=out[:, 2].copy(),
        y=out[:, 3].copy() if has_mode else None,
        diverged=bool(div >= 0),
        substeps=substeps,
    )


def _prepared(eom: EquationOfMotion, t: np.ndarray | None, rate_hz: float | None, n_samples: int | None,
              force: np.ndarray | None, x0: float, v0: float, x_scale: float | None, v_scale: float | None,
              substeps: int | None) -> tuple[np.ndarray, float, int, np.ndarray, int]:
    """:func:`simulate`'s checks and choices: the times, step [s], samples, force and sub-steps."""
    if t is not None:
        t = np.asarray(t, dtype=float)
        if t.ndim != 1 or t.size < 2:
            raise SignalError("time must be a 1-D array of at least 2 samples")
        dt = float(t[1] - t[0])
        if not dt > 0 or not np.allclose(np.diff(t), dt, rtol=1e-6, atol=1e-12):
            raise SignalError("time must be uniform and increasing")
        n = t.size
    else:
        if rate_hz is None or n_samples is None or rate_hz <= 0 or n_samples < 2:
            raise SignalError("give t, or rate_hz > 0 and n_samples >= 2")
        dt = 1.0 / float(rate_hz)
        n = int(n_samples)
        t = np.arange(n) * dt
    f = np.zeros(0) if force is None else np.ascontiguousarray(force, dtype=float)
    if f.ndim != 1:
        raise SignalError("force must be 1-D")
    if not np.all(np.isfinite(f)):
        raise SignalError("force contains NaN or infinite values")
    if substeps is None:
        k1 = abs(eom.linear_stiffness()) or 1.0
        omega1 = math.sqrt(k1 / eom.mass)
        # an impulse I gives a rate of about I/m; its largest peak bounds the rate reached
        v_force = peak_abs(np.cumsum(f)) * dt / eom.mass if f.size else 0.0
        vs = v_scale if v_scale is not None else max(abs(v0) + v_force, abs(x0) * omega1)
        xs = x_scale if x_scale is not None else max(abs(x0), vs / omega1)
        substeps = auto_substeps(eom, dt, xs, vs)
    substeps = int(substeps)
    if substeps < 1:
        raise SignalError("substeps must be >= 1")
    return t, dt, n, f, substeps


def free_simulator(eom: EquationOfMotion, t: np.ndarray, *, force: np.ndarray | None = None,
                   x_scale: float, v_scale: float):
    """``simulate(eom, t, force=force, x0=x0, v0=v0, x_scale=x_scale, v_scale=v_scale)`` as a
    function of the initial state, for fits of it: the checks, sub-steps and term tables are
    computed once (they do not depend on ``x0, v0`` when both scales are given).

    Returns
    -------
    callable
        ``run(x0, v0) -> (x, v)``, each ndarray of shape (n,): the same numbers bit for bit
        as :func:`simulate`'s ``x`` and ``v``.
    """
    # simulate's checks and sub-steps (from the scales, not the state), without its run
    _t, dt, n, f, substeps = _prepared(eom, t, None, None, force, 0.0, 0.0, x_scale, v_scale, None)
    exps = exponent_table(eom.damping_terms() + eom.stiffness_terms())
    coefs = np.array(list(eom.damping.values()) + list(eom.stiffness.values()), dtype=float)
    eff = _effect_vector(eom)
    hysteretic = eom.effect("hysteresis") is not None
    inv_m = 1.0 / eom.mass

    def run(x0: float, v0: float) -> tuple[np.ndarray, np.ndarray]:
        if hysteretic:
            from eddi.hysteresis import simulate_hysteretic

            out, _ = simulate_hysteretic(eom, f, dt, n, x0, v0, substeps, exps, coefs, eff)
        else:
            out = np.empty((n, 4))
            _KERNELS._rk4(f, dt, substeps, np.array([float(x0), float(v0), 0.0, 0.0]), inv_m, exps, coefs,
                          eff, out)
        return out[:, 0], out[:, 1]

    return run


#: Dense output: largest ``omega * q * dt`` of the coarse output grid (cubic Hermite
#: interpolation error ~``(omega h)^4 / 384``: 4e-6 relative at 0.2) ...
DENSE_H_OMEGA = 0.2
#: ... and of an RK4 step on it (phase error ~``(omega h)^5 / 120`` per step: 3e-9 at 0.05).
DENSE_STEP_H_OMEGA = 0.05
#: The force-free part is simulated in up to this many segments, each on the grid and steps of
#: the local frequency at the amplitude the previous one reached (:func:`simulate_dense`) ...
DENSE_SEGMENTS = 8
#: ... times this margin (the coarse grid samples a peak to cos(DENSE_H_OMEGA / 2) = 0.995).
DENSE_AMPLITUDE_MARGIN = 1.02


def _internal_many(x, v, exps, coefs, eff, out):  # pragma: no cover - compiled
    for i in range(x.shape[0]):
        out[i] = _internal(x[i], v[i], 0.0, exps, coefs, eff)


def internal_force(eom: EquationOfMotion, x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``sum b_j B_j + sum k_n K_n + effects`` at every sample (second mode at rest), compiled.

    The same as :meth:`eddi.model.EquationOfMotion.restoring_force` (to rounding), ~30x
    faster on long records (the simulator's own kernel).

    Parameters
    ----------
    eom : EquationOfMotion
    x, v : ndarray, shape (n,)

    Returns
    -------
    ndarray, shape (n,), [N]
    """
    x = np.ascontiguousarray(x, dtype=float)
    v = np.ascontiguousarray(v, dtype=float)
    exps = exponent_table(eom.damping_terms() + eom.stiffness_terms())
    coefs = np.array(list(eom.damping.values()) + list(eom.stiffness.values()), dtype=float)
    out = np.empty(x.size)
    _KERNELS._internal_many(x, v, exps, coefs, _effect_vector(eom), out)
    return out


def hermite_weights(q: int, h: float) -> np.ndarray:
    """The cubic Hermite basis at the ``q`` offsets ``s = i / q`` of a grid interval ``h`` long.

    Rows: ``h00, h10 * h, h01, h11 * h`` (for ``x`` from ``x, v`` and ``v`` from ``v, a``) and
    ``1 - s, s`` (linear ``a``, for plots). The one place the formulas live: the compiled fill
    (:func:`_hermite_fill`) and the numpy picker (:func:`_hermite_at`) both read them (the same
    floats as forming them per sample: ``h10 * h`` is the product the formula forms first)."""
    s = np.arange(q) / q
    s2 = s * s
    s3 = s2 * s
    return np.array([2.0 * s3 - 3.0 * s2 + 1.0, (s3 - 2.0 * s2 + s) * h, -2.0 * s3 + 3.0 * s2,
                     (s3 - s2) * h, 1.0 - s, s])


def _hermite_fill(xc, vc, ac, w, x, v, a):  # pragma: no cover - compiled
    """Cubic Hermite from every ``q``-th sample (``x, v`` and ``v, a``) onto every sample.

    ``w``: :func:`hermite_weights` (``q = w.shape[1]``). A sample on the grid takes the grid's
    value: it reads no point after it (the last sample of a segment ending on the grid has
    none; reading past the end gave a NaN on some machines). The basis is formed once per
    offset, then each grid interval is filled from it: no division per sample (0.5 against
    1.6 ms on 460k samples, the same numbers bit for bit; ``tests/eddi/test_kernels.py``)."""
    n = x.shape[0]
    q = w.shape[1]
    k = 0
    for j in range(0, n, q):
        x0 = xc[k]
        v0 = vc[k]
        a0 = ac[k]
        x[j] = x0  # on the grid
        v[j] = v0
        a[j] = a0
        m = min(q, n - j)
        if m > 1:
            x1 = xc[k + 1]
            v1 = vc[k + 1]
            a1 = ac[k + 1]
            for i in range(1, m):
                x[j + i] = w[0, i] * x0 + w[1, i] * v0 + w[2, i] * x1 + w[3, i] * v1
                v[j + i] = w[0, i] * v0 + w[1, i] * a0 + w[2, i] * v1 + w[3, i] * a1
                a[j + i] = w[4, i] * a0 + w[5, i] * a1  # for plots; not compared
        k += 1


def simulate_dense(eom: EquationOfMotion, t: np.ndarray, *, force: np.ndarray | None = None, x0: float = 0.0,
                   v0: float = 0.0, x_scale: float, v_scale: float, at: np.ndarray | None = None) -> SimulationResult:
    """:func:`simulate` for a record sampled far faster than the model moves.

    Up to the last non-zero force sample the simulation runs on every sample (as
    :func:`simulate`); after it, on every ``q``-th sample (``q`` such that
    ``omega q dt <= DENSE_H_OMEGA``, ``omega``: :func:`local_angular_frequency` over the
    given scales) with RK4 steps of ``omega h <= DENSE_STEP_H_OMEGA``, and ``x, v`` are
    interpolated back onto every sample by cubic Hermite (from ``x, v`` and ``v, a``).
    Records with ``q < 4``, and models with effects or ``sign`` terms (whose sharp switches
    the coarse steps would blur), are simulated on every sample. The difference from
    :func:`simulate` is ~1e-5 of the amplitude over a 45 s ring-down at 19.2 kHz, at
    ~1/10 of its cost.

    Parameters
    ----------
    eom : EquationOfMotion
    t : ndarray, shape (n,), [s]
        Uniform output times; the state at ``t[0]`` is ``(x0, v0)``.
    force : ndarray, shape (n,), [N], optional
    x0, v0 : float
    x_scale, v_scale : float
        Amplitudes the response reaches (sub-steps and ``q``).
    at : ndarray of int, optional
        Increasing sample indices: the result holds only these samples (the same values as
        at those samples of the whole result, up to rounding; the interpolation runs at
        these alone: the refinement's judge reads EDDI's simulation at 1 in 23 samples).

    Returns
    -------
    SimulationResult
        On every sample of ``t`` (``at``: on ``t[at]``; ``substeps`` is that of the fine part).
    """
    t = np.asarray(t, dtype=float)
    n = t.size
    dt = float(t[1] - t[0])
    omega = local_angular_frequency(eom, x_scale, v_scale)
    q = int(DENSE_H_OMEGA / (omega * dt)) if omega > 0 and math.isfinite(omega) else 1
    f = np.zeros(0) if force is None else np.asarray(force, dtype=float)
    last = _end_of_force(f)  # one past the last non-zero force sample
    sharp = bool(eom.effects) or any(tm.exponents[4] % 2 or tm.exponents[5] % 2
                                     for tm in eom.damping_terms() + eom.stiffness_terms())
    if sharp or q < 4 or n - last < 4 * q:
        return _at(simulate(eom, t, force=force, x0=x0, v0=v0, x_scale=x_scale, v_scale=v_scale), at)
    if last > 0:
        head = simulate(eom, t[: last + 1], force=f[: last + 1], x0=x0, v0=v0, x_scale=x_scale, v_scale=v_scale)
        xs0, vs0, sub = float(head.x[-1]), float(head.v[-1]), head.substeps
        if head.diverged:
            return _at(simulate(eom, t, force=force, x0=x0, v0=v0, x_scale=x_scale, v_scale=v_scale), at)
    else:
        head, xs0, vs0, sub = None, float(x0), float(v0), 0
    m = n if at is None else at.size
    x = np.empty(m)
    v = np.empty(m)
    a = np.empty(m)
    if at is None:
        if head is not None:
            x[:last], v[:last], a[:last] = head.x[:last], head.v[:last], head.a[:last]
    elif head is not None:
        h = int(np.searchsorted(at, last))
        x[:h], v[:h], a[:h] = head.x[at[:h]], head.v[at[:h]], head.a[at[:h]]
    diverged, steps0 = _dense_tail(eom, dt, last, q, omega, xs0, vs0, x, v, a, n, at)
    diverged = bool(diverged or not finite(x))
    return SimulationResult(t=t if at is None else t[at], x=x, v=v, a=a, y=None, diverged=diverged,
                            substeps=sub or steps0)


def _end_of_force(f: np.ndarray) -> int:
    """One past the last non-zero sample of ``f`` (0 when there is none): a blow's end in a
    validation's drive (zero after it; ``np.argmax`` stops at the first hit of the reversed mask,
    where ``np.flatnonzero`` listed every one: 0.25 ms on 460k samples)."""
    return last_nonzero(f) + 1  # chunks from the end (the blow is at the start: ~all of it read once)


def _at(sim: SimulationResult, at: np.ndarray | None) -> SimulationResult:
    """``sim`` at the samples ``at`` (all of it when None)."""
    if at is None:
        return sim
    return SimulationResult(t=sim.t[at], x=sim.x[at], v=sim.v[at], a=sim.a[at],
                            y=None if sim.y is None else sim.y[at], diverged=sim.diverged, substeps=sim.substeps)


def _hermite_at(seg: "SimulationResult | _Segment", w: np.ndarray, j: np.ndarray, x: np.ndarray, v: np.ndarray,
                a: np.ndarray) -> None:
    """``_hermite_fill`` at the segment's samples ``j`` alone (numpy, the same weights ``w``)."""
    q = w.shape[1]
    k = j // q
    i = j - k * q
    on = i == 0
    k1 = np.where(on, k, k + 1)  # a sample on the grid reads no point after it
    c00, c10, c01, c11, sa, sb = w[:, i]
    xc, vc, ac = seg.x, seg.v, seg.a
    x[:] = c00 * xc[k] + c10 * vc[k] + c01 * xc[k1] + c11 * vc[k1]
    v[:] = c00 * vc[k] + c10 * ac[k] + c01 * vc[k1] + c11 * ac[k1]
    a[:] = sa * ac[k] + sb * ac[k1]
    x[on], v[on], a[on] = xc[k[on]], vc[k[on]], ac[k[on]]


def _dense_tail(eom: EquationOfMotion, dt: float, start: int, q: int, omega: float, x0: float, v0: float,
                x: np.ndarray, v: np.ndarray, a: np.ndarray, n: int,
                at: np.ndarray | None = None) -> tuple[bool, int]:
    """The force-free part of :func:`simulate_dense`: ``x, v, a[start:]`` filled from ``(x0, v0)``.

    In up to :data:`DENSE_SEGMENTS` segments: the first with the grid (``q``) and RK4 steps of
    ``omega`` (the caller's scales), each later one with those of the amplitude the previous
    segment reached (:func:`local_angular_frequency` at its largest ``|x|, |v|`` times
    :data:`DENSE_AMPLITUDE_MARGIN`, never above the caller's): a free response decays, and a
    hardening model's local frequency with it, so the steps keep ``omega h`` within the same
    bounds with fewer of them (the 45 s, 19.2 kHz ring-down: ~0.4 of the steps of one grid; a
    softening or linear model keeps its steps). A model whose response grows is stepped at the
    frequency of the amplitude before the growth, as the single grid was at the caller's scales.
    ``n``: the record's samples; ``at`` (increasing indices): ``x, v, a`` hold those samples alone.
    Returns (diverged, RK4 steps per grid interval of the first segment).
    """
    length = max(4 * q, -(-(n - start) // DENSE_SEGMENTS))
    s, xs, vs, first = start, x0, v0, 0
    run = _free_runner(eom)
    while s < n:
        stop = n if n - s < 2 * length else s + max(1, length // q) * q
        idx = np.arange(s, stop, q)
        if idx[-1] != stop - 1 or stop < n:
            idx = np.append(idx, idx[-1] + q)  # one point past the end: the interpolation covers it
        steps = max(1, math.ceil(q * dt * omega / DENSE_STEP_H_OMEGA))
        first = first or steps
        seg = run(idx.size, float((idx[1] - idx[0]) * dt), xs, vs, steps)
        if at is None:
            hi = stop
            _KERNELS._hermite_fill(seg.x, seg.v, seg.a, hermite_weights(q, q * dt), x[s:stop], v[s:stop], a[s:stop])
        else:
            lo, hi = np.searchsorted(at, (s, stop))
            _hermite_at(seg, hermite_weights(q, q * dt), at[lo:hi] - s, x[lo:hi], v[lo:hi], a[lo:hi])
        if seg.diverged or not (np.isfinite(seg.x[-1]) and np.isfinite(seg.v[-1])):
            x[hi:], v[hi:], a[hi:] = np.nan, np.nan, np.nan
            return True, first
        if stop < n:  # the next segment: from the exact RK4 state at its first sample
            xs, vs = float(seg.x[-1]), float(seg.v[-1])
            om = local_angular_frequency(eom, DENSE_AMPLITUDE_MARGIN * peak_abs(seg.x),
                                         DENSE_AMPLITUDE_MARGIN * peak_abs(seg.v))
            if om > 0 and math.isfinite(om):
                omega = min(omega, om)
                q = max(q, int(DENSE_H_OMEGA / (omega * dt)))
        s = stop
    return False, first


@dataclass(frozen=True)
class _Segment:
    """A force-free run of :func:`_free_runner`: ``x, v, a`` on its grid (views of one array)."""

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    diverged: bool


def _free_runner(eom: EquationOfMotion):
    """``simulate(eom, arange(m) * h, x0=x0, v0=v0, substeps=steps)`` of a model without effects,
    as ``run(m, h, x0, v0, steps) -> _Segment``: the term tables made once for all of
    :func:`_dense_tail`'s segments, no copies of the columns; the same numbers bit for bit
    (the same kernel and arguments; ``tests/eddi/test_free_runner.py``)."""
    exps = exponent_table(eom.damping_terms() + eom.stiffness_terms())
    coefs = np.array(list(eom.damping.values()) + list(eom.stiffness.values()), dtype=float)
    eff = _effect_vector(eom)
    inv_m = 1.0 / eom.mass
    no_force = np.zeros(0)

    def run(m: int, h: float, x0: float, v0: float, steps: int) -> _Segment:
        out = np.empty((m, 4))
        div = _KERNELS._rk4(no_force, h, int(steps), np.array([float(x0), float(v0), 0.0, 0.0]), inv_m, exps,
                            coefs, eff, out)
        return _Segment(out[:, 0], out[:, 1], out[:, 2], bool(div >= 0))

    return run


#: The compiled kernels (:mod:`eddi.kernels`: built ahead of time, else numba's JIT).
_KERNELS = Kernels(globals(), {
    "_rk4": ["i8(f8[::1], f8, i8, f8[::1], f8, i8[:, ::1], f8[::1], f8[::1], f8[:, ::1])"],
    "_internal_many": ["void(f8[::1], f8[::1], i8[:, ::1], f8[::1], f8[::1], f8[::1])"],
    "_hermite_fill": ["void(f8[:], f8[:], f8[:], f8[:, :], f8[:], f8[:], f8[:])"],
}, callees=("_internal",))
