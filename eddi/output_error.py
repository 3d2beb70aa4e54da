"""The output-error problem of one record (:mod:`eddi.refine`): parameters, simulations, Jacobian, covariance.

:class:`OutputErrorProblem` holds a record's measured signal as block means
(:mod:`eddi.refine_grid`) and the scaled parameters (the coefficients of the active terms,
then the initial state ``x0, v0`` and the measured signal's offset: :data:`NUISANCE`); it
simulates them, differentiates them (forward sensitivity equations, :mod:`eddi.sensitivity`,
else forward differences) and fits them (:func:`eddi.lsq.least_squares`,
MINPACK's Levenberg-Marquardt in numpy) over the first ``stop`` block means. :func:`eddi.refine.refine_output_error`
fits it in :data:`STAGES`; :mod:`eddi.selection` removes and adds terms with it.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from eddi.intervals import noise_covariance_of_fit, normal_pinv, sampling_curvature, sampling_quartic, through_sampling
from eddi.model import EquationOfMotion
from eddi.peaks import peak_abs
from eddi.refine_grid import block_means, block_means_abs, block_size, local_substeps, smooth_model
from eddi.secant_jacobian import secant_jacobian, switching_model
from eddi.simulate import MAX_SUBSTEPS, local_angular_frequency, simulate

#: Parameters after the coefficients: x0, v0 and the measured signal's offset.
NUISANCE = 3
#: Fractions of the record fitted in successive stages.
STAGES = (0.125, 0.5, 1.0)
#: Starts whose residual over the whole window is below this (relative to the signal, ~ the
#: phase error in rad) are fitted on the whole window at once.
DIRECT_NRMSE = 0.2
#: Simulations (with their sensitivity passes) remembered. Two: Levenberg-Marquardt's last trial
#: step is usually rejected, and least_squares then asks for the Jacobian at the accepted point
#: before it (its optimum), then the nrmse and the covariance there: all served by the pass
#: that point already had (session 12: 6 -> 5 RK4 passes on the 45 s record). A point served
#: from memory becomes the newest (the oldest is forgotten first).
MEMORY = 2


class OutputErrorProblem:
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
        x_amp, v_amp = peak_abs(x), peak_abs(v)
        self.block = block_size(eom, dt, x_amp, v_amp, t.size)
        half = (self.block - 1) // 2
        self.y = block_means(y, self.block)
        nb = self.y.size
        self.t = t[half: half + nb * self.block: self.block]
        # block mean of samples that are themselves the DAQ's kernel-weighted means (variance
        # ``kernel_var`` sample intervals^2, see :func:`eddi.intervals.sampling_curvature`)
        self.kernel_var = kernel_var
        self.curvature = sampling_curvature(self.block, kernel_var)
        self.quartic = sampling_quartic(self.block, kernel_var)
        d_terms, k_terms = eom.damping_terms(), eom.stiffness_terms()
        self.names = [("damping", tm.text) for tm in d_terms] + [("stiffness", tm.text) for tm in k_terms]
        c0 = np.array([eom.damping[tm.text] for tm in d_terms] + [eom.stiffness[tm.text] for tm in k_terms])
        # parameter scales: the coefficient itself, or (for ~0 coefficients) the value whose term
        # would reach 1e-3 of the peak inertial force
        y_amp = peak_abs(y)
        f_scale = eom.mass * (y_amp if channel == "a" else peak_abs(np.gradient(v, t)))
        step = max(1, t.size // 20000)  # the peak of each term: every sample is not needed
        xs, vs = np.ascontiguousarray(x[::step]), np.ascontiguousarray(v[::step])
        # term by term (the same maxima as of evaluate()'s columns: no (n, terms) table and its
        # strided column reductions)
        peak = np.array([peak_abs(tm(xs, vs)) for tm in d_terms + k_terms], dtype=float)
        floor = 1e-3 * f_scale / np.where(peak > 0, peak, 1.0)
        self.floor = floor
        # nuisance parameters after the coefficients: the initial state (x0, v0) and a constant
        # offset of the measured signal (what is left of the sensor's bias after the rest's
        # mean was removed: unmodelled, it biases every coefficient a little, all the same way)
        self.scale = np.concatenate((np.maximum(np.abs(c0), floor),
                                     [max(x_amp, 1e-300), max(v_amp, 1e-300),
                                      max(1e-3 * y_amp, 1e-300)]))
        self.p0 = np.concatenate((c0, [x[half], v[half], 0.0])) / self.scale
        self.active = list(range(len(self.names)))
        # RK4 steps of omega h <= 0.1 on the blocks' grid (the simulator's own rule): at the
        # record's peak (self.substeps, for the simulator) and per block at the amplitude the
        # record still reaches from that block on (self.steps, for the compiled kernel); at most
        # MAX_SUBSTEPS, as the simulator: a wild starting model (a refit through a bad corner:
        # 1.2e6 steps per sample, 7.6e9 in all) then diverges at once instead of running minutes
        omega = local_angular_frequency(eom, x_amp, v_amp)
        self.omega = omega
        self.substeps = (min(MAX_SUBSTEPS, max(1, math.ceil(dt * self.block * omega / 0.1)))
                         if math.isfinite(omega) else MAX_SUBSTEPS)
        self.steps = local_substeps(eom, dt * self.block, block_means_abs(x, self.block) if self.block > 1
                                    else np.abs(x), block_means_abs(v, self.block) if self.block > 1
                                    else np.abs(v), self.substeps)
        self.count = 0
        self.diverged = False
        #: a stage over ``stop`` values ends when a step lowers the RSS by less than
        #: ``min_gain * RSS / stop`` (MINPACK's ``ftol``; None: 1e-12; see
        #: :func:`refine_output_error`)
        self.min_gain: float | None = None
        self.x_scale: float | str = 1.0
        # the sensitivity passes of the last :data:`MEMORY` simulations: (key, stop, jacobian,
        # diverged), newest last (see :meth:`simulated`); rebound, never changed in place
        self._last: tuple[tuple[bytes, int, np.ndarray, bool], ...] = ()
        # the last :data:`MEMORY` simulated signals: ((parameters key, stop), signal, diverged)
        self._memo: tuple[tuple[tuple[bytes, int], np.ndarray, bool], ...] = ()
        # a switching model's secant Jacobian at the last point asked for ((key, stop), jacobian)
        self._secant: tuple[tuple[bytes, int], np.ndarray] | None = None

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
        for memo in self._memo:
            if memo[0] == key:
                # the same point again (the fit's last evaluation or the accepted point before a
                # rejected trial, then the nrmse and the covariance at the optimum): the same
                # deterministic simulation, not run again
                self.diverged = memo[2]
                self._remember(*memo)  # the newest now: what a later point evicts last
                return memo[1].copy()
        out = self._simulated(p, stop)
        self._remember(key, out.copy(), self.diverged)
        return out

    def _remember(self, key: tuple[bytes, int], out: np.ndarray, diverged: bool) -> None:
        self._memo = tuple(m for m in self._memo if m[0] != key)[-(MEMORY - 1):] + ((key, out, diverged),)

    def _remember_jacobian(self, key: bytes, stop: int, jac: np.ndarray, diverged: bool) -> None:
        self._last = (tuple(j for j in self._last if (j[0], j[1]) != (key, stop))[-(MEMORY - 1):]
                      + ((key, stop, jac, diverged),))

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
            if smooth:
                self._remember_jacobian(self._key(p), stop, jac, bool(diverged))
            out = resp[:, "xva".index(self.channel)]
        out, self.diverged = self._compared(p, stop, out, bool(diverged))
        return out

    def _compared(self, p: np.ndarray, stop: int, out: np.ndarray, diverged: bool) -> tuple[np.ndarray, bool]:
        """The compared values from the simulated signal at the blocks' centres, and whether it diverged."""
        diverged = bool(diverged or not np.all(np.isfinite(out)))
        if diverged:
            return np.full(stop, 1e6 * peak_abs(self.y)), True
        # the block mean of a smooth signal: centre + curvature (+ the fourth difference's term)
        out = through_sampling(out, self.curvature, self.quartic)
        return out + float(p[-1] * self.scale[-1]), False

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
        key = self._key(p)
        last = [j for j in self._last if j[1] == stop and j[0] == key]
        if last:
            jac, div = last[0][2], last[0][3]
            self._remember_jacobian(*last[0])
        else:
            x0, v0 = self.state(p)
            resp, jac, div = free_response_sensitivities(eom, float(self.t[1] - self.t[0]), stop, x0, v0, self.steps)
            # the response came with it (the same bits as a simulation at ``p``): least_squares asks
            # for the Jacobian at its optimum after a rejected trial step, and the residual there is
            # asked for next (the nrmse, the covariance): served from memory, not integrated again
            out, sim_div = self._compared(p, stop, resp[:, "xva".index(self.channel)], bool(div))
            self._remember((key, stop), out, sim_div)
            self._remember_jacobian(key, stop, jac, bool(div))
        j = jac["xva".index(self.channel)]
        if div or not np.all(np.isfinite(j)):
            return None
        j = np.column_stack((j, np.ones(stop)))
        j = through_sampling(j, self.curvature, self.quartic)
        return j * self.scale[self.active + [-3, -2, -1]]

    def fit(self, p: np.ndarray, stop: int, max_nfev: int, free: np.ndarray | None = None):
        """Levenberg-Marquardt from ``p`` over ``[0, stop)``; ``free`` masks the fitted parameters.
        A ``stop`` beyond the record is the whole record (the stages' 64 on a short one)."""
        from eddi.lsq import least_squares  # numpy's MINPACK lmder (EDDI_LSQ=scipy: scipy's)

        stop = min(int(stop), self.n)
        if free is None:
            return least_squares(lambda q: self.residual(q, stop), p, jac=self._jac_function(stop),
                                 x_scale=self.x_scale, max_nfev=max_nfev, xtol=1e-12,
                                 ftol=1e-12 if self.min_gain is None else max(1e-12, self.min_gain / stop))
        fixed = p.copy()

        def full(q: np.ndarray) -> np.ndarray:
            out = fixed.copy()
            out[free] = q
            return out

        jac_all = self._jac_function(stop)
        jac = "2-point" if jac_all == "2-point" else (lambda q: jac_all(full(q))[:, free])  # type: ignore[operator]
        sol = least_squares(lambda q: self.residual(full(q), stop), p[free], jac=jac, x_scale=1.0,
                            max_nfev=max_nfev)
        out = fixed.copy()
        out[free] = sol.x
        return _with_x(sol, out)

    def _jac_function(self, stop: int):
        """The Jacobian for :func:`eddi.lsq.least_squares`: sensitivities, else 2-point."""
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
        if jac is None or switching_model(self.model_of(p)):  # MINPACK's step: see eddi.secant_jacobian
            jac = self.jacobian(p)
        dof = max(1, n - p.size)
        inv = normal_pinv(jac)
        if inv is None:  # the data fix nothing here (see eddi.intervals.normal_pinv)
            return np.full(len(self.active), math.inf), rss
        jtj = jac.T @ jac
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

        Sensitivity equations when the model allows; central secants over one standard error
        for a model with a ``sign`` factor (:mod:`eddi.secant_jacobian`); else forward differences.
        """
        n = self.n if stop is None else stop
        sens = self.sensitivities(p, n)
        if sens is not None:
            return sens
        if switching_model(self.model_of(p)):  # a step of 1e-6 divides the switches' jumps by it
            key = (self._key(p), n)
            if self._secant is None or self._secant[0] != key:
                self._secant = (key, secant_jacobian(self, p, n))
            return self._secant[1].copy()
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


def _with_x(sol, x: np.ndarray):
    """``sol`` with its ``x`` replaced (a frozen :class:`eddi.lsq.LsqResult`, or scipy's result)."""
    if dataclasses.is_dataclass(sol):
        return dataclasses.replace(sol, x=x)
    sol.x = x
    return sol
