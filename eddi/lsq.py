"""Levenberg-Marquardt least squares in numpy: MINPACK's ``lmder`` without scipy.

:func:`least_squares` minimises ``0.5 ||f(p)||^2`` for the output-error refinement
(:meth:`eddi.output_error.OutputErrorProblem.fit`) the way
``scipy.optimize.least_squares(method="lm")`` does: Moré's trust-region Levenberg-Marquardt
(MINPACK ``lmder``: the step bound ``delta`` from ``factor * ||D p0||``, the ratio tests
0.25 / 0.75 / 1e-4, the ``ftol`` / ``xtol`` / ``gtol`` tests and ``max_nfev`` as MINPACK
counts them, the ``lmpar`` root search of the damping parameter to 10 % of ``delta``),
with the scaling ``D`` fixed (``x_scale`` a number or an array: ``D = 1 / x_scale``) or
from the Jacobian's column norms (``x_scale="jac"``).

Why a hand-written solver: ``station identify`` runs one refinement per record, and
importing ``scipy.optimize`` (its ``__init__`` loads every solver: sparse, special,
spatial, fft) cost ~0.11 s of the process's ~0.74 s CPU (docs/speed.md); the refinement is
its only use on that path. MINPACK factors the Jacobian with a column-pivoted QR that numpy
does not offer; here an unpivoted ``numpy.linalg.qr`` and the small ``n x n`` systems of
``lmpar`` solved directly, so the iterates agree with MINPACK's to rounding, not bit for bit,
and the optimum to far less than its confidence interval (docs/speed.md: the 60-record
comparison). ``EDDI_LSQ=scipy`` in the environment (read at each call) uses scipy's
``least_squares(method="lm")`` instead, for comparison.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Callable

import numpy as np

#: MINPACK's ``factor``: the first step bound is ``FACTOR * ||D p0||`` (scipy passes 100).
FACTOR = 100.0
_EPS = float(np.finfo(float).eps)
_DWARF = float(np.finfo(float).tiny)


@dataclass(frozen=True)
class LsqResult:
    """A fit: the parameters, the residual and the Jacobian there, and how it ended.

    ``status`` as scipy's ``least_squares`` reports it: 0 the evaluation limit, 1 ``gtol``,
    2 ``ftol``, 3 ``xtol``, 4 both of ``ftol`` and ``xtol``; ``success`` when > 0.
    """

    x: np.ndarray
    fun: np.ndarray
    jac: np.ndarray
    cost: float
    nfev: int
    njev: int
    status: int

    @property
    def success(self) -> bool:
        return self.status > 0


def forward_difference(fun: Callable[[np.ndarray], np.ndarray], x: np.ndarray, f0: np.ndarray) -> np.ndarray:
    """scipy's ``"2-point"`` Jacobian: steps ``sqrt(eps) max(1, |x|)`` signed as ``x`` (``+`` at 0)."""
    h = math.sqrt(_EPS) * np.where(x >= 0, 1.0, -1.0) * np.maximum(1.0, np.abs(x))
    cols = []
    for i in range(x.size):
        xi = x.copy()
        xi[i] = x[i] + h[i]
        cols.append((np.atleast_1d(fun(xi)) - f0) / (xi[i] - x[i]))
    return np.column_stack(cols) if cols else np.zeros((f0.size, 0))


