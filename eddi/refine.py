"""Optional output-error refinement of an identified equation of motion.

EDDI's two phases are *equation-error* estimates: each balances energies (or forces) sample
by sample or half cycle by half cycle, so measurement noise enters every row directly. An
*output-error* fit instead simulates the model and compares the simulated response with the
measured one over the whole record: a small error of a stiffness coefficient shifts the
phase a little more every cycle and a small damping error bends the whole decay envelope,
so a long ring-down constrains both far more tightly than any single cycle does.

:func:`refine_output_error` starts from the EDDI estimate (which is close enough for the
non-convex output-error problem to converge to the right minimum) and minimises, with
:func:`scipy.optimize.least_squares`,

    sum_k (y_sim(t_k; b, k, x0, v0) - y_meas(t_k))^2

over the damping and stiffness coefficients and the initial state ``(x0, v0)`` of the free
response, where ``y`` is the signal the sensor measured: the acceleration for an
accelerometer (white sensor noise: this is then the maximum-likelihood fit), the rate for a
vibrometer, the coordinate for a displacement sensor (default: ``a`` when given, else ``x``). The window grows in stages
(1/8, 1/2, all of the record) so that the phase error of the starting model never exceeds
a fraction of a cycle.

Cost. A densely sampled record (19.2 kHz for a 4 Hz oscillator: thousands of samples per
cycle) is compared as block means of ``block`` samples (:func:`block_means`, ``block`` set
by :func:`block_size` so that a block spans at most 0.2 rad of the fastest local
oscillation): with white sensor noise the block means carry the same information about a
signal whose band lies far below ``1 / (block dt)``, and every simulation runs on the grid
of the blocks' centres (``1 / block`` of the cost). The Jacobian of every
Levenberg-Marquardt step, and of the intervals below, comes from the forward sensitivity
equations integrated with the response (:mod:`eddi.sensitivity`: one pass at ~2x the cost
of a simulation, instead of one simulation per parameter); models with effects or
``sign`` terms use forward differences. On the 45 s, 19.2 kHz record of
``benchmarks/bench_identify_speed.py`` the refinement with term selection went from ~250
whole-window simulations (~15 s) to ~35 passes on 14k block means (<1 s).

This is an explicit option (``identify(..., refine=True)``), not part of the paper's method:
the EDDI estimate before refinement is kept in :attr:`eddi.identify.IdentifiedModel.unrefined`.

Evidence for each term (``select=True``)
----------------------------------------
At the optimum the output-error fit is a nonlinear least-squares problem with white sensor
noise, so the coefficients' covariance is ``s^2 (J^T J)^-1`` (``J``: the Jacobian of the
simulated signal, ``s^2 = RSS / (n - p)``, over the block means): :attr:`Refinement.ci95`
is ``1.96`` standard errors. Residuals that are not white (a DAQ's decimation filter, a
drifting bias) widen it by a sandwich over the response's band
(:func:`eddi.intervals.noise_covariance_of_fit`); a DAQ's sampling kernel, when told, is part of the model
(:func:`eddi.intervals.sampling_curvature`). Terms are then removed one at a time, the one with the smallest ``|c| / se`` first,
each removal refitted and kept only when it lowers the Bayesian information criterion
``BIC = n ln(RSS / n) + p ln(N)`` (``n`` block means, ``N`` samples: the likelihood ratio of
two nested fits is the same on block means as on the samples, and the penalty stays that of
the samples, so blocking does not change which terms are kept; when the least significant
term has ``(c / se)^2 > 4 ln N`` its removal would raise the BIC by ~``3 ln N`` (Wald), and the
elimination stops without refitting); the linear stiffness ``x`` and the last damping term stay.
When that backward path stalls (an ill-conditioned library on a short record), a forward path
from ``x`` and ``v`` is tried as well (:mod:`eddi.selection`).
:attr:`Refinement.dropped` says, per term removed, the BIC change and the coefficient it had.
:func:`confidence_intervals` gives the same covariance for a model that is not refitted
(only its initial state is fitted).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from eddi.errors import IdentificationError, SignalError
from eddi.intervals import (integration_shift, noise_covariance_of_fit, sampling_curvature, sampling_quartic,
                            through_sampling)
from eddi.model import EquationOfMotion
from eddi.simulate import local_angular_frequency, simulate
from eddi.terms import evaluate

#: Parameters after the coefficients: x0, v0 and the measured signal's offset.
NUISANCE = 3
#: Fractions of the record fitted in successive stages.
STAGES = (0.125, 0.5, 1.0)
#: Starts whose residual over the whole window is below this (relative to the signal, ~ the
#: phase error in rad) are fitted on the whole window at once.
DIRECT_NRMSE = 0.2


@dataclass(frozen=True)
class Refinement:
    """What the output-error refinement did.

    Attributes
    ----------
    channel : str
        ``"a"``, ``"v"`` or ``"x"``: the measured signal the simulation was fitted to.
    nrmse_before, nrmse_after : float
        ``||y_sim - y|| / ||y||`` over the whole window, EDDI estimate and refined.
    x0, v0 : float
        Fitted initial state at the centre of the first block (the window start when
        ``block`` is 1).
    evaluations : int
        Simulations asked for (all stages, Jacobians included; one asked for again at the
        point just simulated is served from memory, bit for bit the same, and counted).
    samples : int
        Samples in the whole window.
    block : int
        Samples per block mean compared (1: every sample; see :func:`block_size`).
    unselected, unselected_ci95 : dict of str to dict of str to float
        The output-error fit of every starting term before the selection: coefficients and
        their 95 % half widths (what :func:`bounded_intervals` bounds another estimate with).
    ci95 : dict of str to dict of str to float
        ``{"damping": {term: half width}, "stiffness": {...}}`` of the 95 % confidence
        intervals of the returned coefficients (empty when not computed).
    dropped : dict of str to str
        Terms removed by the selection, and why (empty without ``select``).
    """

    channel: str
    nrmse_before: float
    nrmse_after: float
    x0: float
    v0: float
    evaluations: int
    samples: int
    ci95: dict[str, dict[str, float]] = field(default_factory=dict)
    dropped: dict[str, str] = field(default_factory=dict)
    block: int = 1
    unselected: dict[str, dict[str, float]] = field(default_factory=dict)
    unselected_ci95: dict[str, dict[str, float]] = field(default_factory=dict)


#: Largest ``omega_max * block * dt`` (rad) of a block: the block mean then differs from the
#: curvature-corrected centre value by ~``(omega h)^4 / 339`` (4.7e-6 relative at 0.2), which
#: the fourth difference's term removes (:func:`eddi.intervals.sampling_quartic`; 2e-8 left).
BLOCK_H_OMEGA = 0.2
#: Fewest block means compared (short records keep every sample).
MIN_BLOCKS = 2000


def block_size(eom: EquationOfMotion, dt: float, x_amp: float, v_amp: float, n: int) -> int:
    """Samples per block mean (odd, >= 1): ``omega_max * block * dt <= BLOCK_H_OMEGA``.

    ``omega_max``: :func:`local_angular_frequency` over the record's amplitudes; at least
    :data:`MIN_BLOCKS` blocks are kept.
    """
    omega = local_angular_frequency(eom, x_amp, v_amp)
    if not (omega > 0 and math.isfinite(omega)):
        return 1
    b = min(int(BLOCK_H_OMEGA / (omega * dt)), n // MIN_BLOCKS)
    b = b if b % 2 == 1 else b - 1
    return max(1, b)


#: ``omega h`` of an RK4 step where the response has decayed (:func:`local_substeps`): half the
#: simulator's 0.1, so that a clean record is refitted as exactly as with the peak's step
#: everywhere (paper Duffing: every coefficient within 1e-6).
LOCAL_H_OMEGA = 0.05


def local_substeps(eom: EquationOfMotion, h: float, x_abs: np.ndarray, v_abs: np.ndarray,
                   most: int) -> np.ndarray:
    """RK4 steps per interval of ``h`` so that ``omega h / steps <= LOCAL_H_OMEGA`` at the amplitude ahead.

    ``omega``: :func:`eddi.simulate.local_angular_frequency` at the largest ``|x|, |v|`` the
    record reaches from each interval on (a ring-down slows as it decays: a hardening spring's
    first peak sets ~110 rad/s, its late cycles ~25), on 12 amplitude levels, interpolated;
    at most ``most``.
    """
    ax = np.maximum.accumulate(np.asarray(x_abs, dtype=float)[::-1])[::-1]
    av = np.maximum.accumulate(np.asarray(v_abs, dtype=float)[::-1])[::-1]
    if ax.size < 2 or not (ax[0] > 0 and av[0] > 0):
        return np.full(max(1, ax.size - 1), most, dtype=np.int64)
    levels = np.geomspace(max(ax[0] * 1e-3, float(ax[-1]) or ax[0] * 1e-3), ax[0], 12)
    ratio = av[0] / ax[0]
    omega = np.array([local_angular_frequency(eom, a, a * ratio) for a in levels])
    om = np.interp(ax[:-1], levels, omega)
    # the next level up bounds the interpolation between levels
    steps = np.ceil(h * np.maximum(om, np.interp(ax[:-1] * 1.2, levels, omega)) / LOCAL_H_OMEGA).astype(np.int64)
    return np.clip(steps, 1, most)


def block_means(y: np.ndarray, block: int) -> np.ndarray:
    """Means of consecutive blocks of ``block`` samples (a shorter last block is dropped).

    With white noise of variance ``s^2`` on ``y`` the block means carry white noise of
    variance ``s^2 / block``: for a signal whose band is far below ``1 / (block dt)`` the
    least-squares fit to the block means keeps (nearly) all the information of the samples,
    at ``1 / block`` of the cost. The model is compared through its value at the block's
    centre sample plus the curvature inside the block,
    ``mean = y_c + (block^2 - 1) / (24 block^2) (y_{c+1} - 2 y_c + y_{c-1})`` on the grid of
    centres (exact for a quadratic), plus a fourth difference's term
    (:func:`eddi.intervals.sampling_quartic`; ``O((omega h)^6)`` left).
    """
    if block <= 1:
        return np.asarray(y, dtype=float)
    nb = y.size // block
    return np.asarray(y[: nb * block], dtype=float).reshape(nb, block).mean(axis=1)


def smooth_model(eom: EquationOfMotion) -> bool:
    """True when the sensitivity equations give the Jacobian: no effects, no ``sign`` factor.

    A ``sign(v)`` (dry friction) switches the force at every reversal: the response's
    derivative then has jumps the sensitivity equations do not carry.
    """
    if eom.effects:
        return False
    return all(tm.exponents[4] % 2 == 0 and tm.exponents[5] % 2 == 0
               for tm in eom.damping_terms() + eom.stiffness_terms())


class _OutputError:
    """The output-error problem of one record: parameters scaled, simulations counted.

    The measured signal is compared as block means of ``block`` samples (odd), against the
    simulation on the grid of the blocks' centre samples, corrected for the curvature
    inside a block (see :func:`block_means`); ``block = 1`` on coarsely sampled records.
    """

    def __init__(self, eom: EquationOfMotion, t: np.ndarray, x: np.ndarray, v: np.ndarray, y: np.ndarray,
                 channel: str, kernel_var: float = 0.0) -> None:
        self.eom, self.channel = eom, channel
        self.n_samples = t.size
        dt = float(t[1] - t[0])
        x_amp, v_amp = float(np.max(np.abs(x))), float(np.max(np.abs(v)))
        self.block = block_size(eom, dt, x_amp, v_amp, t.size)
        half = (self.block - 1) // 2
        self.y = block_means(y, self.block)
        nb = self.y.size
        self.t = t[half: half + nb * self.block: self.block]
        # block mean of samples that are themselves the DAQ's kernel-weighted means (variance
        # ``kernel_var`` sample intervals^2, see :func:`eddi.intervals.sampling_curvature`)
        self.curvature = sampling_curvature(self.block, kernel_var)
        self.quartic = sampling_quartic(self.block, kernel_var)
        d_terms, k_terms = eom.damping_terms(), eom.stiffness_terms()
        self.names = [("damping", tm.text) for tm in d_terms] + [("stiffness", tm.text) for tm in k_terms]
        c0 = np.array([eom.damping[tm.text] for tm in d_terms] + [eom.stiffness[tm.text] for tm in k_terms])
        # parameter scales: the coefficient itself, or (for ~0 coefficients) the value whose term
        # would reach 1e-3 of the peak inertial force
        f_scale = eom.mass * float(np.max(np.abs(y if channel == "a" else np.gradient(v, t))))
        step = max(1, t.size // 20000)  # the peak of each term: every sample is not needed
        peak = (np.max(np.abs(evaluate(d_terms + k_terms, x[::step], v[::step])), axis=0) if self.names
                else np.zeros(0))
        floor = 1e-3 * f_scale / np.where(peak > 0, peak, 1.0)
        self.floor = floor
        # nuisance parameters after the coefficients: the initial state (x0, v0) and a constant
        # offset of the measured signal (what is left of the sensor's bias after the rest's
        # mean was removed: unmodelled, it biases every coefficient a little, all the same way)
        self.scale = np.concatenate((np.maximum(np.abs(c0), floor),
                                     [max(x_amp, 1e-300), max(v_amp, 1e-300),
                                      max(1e-3 * float(np.max(np.abs(y))), 1e-300)]))
        self.p0 = np.concatenate((c0, [x[half], v[half], 0.0])) / self.scale
        self.active = list(range(len(self.names)))
        # RK4 steps of omega h <= 0.1 on the blocks' grid (the simulator's own rule): at the
        # record's peak (self.substeps, for the simulator) and per block at the amplitude the
        # record still reaches from that block on (self.steps, for the compiled kernel)
        self.substeps = max(1, math.ceil(dt * self.block * local_angular_frequency(eom, x_amp, v_amp) / 0.1))
        self.steps = local_substeps(eom, dt * self.block, block_means(np.abs(x), self.block) if self.block > 1
                                    else np.abs(x), block_means(np.abs(v), self.block) if self.block > 1
                                    else np.abs(v), self.substeps)
        self.count = 0
        self.diverged = False
        #: a stage over ``stop`` values ends when a step lowers the RSS by less than
        #: ``min_gain * RSS / stop`` (MINPACK's ``ftol``; None: 1e-12; see
        #: :func:`refine_output_error`)
        self.min_gain: float | None = None
        self.x_scale: float | str = 1.0
        # the sensitivity pass of the last simulation (see :meth:`simulated`)
        self._last: tuple[bytes, int, np.ndarray, bool] | None = None
        # the last simulated signal: ((parameters key, stop), signal, diverged)
        self._memo: tuple[tuple[bytes, int], np.ndarray, bool] | None = None

    @property
    def n(self) -> int:
        """Compared values (block means)."""
        return self.y.size

    def bic(self, rss: float, n_params: int) -> float:
        """``n ln(RSS / n) + p ln(N)``: ``n`` block means, ``N`` samples (see the module notes)."""
        return self.n * float(np.log(rss / self.n)) + n_params * float(np.log(self.n_samples))

    def model_of(self, p: np.ndarray) -> EquationOfMotion:
        """The model of the active terms' scaled coefficients ``p[:-NUISANCE]``."""
        damping: dict[str, float] = {}
        stiffness: dict[str, float] = {}
        for k, i in enumerate(self.active):
            group, name = self.names[i]
            (damping if group == "damping" else stiffness)[name] = float(p[k] * self.scale[i])
        return self.eom.model_copy(update={"damping": damping, "stiffness": stiffness})

    def state(self, p: np.ndarray) -> tuple[float, float]:
        return float(p[-3] * self.scale[-3]), float(p[-2] * self.scale[-2])

    def simulated(self, p: np.ndarray, stop: int) -> np.ndarray:
        self.count += 1
        key = (self._key(p), stop)
        memo = self._memo
        if memo is not None and memo[0] == key:
            # the same point again (the fit's last evaluation, then the nrmse and the covariance
            # at the optimum): the same deterministic simulation, not run again
            self.diverged = memo[2]
            return memo[1].copy()
        out = self._simulated(p, stop)
        self._memo = (key, out.copy(), self.diverged)
        return out

    def _simulated(self, p: np.ndarray, stop: int, sensitivities: bool = True) -> np.ndarray:
        """The compared values at ``p`` (``sensitivities=False``: not integrating the Jacobian
        along, nor keeping it)."""
        x0, v0 = self.state(p)
        eom = self.model_of(p)
        if eom.effects:
            sim = simulate(eom, self.t[:stop] - self.t[0], x0=x0, v0=v0, substeps=self.substeps)
            out, diverged = {"a": sim.a, "v": sim.v, "x": sim.x}[self.channel], sim.diverged
        else:  # the same RK4, a kernel without the effects' branches
            from eddi.sensitivity import free_response_sensitivities

            # Levenberg-Marquardt asks for the Jacobian at the last point it evaluated whenever it
            # accepts a step (most steps): the sensitivities are integrated with the response
            # (the response is the same bit for bit with or without them) and kept for
            # :meth:`sensitivities`, one pass instead of two
            smooth = smooth_model(eom) and sensitivities
            resp, jac, diverged = free_response_sensitivities(eom, float(self.t[1] - self.t[0]), stop, x0, v0,
                                                              self.steps, jacobian=smooth)
            self._last = (self._key(p), stop, jac, bool(diverged)) if smooth else None
            out = resp[:, "xva".index(self.channel)]
        self.diverged = bool(diverged or not np.all(np.isfinite(out)))
        if self.diverged:
            return np.full(stop, 1e6 * float(np.max(np.abs(self.y))))
        # the block mean of a smooth signal: centre + curvature (+ the fourth difference's term)
        out = through_sampling(out, self.curvature, self.quartic)
        return out + float(p[-1] * self.scale[-1])

    def _key(self, p: np.ndarray) -> bytes:
        """What a simulation depends on: the scaled parameters, the active terms and their scales."""
        return (np.ascontiguousarray(p, dtype=float).tobytes() + np.asarray(self.active, dtype=np.int64).tobytes()
                + self.scale.tobytes())

    def residual(self, p: np.ndarray, stop: int) -> np.ndarray:
        return self.simulated(p, stop) - self.y[:stop]

    def sensitivities(self, p: np.ndarray, stop: int) -> np.ndarray | None:
        """Jacobian of the residual over ``[0, stop)`` w.r.t. the scaled parameters ``p``.

        From the forward sensitivity equations (:mod:`eddi.sensitivity`, one RK4 pass);
        None for a model that is not :func:`smooth_model` or when the simulation diverged
        (then: finite differences).
        """
        eom = self.model_of(p)
        if not smooth_model(eom):
            return None
        from eddi.sensitivity import free_response_sensitivities

        self.count += 1
        last = self._last
        if last is not None and last[1] == stop and last[0] == self._key(p):
            jac, div = last[2], last[3]
        else:
            x0, v0 = self.state(p)
            _, jac, div = free_response_sensitivities(eom, float(self.t[1] - self.t[0]), stop, x0, v0, self.steps)
        j = jac["xva".index(self.channel)]
        if div or not np.all(np.isfinite(j)):
            return None
        j = np.column_stack((j, np.ones(stop)))
        j = through_sampling(j, self.curvature, self.quartic)
        return j * self.scale[self.active + [-3, -2, -1]]

    def fit(self, p: np.ndarray, stop: int, max_nfev: int, free: np.ndarray | None = None):
        """Levenberg-Marquardt from ``p`` over ``[0, stop)``; ``free`` masks the fitted parameters."""
        from scipy.optimize import least_squares  # local: scipy.optimize only when refining

        if free is None:
            return least_squares(lambda q: self.residual(q, stop), p, jac=self._jac_function(stop), method="lm",
                                 x_scale=self.x_scale, max_nfev=max_nfev, xtol=1e-12,
                                 ftol=1e-12 if self.min_gain is None else max(1e-12, self.min_gain / stop))
        fixed = p.copy()

        def full(q: np.ndarray) -> np.ndarray:
            out = fixed.copy()
            out[free] = q
            return out

        jac_all = self._jac_function(stop)
        jac = "2-point" if jac_all == "2-point" else (lambda q: jac_all(full(q))[:, free])  # type: ignore[operator]
        sol = least_squares(lambda q: self.residual(full(q), stop), p[free], jac=jac, method="lm", x_scale=1.0,
                            max_nfev=max_nfev)
        out = fixed.copy()
        out[free] = sol.x
        sol.x = out
        return sol

    def _jac_function(self, stop: int):
        """The Jacobian for :func:`scipy.optimize.least_squares`: sensitivities, else 2-point."""
        if not smooth_model(self.eom):
            return "2-point"

        def jac(q: np.ndarray) -> np.ndarray:
            j = self.sensitivities(q, stop)
            return j if j is not None else self.jacobian(q, stop)

        return jac

    def ci95(self, p: np.ndarray, jac: np.ndarray | None = None) -> tuple[np.ndarray, float]:
        """95 % half widths of the active coefficients (their units) and the RSS at ``p``.

        ``inf`` where the data say nothing: a simulation that blows up at ``p``, or a
        coefficient the simulated signal does not depend on (a zero Jacobian column).
        """
        n = self.n
        r = self.residual(p, n)
        rss = float(r @ r)
        if self.diverged:
            return np.full(len(self.active), math.inf), rss
        if jac is None:
            jac = self.jacobian(p)
        dof = max(1, n - p.size)
        jtj = jac.T @ jac
        inv = np.linalg.pinv(jtj)
        # the coloured-noise covariance only ever widens an interval: a drift's low-frequency
        # power lies outside the response's band, but a slow ramp still leaks into the
        # coefficients, which the white s^2 (raised by it) happened to hold (see
        # noise_covariance_of_fit)
        var = np.maximum((rss / dof) * np.diag(inv), np.diag(inv @ noise_covariance_of_fit(jac, r, dof, jtj) @ inv))
        se = np.sqrt(np.clip(var[:-NUISANCE], 0.0, None)) * self.scale[self.active]
        se[~(np.diag(jtj)[:-NUISANCE] > 0)] = math.inf
        return 1.959964 * se, rss

    def jacobian(self, p: np.ndarray, stop: int | None = None) -> np.ndarray:
        """Jacobian of the simulated signal over ``[0, stop)`` (default: the whole window).

        Sensitivity equations when the model allows, else forward differences.
        """
        n = self.n if stop is None else stop
        sens = self.sensitivities(p, n)
        if sens is not None:
            return sens
        base = self.simulated(p, n)
        cols = []
        for k in range(p.size):
            h = 1e-6 * max(1.0, abs(float(p[k])))
            q = p.copy()
            q[k] += h
            cols.append((self.simulated(q, n) - base) / h)
        return np.column_stack(cols)

    def ci_dict(self, half: np.ndarray) -> dict[str, dict[str, float]]:
        out: dict[str, dict[str, float]] = {"damping": {}, "stiffness": {}}
        for k, i in enumerate(self.active):
            group, name = self.names[i]
            out[group][name] = float(half[k])
        return out


