"""Output-error refinement of an identified :class:`~eddi.mdof.model.MdofModel`.

EDDI's energy and force balances give every coefficient to about 1 %; predicting a long
ring-down to a few per cent needs the frequencies to 1e-4 (a 0.1 % error drifts by 0.4 rad
over 70 cycles). As the single-DOF ``eddi.refine``, the coefficients are then polished by
nonlinear least squares (``scipy.optimize.least_squares``) on the simulated displacement of
every channel of the training records, starting from EDDI's values, each coefficient scaled
by its start value (so a term EDDI pruned stays out). Masses and inputs are kept.
The Jacobian comes from forward sensitivities integrated alongside the simulation
(:mod:`eddi.mdof.sensitivity`; one run per Jacobian instead of one simulation per parameter:
the three-mass chain's diagnose 76 -> 44 s CPU, same verdict and fold errors); ``jac="2-point"``
keeps scipy's finite differences.

:func:`refine_lumped` does the same for a lumped-element fit (:mod:`eddi.mdof.lumped`) in its
own parameters: one scale per element constant (a spring's monomials in both equations move
together, Newton's third law kept) and one per mass. Its few parameters (5 on the energy sink
against 13 monomials) make it cheaper, and the masses matter: on the rig's energy sink a 1 %
error of the sink's mass, cubic constant or the primary's damping alone moves the held-out
nrmse of the sink's channel from 0.005 to 0.11-0.15 (measured), so EDDI's 0.1-1.5 % leave
visible phase errors there.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from scipy import optimize, signal

from eddi.threads import one_blas_thread
from eddi.mdof.identify import ChannelRecord
from eddi.mdof.model import MdofModel
from eddi.mdof.steering import Steering, noise_cost
from eddi.mdof.terms import parse_multi_term
from eddi.mdof.validate import impulse_floor, noise_floor, predict_channels


def _with(model: MdofModel, scales: np.ndarray) -> MdofModel:
    k = 0
    damping, stiffness = [], []
    for i in range(model.n_coords):
        d = {}
        for t, c in model.damping[i].items():
            d[t] = c * (1.0 + scales[k])
            k += 1
        s = {}
        for t, c in model.stiffness[i].items():
            s[t] = c * (1.0 + scales[k])
            k += 1
        damping.append(d)
        stiffness.append(s)
    return model.model_copy(update={"damping": tuple(damping), "stiffness": tuple(stiffness)})


def _weights(records: Sequence[ChannelRecord], horizon: float) -> list[tuple[ChannelRecord, int, np.ndarray]]:
    """Per record: the samples of the free window the error keeps and each channel's divisor
    (:func:`_residual_function`), shape (n_channels, 1)."""
    out = []
    for r in records:
        y = r.x[:, r.window[0]:r.window[1]]
        norm = np.linalg.norm(y, axis=1, keepdims=True) * np.maximum(noise_floor(r), FLOOR_MIN)[:, None]
        keep = max(8, int(horizon * y.shape[1]))
        out.append((r, keep, np.where(norm > 0, norm, 1.0) * np.sqrt(keep / y.shape[1])))
    return out


def _residual_function(records: Sequence[ChannelRecord], build, horizon: float = 1.0, memo: dict | None = None,
                       impulses: ImpulseScales | None = None):
    """``p -> stacked displacement errors`` (every second sample) of ``build(p)``, each channel
    of each record divided by its norm times its noise floor (:func:`eddi.mdof.validate.noise_floor`,
    at least :data:`FLOOR_MIN`): the errors in units of what the noise allows. Without it a
    small blow whose lowest peak set a 2 Hz drift cut-off (floor 0.05, ten times the others')
    dominated the fit: on an energy sink of our own the polish stopped at 0.015 / 0.053
    held out, against 0.007 / 0.009 without that record (the floor 0.007 / 0.008).

    ``memo`` (a dict shared by the residual functions of one polish): the simulations per
    parameter vector, so that a horizon's least squares starts (value, and with
    ``jac="2-point"`` the finite-difference Jacobian) from the last one's simulations instead of
    running them again. Every horizon simulates the whole record (the zero-phase filter needs
    it) and truncates the error, so the memo gives the same numbers.

    ``impulses`` (:class:`ImpulseScales`): ``p``'s last entries scale each record's measured
    force (``build`` sees the rest), and their prior's residuals end the vector.
    """
    prepared = [(r, r.x[:, r.window[0]:r.window[1]][:, :keep], norm) for r, keep, norm in _weights(records, horizon)]
    n_model = None if impulses is None else -impulses.size

    def simulate(p: np.ndarray) -> list[tuple[np.ndarray, bool]]:
        key = np.asarray(p, float).tobytes()
        if memo is not None and key in memo:
            memo[key] = memo.pop(key)  # most recently used last
            return memo[key]
        m = build(p[:n_model] if impulses is not None else p)
        plain = [r for r, _y, _n in prepared]
        scaled = plain if impulses is None else impulses.records(p, plain)
        sims = [predict_channels(m, r)[::3] for r in scaled]
        if memo is not None:
            memo[key] = sims
            while len(memo) > MEMO_SIZE:
                memo.pop(next(iter(memo)))
        return sims

    def residual(p: np.ndarray) -> np.ndarray:
        out = []
        for (y_sim, div), (_r, y, norm) in zip(simulate(p), prepared):
            e = (y_sim[:, :y.shape[1]] - y) / norm if not div else np.full_like(y, 10.0)
            out.append(e.ravel()[::2])
        if impulses is not None:
            out.append(impulses.prior(p))
        return np.concatenate(out)

    return residual, [y.size // 2 + y.size % 2 for _r, y, _n in prepared]


def _jacobian_function(records: Sequence[ChannelRecord], build, horizon: float = 1.0, coarsen: int | None = None,
                       impulses: ImpulseScales | None = None):
    """``p -> d residual / d p`` of :func:`_residual_function` (same records, build and horizon)
    from forward sensitivities (:mod:`eddi.mdof.sensitivity`): one simulation with its
    variational equations (along the ``p`` directions) per Jacobian instead of one simulation per parameter.
    ``coarsen``: the sensitivities' sub-steps that many times fewer than the simulation's
    (default :data:`JACOBIAN_COARSEN`; 1: the exact derivative of the residual).

    The sensitivities are in the ODE's own parameters ``theta`` (coefficients, inverse masses);
    ``d theta / d p`` comes from central differences of ``build`` alone (no simulation: the
    coefficients are linear in ``p``, the inverse masses smooth, so the step 1e-6 is exact to
    about 1e-12). A diverged simulation (whose residual is a constant) has a zero Jacobian.
    ``impulses``: a record's force scale is one more direction of its own run
    (:meth:`ImpulseScales.direction`), its prior's rows end the matrix.
    """
    from eddi.mdof.sensitivity import predict_sensitivities, theta

    prepared = _weights(records, horizon)
    coarsen = JACOBIAN_COARSEN if coarsen is None else coarsen

    def jac(p: np.ndarray) -> np.ndarray:
        p = np.asarray(p, float)
        n_imp = 0 if impulses is None else impulses.size
        q = p[:p.size - n_imp]
        step = 1e-6
        cols = []
        for k in range(q.size):
            e = np.zeros(q.size)
            e[k] = step
            cols.append((theta(build(q + e)) - theta(build(q - e))) / (2 * step))
        model = build(q)
        dtheta = np.column_stack(cols) if cols else np.zeros((theta(model).size, 0))  # (n_theta, n_par)
        plain = [r for r, _k, _n in prepared]
        scaled = plain if impulses is None else impulses.records(p, plain)
        blocks = []
        for j, ((_r, keep, norm), r) in enumerate(zip(prepared, scaled)):
            own = None if impulses is None else impulses.direction(model, p, j)
            dirs = dtheta if own is None else np.column_stack([dtheta, own])
            _y, dy, div = predict_sensitivities(model, r, dirs, coarsen=coarsen)
            if div:
                blocks.append(np.zeros(((r.x.shape[0] * keep + 1) // 2, p.size)))
                continue
            block = (dy[:, :, :keep] / norm[None]).reshape(dirs.shape[1], -1)[:, ::2].T
            if impulses is not None:
                extra = np.zeros((block.shape[0], n_imp))
                if own is not None:  # d force factor_j / d p_imp, times the response to the factor
                    extra = np.outer(block[:, -1], impulses.factor_gradient(j))
                    block = block[:, :-1]
                block = np.hstack([block, extra])
            blocks.append(block)
        if impulses is not None:
            prior = np.zeros((impulses.n_prior, p.size))
            prior[:, p.size - n_imp:] = impulses.prior_jacobian()
            blocks.append(prior)
        return np.vstack(blocks)

    return jac


class ImpulseScales:
    """One force scale per training capture, fitted with the polish's parameters (``p``'s last entries).

    The simulation is driven by the force measured during the blow, whose noise leaves each
    capture's impulse uncertain by ``u`` (:func:`eddi.mdof.validate.impulse_floor`): one draw per
    capture, a scale of its whole response. A light blow on an energy sink moves the sink's
    response 25-100 times ``u`` (the onset of energy pumping; session 16: the TRUE model met its
    own nes-5-1 captures at 0.07-0.21 nrmse with the measured force, 0.0002-0.0004 with the ideal
    one), and without a parameter for it the polish bends the masses and the cubic to mimic it.
    Here capture ``k``'s force is multiplied by ``1 + s_k - mean(s)``: the mean is held at 1 (a
    common scale of every force trades exactly with the masses of a linear system), each
    ``s_k - mean(s)`` carries a Gaussian prior of width ``u_k`` (residual rows ``(s_k - mean) / u_k``
    and one pinning ``mean(s)``, a direction nothing else sees) and ``s_k`` is bounded to
    :data:`IMPULSE_BOUND` ``u_k``. Captures without a force noise (or a force) get no scale.
    The held-out validation drives its simulations with the measured force as it is.
    """

    def __init__(self, records: Sequence[ChannelRecord]):
        u = np.array([impulse_floor(r) for r in records])
        self.index = [k for k in range(len(records)) if u[k] > 0]
        self.u = u[self.index]
        self.size = len(self.index)
        self.n_prior = self.size + 1
        self._where = {k: j for j, k in enumerate(self.index)}

    @classmethod
    def of(cls, records: Sequence[ChannelRecord], enabled: bool | None = None) -> ImpulseScales | None:
        """The scales of ``records``, or None (switched off, :data:`IMPULSE_SCALES`, or under two scaled captures)."""
        out = cls(records)
        return out if (IMPULSE_SCALES if enabled is None else enabled) and out.size >= 2 else None

    def factors(self, p: np.ndarray) -> np.ndarray:
        s = np.asarray(p, float)[p.size - self.size:]
        return 1.0 + s - np.mean(s)

    def records(self, p: np.ndarray, records: Sequence[ChannelRecord]) -> list[ChannelRecord]:
        f = self.factors(p)
        return [replace(r, force=r.force * f[self._where[k]]) if k in self._where else r
                for k, r in enumerate(records)]

    def prior(self, p: np.ndarray) -> np.ndarray:
        s = np.asarray(p, float)[p.size - self.size:]
        return np.concatenate([(s - np.mean(s)) / self.u, [np.sqrt(self.size) * np.mean(s) / np.min(self.u)]])

    def prior_jacobian(self) -> np.ndarray:
        n = self.size
        centre = (np.eye(n) - 1.0 / n) / self.u[:, None]
        return np.vstack([centre, np.full((1, n), np.sqrt(n) / n / np.min(self.u))])

    def factor_gradient(self, k: int) -> np.ndarray:
        """``d factor_k / d s`` (record ``k`` in the polish's order)."""
        g = np.full(self.size, -1.0 / self.size)
        g[self._where[k]] += 1.0
        return g

    def direction(self, model: MdofModel, p: np.ndarray, k: int) -> np.ndarray | None:
        """``d theta`` equivalent to ``d factor_k`` (None: record ``k`` has no scale). The force
        scaled by ``f (1 + e)`` moves the acceleration ``inv_m (u f F - sum c T)`` as the inverse
        masses scaled by ``1 + e`` and the coefficients by ``1 / (1 + e)`` do: ``(-c, inv_m) / f``."""
        from eddi.mdof.sensitivity import theta

        if k not in self._where:
            return None
        th = theta(model)
        n_c = th.size - model.n_coords
        return np.concatenate([-th[:n_c], th[n_c:]]) / self.factors(p)[self._where[k]]

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return -IMPULSE_BOUND * self.u, IMPULSE_BOUND * self.u


@one_blas_thread()
def refine_lumped(fit, channels: tuple[str, ...], driving_point: str, records: Sequence[ChannelRecord], *,
                  max_nfev: int = 40, jac: str = "sensitivity", noise_stop: bool | None = None,
                  impulse_scales: bool | None = None):
    """Polish a :class:`~eddi.mdof.lumped.LumpedFit`'s masses and element constants (module docstring),
    with one force scale per training capture (:class:`ImpulseScales`; ``impulse_scales``: None
    :data:`IMPULSE_SCALES`).

    Returns
    -------
    fit : LumpedFit
        Refined (``ci95`` from the Gauss-Newton covariance, as :func:`refine_mdof`).
    model : MdofModel
    cost_before, cost_after : float
    """
    from eddi.mdof.lumped import LumpedFit
    from eddi.mdof.physical import lumped_model

    d = channels.index(driving_point)
    elements = list(fit.constants)
    n_m = len(fit.masses)

    def make(p: np.ndarray) -> LumpedFit:
        return LumpedFit(fit.masses * (1.0 + p[:n_m]),
                         {e: fit.constants[e] * (1.0 + p[n_m + k]) for k, e in enumerate(elements)},
                         fit.ci95, fit.residual)

    def build(p: np.ndarray) -> MdofModel:
        return lumped_model(make(p), channels, driving_point, d, len(records))

    n_par = n_m + len(elements)
    imp = ImpulseScales.of(records, impulse_scales)
    n_all = n_par + (0 if imp is None else imp.size)
    lo, hi = -0.9 * np.ones(n_all), 2.0 * np.ones(n_all)
    x_scale = np.full(n_all, 0.01)
    if imp is not None:
        lo[n_par:], hi[n_par:] = imp.bounds()
        x_scale[n_par:] = imp.u
    p, nfev = np.zeros(n_all), max(4, max_nfev // len(HORIZONS))
    memo: dict = {}
    r0 = _residual_function(records, build, memo=memo, impulses=imp)[0](p)
    fun, final_jac = r0, None
    for horizon in HORIZONS:  # continuation in the simulated span (docstring)
        residual, sizes = _residual_function(records, build, horizon, memo, imp)
        stop = Steering(residual, _jac(jac, records, build, horizon, imp),
                        noise_cost(_weights(records, horizon), FLOOR_MIN, 0 if imp is None else imp.size)
                        if _stops(noise_stop) else -1.0)
        final_jac = None
        if imp is not None and not stop.within(p):  # the blows' impulses first, the model kept
            p = _fit_scales(residual, stop.scipy_jac, p, imp, nfev)
        if stop.within(p):  # already within the noise on this span: no step
            fun = residual(p)
            continue
        sol = optimize.least_squares(residual, p, jac=stop.scipy_jac, x_scale=x_scale, diff_step=1e-5, max_nfev=nfev,
                                     bounds=(lo, hi), callback=stop.callback)
        p, fun, final_jac = sol.x, sol.fun, (sol.jac if stop.exact else None)
        settled = stop.settle(p)  # a step that crossed the noise: back to where it met it
        if settled is not p:
            p, fun = settled, residual(settled)
    n_ch = len(channels)
    before = float(np.sum(r0**2) * 2 / len(records) / n_ch)
    after = float(np.sum(fun**2) * 2 / len(records) / n_ch)
    if after >= before:
        return fit, build(np.zeros(n_par)), before, before
    if final_jac is None:  # the whole window's Jacobian at the result (the stop left none there)
        final_jac = _jacobian_at(jac, records, build, p, fun, imp)
    n_data = sum(sizes)  # the intervals given the forces (the scales' columns and prior rows left out)
    half = _ci95_scales(np.asarray(final_jac)[:n_data, :n_par], fun[:n_data], sizes)  # the whole window
    out = make(p[:n_par])
    out = LumpedFit(out.masses, out.constants,
                    {e: float(abs(c) * h) for (e, c), h in zip(out.constants.items(), half[n_m:n_par])}, out.residual)
    return out, lumped_model(out, channels, driving_point, d, len(records)), before, after


#: Spans (fractions of each free window) the lumped polish fits in turn, each from the last
#: one's result: the energy sink's response to a 1 % parameter change is a shift in when
#: energy pumping sets in, so over the whole window the least squares has local minima
#: (measured on an energy sink of our own: from EDDI's start the whole-window fit stopped at
#: 0.07 / 0.34 held out); over the first fifth the responses are still close.
HORIZONS = (0.2, 0.5, 1.0)
#: The polish's Jacobian integrates the sensitivities with this many times fewer RK4 sub-steps than
#: the simulation (``h * omega`` up to 0.1 instead of 0.05; :func:`_jacobian_function`). The
#: Jacobian only steers the least squares: every step is accepted or refused on the residual,
#: simulated at full accuracy, so the result is the same minimum. Session 15 (session 13's three-mass
#: chain, fold 0, 16 Jacobians of 10 directions on 2 records): 35.7 -> 22.4 s CPU, the same steps
#: (cost 37.623 -> 19.303, held-out 0.3612 both, per channel the same to 4 digits).
JACOBIAN_COARSEN = 2
#: The polishes stop within the records' noise (:mod:`eddi.mdof.steering`; their ``noise_stop``).
NOISE_STOP = True
#: :func:`refine_mdof` takes at most this many Broyden updates of its Jacobian between two computed
#: ones (:class:`eddi.mdof.steering.Steering`; its ``broyden``). 0: every Jacobian computed. Measured
#: (session 16, session 13's three-mass chain, fold 0, the same model polished in one process): with 2,
#: 9 computed Jacobians instead of 15 (18 sensitivity runs, 7.5 s, against 30, 12.5 s) but 46
#: simulations instead of 30 (12.7 s against 8.2 s: the secant Jacobians' steps are refused more
#: often), 20.3 against 20.9 s CPU in all, and a different end (training cost 19.60 against 19.30,
#: the middle mode 186.6 against 195.2 Hz, held out 0.3618 against 0.3612): no gain, not taken.
BROYDEN_RUN = 0
#: The polishes fit one force scale per training capture (:class:`ImpulseScales`). Off by default:
#: measured (session 17, ``bench_mdof_target.py --snr 45``) nes-5-1 held out 0.0244 / 0.0781 -> 0.0161 /
#: 0.0624 (coefficients 2.3 -> 0.0 %), nes-7-11 FAIL -> PASS (2.1 -> 0.0 %, sink 0.062 -> 0.037), but
#: nes-5-11 0.0512 / 0.1574 -> 0.0635 / 0.2175, nes-7-1's sink 0.055 -> 0.060, and the MDOF null
#: h1-ground (``bench_mdof_nulls.py --set heldout --seeds 1 --refine``) ``none`` -> ``unexplained``.
IMPULSE_SCALES = False
#: An impulse scale stays within this many of its capture's impulse uncertainties.
IMPULSE_BOUND = 4.0
#: Parameter vectors whose simulations a polish keeps (:func:`_residual_function`).
MEMO_SIZE = 64
#: Smallest noise floor a channel is weighted by (relative nrmse).
FLOOR_MIN = 1e-3
#: Which coefficients :func:`refine_mdof` polishes by default (its ``free``).
POLISH_FREE = "frequency"
#: :func:`refine_mdof` stops when a step lowers the training cost by less than this fraction
#: (``least_squares``' ``ftol``; its default 1e-8 ran every polish to ``max_nfev``). Measured on
#: session 13's three-mass chain (fold 0, frequency terms): the held-out nrmse 0.462 -> 0.364 within
#: 9 evaluations (16 s CPU), then 50 more evaluations (110 s) moved the training cost 2 % and the
#: held-out +0.0005; steps below 1e-3 begin at the 15th.
POLISH_FTOL = 1e-3


def frequency_terms(model: MdofModel) -> np.ndarray:
    """Indices (in :func:`_with`'s order: per equation its damping, then its stiffness) of the
    coefficients the energy balance leaves to the polish: the stiffness terms that set the
    frequencies - every linear one, and each equation's nonlinear terms in its own coordinate
    alone (the backbone: a conservative term in ``x_i`` does no work over a cycle of ``x_i``).

    The others - the damping (the energy dissipated per half cycle) and the nonlinear terms
    coupling two coordinates (the energy exchanged between them) - are what EDDI's balances
    measure; a 1 % error of those moves a prediction by about 1 % of the decay, where a 1 %
    error of a frequency drifts the phase by cycles over a long ring-down.
    """
    out, k = [], 0
    for i in range(model.n_coords):
        k += len(model.damping[i])
        for text in model.stiffness[i]:
            term = parse_multi_term(text, model.n_coords)
            if term.degree == 1 or term.coordinates == (i,):
                out.append(k)
            k += 1
    return np.array(out, dtype=int)


@one_blas_thread()
def refine_mdof(model: MdofModel, records: Sequence[ChannelRecord], *, max_nfev: int = 60,
                jac: str = "sensitivity", free: str | None = None, intervals: bool = True,
                noise_stop: bool | None = None, broyden: int | None = None, impulse_scales: bool | None = None
                ) -> tuple[MdofModel, float, float]:
    """Polish the coefficients on the records' simulated displacements, with one force scale per
    training capture (:class:`ImpulseScales`; ``impulse_scales``: None :data:`IMPULSE_SCALES`).

    ``free``: ``"frequency"`` polishes :func:`frequency_terms` only (the rest kept at EDDI's values);
    ``"all"`` every coefficient (the former polish); None: :data:`POLISH_FREE`. The intervals
    (``stiffness_ci95``) are the Gauss-Newton ones of every coefficient at the result either way
    (one Jacobian in all of them). ``intervals=False``: the polished coefficients with EDDI's
    intervals kept (no Jacobian in every coefficient when only freed ones were polished: a fold
    model whose intervals nobody reads, :func:`station.mdof_polish.polished_fold`).

    Returns
    -------
    model : MdofModel
    cost_before, cost_after : float
        Mean squared error over the records' channels, in units of each channel's noise floor.
    """
    n_all = sum(len(d) + len(s) for d, s in zip(model.damping, model.stiffness))
    free = POLISH_FREE if free is None else free
    if free == "all":
        idx = np.arange(n_all)
    elif free == "frequency":
        idx = frequency_terms(model)
    else:
        raise ValueError(f"free: expected 'frequency' or 'all', got {free!r}")

    def build(p: np.ndarray) -> MdofModel:
        full = np.zeros(n_all)
        full[idx] = p
        return _with(model, full)

    n_par = idx.size
    imp = ImpulseScales.of(records, impulse_scales) if n_par else None
    n_imp = 0 if imp is None else imp.size
    residual, sizes = _residual_function(records, build, memo={}, impulses=imp)
    p0 = np.zeros(n_par + n_imp)
    r0 = residual(p0)
    n_ch = len(model.channels)
    before = float(np.sum(r0**2) * 2 / len(records) / n_ch)
    if n_par == 0:
        return model, before, before
    stop = Steering(residual, _jac(jac, records, build, impulses=imp),
                    noise_cost(_weights(records, 1.0), FLOOR_MIN, n_imp) if _stops(noise_stop) else -1.0,
                    BROYDEN_RUN if broyden is None else broyden)
    if stop.within(p0):  # the start is within the noise: nothing the records can tell
        return model, before, before
    sol = _converged(residual, p0, stop, max_nfev, imp)
    x, fun = sol.x, sol.fun
    settled = stop.settle(x)  # a step that crossed the noise: back to where it met it
    if settled is not x:
        x, fun = settled, residual(settled)
    after = float(np.sum(fun**2) * 2 / len(records) / n_ch)
    if after >= before:
        return model, before, before
    full = np.zeros(n_all)
    full[idx] = x[:n_par]
    out = _with(model, full)
    if not intervals:
        return out, before, after
    if n_par == n_all:
        full_jac = sol.jac if stop.exact and settled is sol.x else _jacobian_at(jac, records, build, x, fun, imp)
        n_data = sum(sizes)  # the intervals given the forces (as :func:`refine_lumped`)
        half = _ci95_scales(np.asarray(full_jac)[:n_data, :n_par], fun[:n_data], sizes)
    else:  # the intervals of every coefficient, as the polish of all gives them
        every = _jac(jac, records, lambda p: _with(model, p))
        data = fun[:sum(sizes)]
        if not callable(every):
            every = _forward_differences(_residual_function(records, lambda p: _with(model, p))[0], data)
        half = _ci95_scales(every(full), data, sizes)
    k, ci = 0, []
    for i in range(model.n_coords):
        k += len(model.damping[i])
        ci.append({t: float(abs(c) * h) for (t, c), h in zip(out.stiffness[i].items(), half[k:])})
        k += len(model.stiffness[i])
    return out.model_copy(update={"stiffness_ci95": tuple(ci)}), before, after


def _jac(kind: str, records: Sequence[ChannelRecord], build, horizon: float = 1.0,
         impulses: ImpulseScales | None = None):
    """``least_squares``'s ``jac``: forward sensitivities (``"sensitivity"``, the default) or
    scipy's finite differences (``"2-point"``, the former default, one simulation per parameter)."""
    if kind == "sensitivity":
        return _jacobian_function(records, build, horizon, impulses=impulses)
    if kind == "2-point":
        return "2-point"
    raise ValueError(f"jac: expected 'sensitivity' or '2-point', got {kind!r}")


def _fit_scales(residual, jac, p: np.ndarray, impulses: ImpulseScales, max_nfev: int) -> np.ndarray:
    """``p`` with its force scales (:class:`ImpulseScales`, the last entries) fitted and the model's
    parameters kept: the nuisance the records determine best (a light blow's sink response moves
    25-100 times its impulse error) taken out before the model is asked to explain the rest. A
    joint fit from EDDI's start moved the masses with the scales: nes-5-1 of ``bench_mdof_target.py``,
    coefficients 0.1 % at the start, 0.23 % after the joint polish, held out 0.0064 / 0.029 ->
    0.013 / 0.047 (measured, session 17)."""
    n = impulses.size
    head = p[:p.size - n]

    def sub(z: np.ndarray) -> np.ndarray:
        return residual(np.concatenate([head, z]))

    sub_jac = (lambda z: np.asarray(jac(np.concatenate([head, z])), float)[:, -n:]) if callable(jac) else jac
    lo, hi = impulses.bounds()
    sol = optimize.least_squares(sub, np.clip(p[-n:], lo, hi), jac=sub_jac, x_scale=impulses.u, diff_step=1e-5,
                                 max_nfev=max_nfev, ftol=POLISH_FTOL, bounds=(lo, hi))
    return np.concatenate([head, sol.x])


def _stops(noise_stop: bool | None) -> bool:
    return NOISE_STOP if noise_stop is None else bool(noise_stop)


def _converged(residual, p0: np.ndarray, stop: Steering, max_nfev: int, impulses: ImpulseScales | None = None):
    """``least_squares`` (trust region, ``ftol`` :data:`POLISH_FTOL`) steered by ``stop``; convergence
    is declared on a computed Jacobian only: a run that ended on its tolerances with a Broyden one
    starts again from its result with a computed one (within the evaluations left). Measured on
    session 13's three-mass chain (fold 0): a Broyden step that gained little ended the polish at a
    training cost 22.3 where the computed Jacobians went on to 19.3."""
    lo, hi, x_scale = -0.9 * np.ones(p0.size), 2.0 * np.ones(p0.size), np.full(p0.size, 0.01)
    if impulses is not None:  # the force scales end the vector
        n = impulses.size
        lo[-n:], hi[-n:] = impulses.bounds()
        x_scale[-n:] = impulses.u
    bounds = (lo, hi)
    left, p = max_nfev, p0
    while True:
        sol = optimize.least_squares(residual, p, jac=stop.scipy_jac, x_scale=x_scale, diff_step=1e-5, max_nfev=left,
                                     ftol=POLISH_FTOL, bounds=bounds, callback=stop.callback)
        left -= sol.nfev
        if stop.exact or sol.status not in (1, 2, 3, 4) or left <= 0 or np.array_equal(sol.x, p):
            return sol
        stop.recompute()
        p = sol.x


def _jacobian_at(kind: str, records: Sequence[ChannelRecord], build, p: np.ndarray, fun: np.ndarray,
                 impulses: ImpulseScales | None = None) -> np.ndarray:
    """The whole window's Jacobian at ``p`` (``fun`` its residual), for the intervals where the
    noise stop or a Broyden update (:class:`~eddi.mdof.steering.Steering`) left the previous point's."""
    jac = _jac(kind, records, build, impulses=impulses)
    if not callable(jac):
        jac = _forward_differences(_residual_function(records, build, impulses=impulses)[0], fun)
    return jac(p)


def _forward_differences(residual, at_value: np.ndarray, step: float = 1e-5):
    """``p -> d residual / d p`` by forward differences, ``at_value`` the residual at that ``p``."""
    def jac(p: np.ndarray) -> np.ndarray:
        cols = []
        for k in range(p.size):
            e = np.zeros(p.size)
            e[k] = step
            cols.append((residual(p + e) - at_value) / step)
        return np.column_stack(cols)

    return jac


def _ci95_scales(jac: np.ndarray, fun: np.ndarray, sizes: list[int]) -> np.ndarray:
    """95 % half-widths of the relative scales ``p`` (coefficient = start value times ``1 + p``).

    Gauss-Newton covariance ``tau s^2 (J^T J)^-1`` at the solution: ``s^2`` the residual
    variance, ``tau`` the integrated autocorrelation time of the residual (summed until the
    autocorrelation first drops below zero, averaged over the records): the residual of a
    ring-down is correlated over many samples (slow noise of the double integration, a phase
    drift), which inflates the spread of the fit by about ``tau`` over independent samples.
    """
    jac = np.asarray(jac.toarray() if hasattr(jac, "toarray") else jac, float)
    taus, start = [], 0
    for size in sizes:
        r = fun[start:start + size]
        start += size
        r = r - r.mean()
        # by FFT: np.correlate is O(n^2) (45 s CPU for one 8 s record's 1e5 residuals at 10 kHz;
        # the FFT 0.03 s, equal to 3e-16 relative)
        ac = signal.correlate(r, r, "full", method="fft")[r.size - 1:] / max(float(r @ r), 1e-300)
        neg = np.nonzero(ac < 0)[0]
        taus.append(1.0 + 2.0 * float(np.sum(ac[1:neg[0] if neg.size else ac.size])))
    tau = max(1.0, float(np.mean(taus)))
    s2 = float(fun @ fun) / max(fun.size - jac.shape[1], 1)
    try:
        cov = np.linalg.pinv(jac.T @ jac) * s2 * tau
    except np.linalg.LinAlgError:
        return np.full(jac.shape[1], np.inf)
    return 1.96 * np.sqrt(np.maximum(np.diag(cov), 0.0))


@one_blas_thread()
def refine_identified(ident, records: Sequence[ChannelRecord], *, jac: str = "sensitivity", intervals: bool = True
                      ) -> tuple[MdofModel, float, float]:
    """:func:`refine_lumped` when ``ident`` (an :class:`~eddi.mdof.identify.MdofIdentification`)
    is the lumped-element candidate, else :func:`refine_mdof` (``intervals``: its); returns the
    model and the costs."""
    if ident.lumped is not None:
        m = ident.model
        _fit, model, before, after = refine_lumped(ident.lumped, tuple(m.channels), m.driving_point, records,
                                                   jac=jac)
        return model, before, after
    return refine_mdof(ident.model, records, jac=jac, intervals=intervals)