def least_squares(fun: Callable[[np.ndarray], np.ndarray], x0: np.ndarray,
                  jac: Callable[[np.ndarray], np.ndarray] | str = "2-point", *, x_scale: float | np.ndarray | str = 1.0,
                  max_nfev: int | None = None, ftol: float = 1e-8, xtol: float = 1e-8, gtol: float = 1e-8):
    """Levenberg-Marquardt from ``x0`` (``scipy.optimize.least_squares(..., method="lm")``'s arguments).

    ``jac`` is a function of ``x`` (the Jacobian of ``fun``) or ``"2-point"`` (forward
    differences); ``max_nfev`` limits the evaluations of ``fun`` (not the Jacobian's;
    default ``100 n``). Returns an :class:`LsqResult` (scipy's ``OptimizeResult`` under
    ``EDDI_LSQ=scipy``: the same attributes ``x``, ``fun``, ``jac``, ``cost``, ``nfev``, ``status``).
    """
    if os.environ.get("EDDI_LSQ", "").strip().lower() == "scipy":
        from scipy.optimize import least_squares as scipy_least_squares

        return scipy_least_squares(fun, x0, jac=jac, method="lm", x_scale=x_scale, max_nfev=max_nfev,
                                   ftol=ftol, xtol=xtol, gtol=gtol)
    x = np.array(x0, dtype=float, copy=True).ravel()
    jfun = jac if callable(jac) else None
    if jfun is None and jac != "2-point":
        raise ValueError(f"jac must be a function or '2-point'; got {jac!r}")

    def jacobian(p: np.ndarray, f: np.ndarray) -> np.ndarray:
        return np.atleast_2d(np.asarray(jfun(p), dtype=float)) if jfun else forward_difference(fun, p, f)

    x, f, nfev, njev, status = _lmder(fun, jacobian, x, x_scale, 100 * x.size if max_nfev is None else max_nfev,
                                      ftol, xtol, gtol)
    j = jacobian(x, f)
    return LsqResult(x=x, fun=f, jac=j, cost=0.5 * float(f @ f), nfev=nfev, njev=njev + 1, status=status)


def _lmder(fun, jacobian, x: np.ndarray, x_scale, maxfev: int, ftol: float, xtol: float,
           gtol: float) -> tuple[np.ndarray, np.ndarray, int, int, int]:
    """MINPACK ``lmder``'s loops: (x, f(x), evaluations, Jacobians, scipy's status)."""
    n = x.size
    scaled = isinstance(x_scale, str)
    diag = None if scaled else np.broadcast_to(1.0 / np.asarray(x_scale, dtype=float), (n,)).copy()
    f = np.atleast_1d(np.asarray(fun(x), dtype=float))
    if f.size < n:
        raise ValueError(f"Levenberg-Marquardt needs at least as many residuals as variables ({f.size} < {n})")
    nfev, njev = 1, 0
    fnorm = float(np.linalg.norm(f))
    par, delta, xnorm, first = 0.0, 0.0, 0.0, True
    while True:
        jac = jacobian(x, f)
        njev += 1
        acnorm = np.linalg.norm(jac, axis=0)
        # R and Q'f from one factorisation of [J f] without forming Q (13k x 11 on the 45 s
        # record: ~0.5 ms against ~3 ms for the reduced Q and q.T @ f; equal to rounding)
        raug = np.linalg.qr(np.column_stack((jac, f)), mode="r")
        r, qtf = raug[:n, :n], raug[:n, n].copy()
        if first:
            if scaled:
                diag = np.where(acnorm == 0, 1.0, acnorm)
            xnorm = float(np.linalg.norm(diag * x))
            delta = FACTOR * xnorm if xnorm != 0 else FACTOR
        gnorm = 0.0
        if fnorm != 0:
            rq = r.T @ (qtf / fnorm)
            ok = acnorm != 0
            gnorm = float(np.max(np.abs(rq[ok] / acnorm[ok]))) if ok.any() else 0.0
        if gnorm <= gtol:
            return x, f, nfev, njev, 1
        if scaled:
            diag = np.maximum(diag, acnorm)
        while True:  # the inner loop: a step within delta, until one lowers the sum of squares
            par, step = _lmpar(r, diag, qtf, delta, par)
            step = -step
            trial = x + step
            pnorm = float(np.linalg.norm(diag * step))
            if first:
                delta = min(delta, pnorm)
            f1 = np.atleast_1d(np.asarray(fun(trial), dtype=float))
            nfev += 1
            fnorm1 = float(np.linalg.norm(f1))
            actred = 1.0 - (fnorm1 / fnorm) ** 2 if 0.1 * fnorm1 < fnorm else -1.0
            t1 = float(np.linalg.norm(r @ step)) / fnorm
            t2 = math.sqrt(par) * pnorm / fnorm
            prered = t1 * t1 + t2 * t2 / 0.5
            dirder = -(t1 * t1 + t2 * t2)
            ratio = actred / prered if prered != 0 else 0.0
            if ratio <= 0.25:
                temp = 0.5 if actred >= 0 else 0.5 * dirder / (dirder + 0.5 * actred)
                if 0.1 * fnorm1 >= fnorm or temp < 0.1:
                    temp = 0.1
                delta = temp * min(delta, pnorm / 0.1)
                par = par / temp
            elif par == 0 or ratio >= 0.75:
                delta = pnorm / 0.5
                par = 0.5 * par
            if ratio >= 1e-4:  # a success: the new point
                x, f, fnorm, first = trial, f1, fnorm1, False
                xnorm = float(np.linalg.norm(diag * x))
            f_ok = abs(actred) <= ftol and prered <= ftol and 0.5 * ratio <= 1
            x_ok = delta <= xtol * xnorm
            if f_ok or x_ok:
                return x, f, nfev, njev, 4 if f_ok and x_ok else (2 if f_ok else 3)
            if nfev >= maxfev:
                return x, f, nfev, njev, 0
            # MINPACK's 6-8: the tolerances are too small to meet (scipy: as ftol, xtol, gtol)
            if abs(actred) <= _EPS and prered <= _EPS and 0.5 * ratio <= 1:
                return x, f, nfev, njev, 2
            if delta <= _EPS * xnorm:
                return x, f, nfev, njev, 3
            if gnorm <= _EPS:
                return x, f, nfev, njev, 1
            if ratio >= 1e-4:
                break