def _check(t: np.ndarray, x: np.ndarray, v: np.ndarray, a: np.ndarray | None,
           channel: str | None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, str]:
    t = np.asarray(t, dtype=float)
    n = t.size
    if n < 64:
        raise IdentificationError(f"output-error refinement needs >= 64 samples, got {n}")
    x = np.asarray(x, dtype=float)
    v = np.asarray(v, dtype=float)
    if channel is None:
        channel = "a" if a is not None else "x"
    if channel not in ("a", "v", "x") or (channel == "a" and a is None):
        raise SignalError(f"refinement channel must be 'a' (with a given), 'v' or 'x'; got {channel!r}"
                          + (" without a" if channel == "a" else ""))
    y = np.asarray({"a": a, "v": v, "x": x}[channel], dtype=float)
    return t, x, v, y, channel


def refine_output_error(
    eom: EquationOfMotion,
    t: np.ndarray,
    x: np.ndarray,
    v: np.ndarray,
    a: np.ndarray | None = None,
    *,
    channel: str | None = None,
    max_nfev: int = 60,
    select: bool = False,
    mapper=None,
    min_gain: float | None = None,
    kernel_var: float = 0.0,
) -> tuple[EquationOfMotion, Refinement]:
    """Refine the coefficients of ``eom`` by fitting its free response to the measurement.

    Parameters
    ----------
    eom : EquationOfMotion
        Starting model (from EDDI); its terms are kept (unless ``select``), their
        coefficients refined.
    t : ndarray, shape (n,), [s]
        Uniform times of a free response (no external force).
    x, v : ndarray, shape (n,)
        Measured coordinate and rate (``x[0], v[0]`` start the fit of the initial state).
    a : ndarray, shape (n,), optional
        Measured acceleration.
    channel : {"a", "v", "x"}, optional
        The signal to fit (the one the sensor measured); default ``"a"`` when ``a`` is
        given, else ``"x"``.
    max_nfev : int
        Limit per stage, as :func:`scipy.optimize.least_squares` counts for ``method="lm"``
        (a stage usually converges, by ``ftol``, in 3-5 iterations).
    select : bool
        Remove terms the data do not support (BIC, see the module notes).
    mapper : callable, optional
        ``mapper(fn, items) -> [fn(item) for item in items]`` for the independent trials of
        the forward term selection (:func:`eddi.selection._forward`), possibly in forked
        processes (:mod:`eddi.diagnosis.mapping`); default: in turn, here. Same result.
    min_gain : float, optional
        End a stage when a Levenberg-Marquardt step lowers the sum of squares by less than
        ``min_gain`` times its mean square per compared value (``RSS / n``: about the noise
        variance once the model fits, so ``min_gain = 1`` stops where a step moves the fit by
        less than one unit of chi-square). Default: run each stage to ``max_nfev`` or to
        rounding (``ftol`` 1e-12), as the identification does.
    kernel_var : float
        Variance of the DAQ's sampling kernel [sample intervals^2] (:func:`eddi.intervals.sampling_curvature`;
        :attr:`eddi.conditioning.ConditionedSignal.sample_kernel_var`): 0 for point samples.

    Returns
    -------
    eom : EquationOfMotion
        Refined model (same mass and effects; same terms unless ``select``).
    info : Refinement
        With ``ci95`` of the returned coefficients.

    Raises
    ------
    IdentificationError
        If the window is too short (fewer than 64 samples).
    SignalError
        If ``channel`` is unknown, or ``"a"`` without ``a``.
    """
    t, x, v, y, channel = _check(t, x, v, a, channel)
    prob = _OutputError(eom, t, x, v, y, channel, kernel_var)
    n = prob.n
    prob.min_gain = None if min_gain is None else float(min_gain)
    p = prob.p0.copy()
    norm = float(np.linalg.norm(prob.y)) or 1.0
    before = float(np.linalg.norm(prob.residual(p, n))) / norm
    sol = None
    # a start already within a fraction of a radian of the record over the whole window is in
    # the whole window's basin: the growing stages are for starts that would slip a cycle
    for frac in (STAGES if before > DIRECT_NRMSE else STAGES[-1:]):
        sol = prob.fit(p, max(64, int(round(frac * n))), max_nfev)
        p = sol.x
    after = float(np.linalg.norm(prob.residual(p, n))) / norm
    if not after <= before:  # never return a worse fit than the start
        p, after, sol = prob.p0.copy(), before, None
    # the Jacobian at the optimum: least_squares evaluated it there (the last stage is the whole window)
    jac = sol.jac if sol is not None and sol.jac.shape == (n, p.size) else None
    half, rss = prob.ci95(p, jac)
    # the fit's own RK4 error, corrected (eddi.intervals.integration_shift)
    shift, spread = integration_shift(prob, p, jac)
    unselected = prob.model_of(_shifted(p, shift))
    unselected_ci = prob.ci_dict(half + spread * prob.scale[prob.active])
    dropped: dict[str, str] = {}
    if select:
        from eddi.selection import core_start, select_terms  # local: it builds on this module
        p, half, dropped = select_terms(prob, p, half, rss, max_nfev, core_start(prob, t, x, v, y),
                                        mapper)
        after = min(after, float(np.linalg.norm(prob.residual(p, n))) / norm)
        if dropped:
            shift, spread = integration_shift(prob, p)
    p = _shifted(p, shift)
    half = half + spread * prob.scale[prob.active]
    refined = prob.model_of(p).model_copy(update={"notes": (eom.notes + "; " if eom.notes else "")
                                                  + f"refined by output error on {channel}"})
    x0, v0 = prob.state(p)
    return refined, Refinement(channel=channel, nrmse_before=before, nrmse_after=after, x0=x0, v0=v0,
                               evaluations=prob.count, samples=prob.n_samples, ci95=prob.ci_dict(half),
                               dropped=dropped, block=prob.block,
                               unselected={"damping": dict(unselected.damping), "stiffness": dict(unselected.stiffness)},
                               unselected_ci95=unselected_ci)