def _lmpar(r: np.ndarray, diag: np.ndarray, qtb: np.ndarray, delta: float,
           par: float) -> tuple[float, np.ndarray]:
    """MINPACK ``lmpar``: the damping ``par`` with ``||D x|| ~ delta`` (to 10 %) and its step ``x``.

    ``x`` solves ``(J'J + par D^2) x = J'f`` (``J = QR``, ``qtb = Q'f``); ``par = 0`` and the
    Gauss-Newton step when that is within ``1.1 delta``.
    """
    n = r.shape[1]
    rd = np.abs(np.diag(r))
    full = bool(np.all(rd > 0))
    x = np.linalg.solve(r, qtb) if full else np.linalg.lstsq(r, qtb, rcond=None)[0]
    dx = diag * x
    dxnorm = float(np.linalg.norm(dx))
    fp = dxnorm - delta
    if fp <= 0.1 * delta:
        return 0.0, x
    parl = 0.0
    if full:
        w = np.linalg.solve(r.T, diag * (dx / dxnorm))
        wn = float(np.linalg.norm(w))
        parl = ((fp / delta) / wn) / wn
    g = (r.T @ qtb) / diag
    gnorm = float(np.linalg.norm(g))
    paru = gnorm / delta
    if paru == 0:
        paru = _DWARF / min(delta, 0.1)
    par = min(max(par, parl), paru)
    if par == 0:
        par = gnorm / dxnorm
    for it in range(10):
        if par == 0:
            par = max(_DWARF, 0.001 * paru)
        # the least-squares solution of [R; sqrt(par) D] x = [Q'f; 0] and that system's R (s)
        stacked, rhs = np.vstack((r, math.sqrt(par) * np.diag(diag))), np.concatenate((qtb, np.zeros(n)))
        qs, s = np.linalg.qr(stacked)
        x = (np.linalg.solve(s, qs.T @ rhs) if np.all(np.diag(s) != 0)
             else np.linalg.lstsq(stacked, rhs, rcond=None)[0])
        dx = diag * x
        dxnorm = float(np.linalg.norm(dx))
        temp, fp = fp, dxnorm - delta
        if abs(fp) <= 0.1 * delta or (parl == 0 and fp <= temp < 0) or it == 9:
            break
        w = np.linalg.solve(s.T, diag * (dx / dxnorm))
        wn = float(np.linalg.norm(w))
        parc = ((fp / delta) / wn) / wn
        if fp > 0:
            parl = max(parl, par)
        elif fp < 0:
            paru = min(paru, par)
        par = max(parl, par + parc)
    return par, x