def _shifted(p: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """``p`` with its active coefficients moved by ``shift`` (the nuisance parameters kept)."""
    out = p.copy()
    out[: shift.size] += shift
    return out


def confidence_intervals(eom: EquationOfMotion, t: np.ndarray, x: np.ndarray, v: np.ndarray,
                         a: np.ndarray | None = None, *, channel: str | None = None,
                         kernel_var: float = 0.0) -> dict[str, dict[str, float]]:
    """95 % half widths of the coefficients of ``eom`` as they stand (not refitted).

    Only the initial state of the free response is fitted; the covariance is that of the
    output-error problem at ``eom`` (see the module notes), its residual including any bias
    of ``eom``.

    Returns
    -------
    dict
        ``{"damping": {term: half width}, "stiffness": {...}}`` in the coefficients' units.
    """
    t, x, v, y, channel = _check(t, x, v, a, channel)
    prob = _OutputError(eom, t, x, v, y, channel, kernel_var)
    free = np.zeros(prob.p0.size, dtype=bool)
    free[-NUISANCE:] = True
    p = prob.p0.copy()
    for frac in STAGES:
        p = prob.fit(p, max(64, int(round(frac * prob.n))), 20, free=free).x
    half, _ = prob.ci95(p)
    return prob.ci_dict(half)


def bounded_intervals(eom: EquationOfMotion, reference: dict[str, dict[str, float]],
                      reference_ci95: dict[str, dict[str, float]]) -> dict[str, dict[str, float]]:
    """95 % half widths for an estimate that is not the output-error fit (EDDI's).

    ``|c - c_ref| + h_ref`` per coefficient, where ``c_ref +- h_ref`` is the output-error fit
    of the same terms (:attr:`Refinement.unselected`): whenever the reference interval
    holds the true value, so does this one (triangle inequality), so it covers at least at
    the reference's rate. The output-error covariance evaluated at EDDI's model instead
    (:func:`confidence_intervals`) leaves out EDDI's own error and covered 0-40 % on
    the records where the pipeline kept EDDI's estimate (``benchmarks/bench_ci_coverage.py``).

    Parameters
    ----------
    eom : EquationOfMotion
        The estimate.
    reference, reference_ci95 : dict
        ``{"damping": {term: value}, "stiffness": {...}}`` and the half widths.

    Returns
    -------
    dict
        ``{"damping": {term: half width}, "stiffness": {...}}``; a term the reference lacks
        gets ``inf``.
    """
    out: dict[str, dict[str, float]] = {"damping": {}, "stiffness": {}}
    for group in ("damping", "stiffness"):
        for term, c in getattr(eom, group).items():
            ref = reference.get(group, {}).get(term)
            half = reference_ci95.get(group, {}).get(term)
            out[group][term] = (abs(c - ref) + half) if ref is not None and half is not None else math.inf
    return out
