"""How the output-error polish (:mod:`eddi.mdof.refine`) steps, and where it stops: at the records' noise.

The polish minimises the training records' simulated-displacement error. Below the error the
noise alone leaves, every further step fits the noise: on ``bench_mdof_target.py``'s two-mass
chain chain-6-0 (held out in session 15) the model EDDI identified had its coupling cubic within
0.06 % and reproduced the held-out captures at the true model's 0.0078; the polish took the
training error below the truth's and left the cubic 3.1 % off, held out 0.0085. The error it
removed there was the blows' impulse errors (the force noise during the impact,
:func:`eddi.mdof.validate.impulse_floor`): one draw per record, at the modes' frequencies, which
a cubic and the masses can mimic over three records.

The stop is the discrepancy principle (Morozov) of iterative regularisation: the polish takes
no step once the training cost is within what the noise explains, :func:`noise_cost` - the
expected sum of squared weighted residuals of the true model: per record and channel the
acceleration noise through the integration and the drift high-pass
(:func:`~eddi.mdof.validate.noise_floor`, stationary: the same density on any span) plus the
impulse error times the share of the channel's signal in the fitted span (it scales the
response).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from eddi.mdof.validate import impulse_floor, noise_floor


def noise_cost(prepared: Sequence[tuple], floor_min: float, scaled: int = 0) -> float:
    """Expected ``sum(residual**2)`` of the noise alone for the polish's residual vector.

    ``prepared``: per record ``(record, keep, divisor)`` as :func:`eddi.mdof.refine._weights`
    gives them (the first ``keep`` samples of the free window, every second one in the residual,
    each channel divided by ``divisor`` = its window norm times its floor times ``sqrt(keep/n)``).
    ``scaled``: the number of captures whose impulse the polish fits (``eddi.mdof.refine.ImpulseScales``,
    their mean held): of each one's impulse error only the mean's share ``1 / scaled`` is left in
    the records' residual, and the scales' prior rows add ``scaled - 1``.
    """
    total = 0.0 if scaled < 2 else float(scaled - 1)
    for r, keep, _norm in prepared:
        y = r.x[:, r.window[0]:r.window[1]]
        n = y.shape[1]
        floor = noise_floor(r)
        weight = np.maximum(floor, floor_min)
        energy = np.sum(y**2, axis=1)
        share = np.sum(y[:, :keep] ** 2, axis=1) / np.where(energy > 0, energy, 1.0)
        eps = impulse_floor(r) / (np.sqrt(scaled) if scaled >= 2 and impulse_floor(r) > 0 else 1.0)
        per_channel = (floor**2 + eps**2 * share * n / keep) / weight**2
        total += 0.5 * float(np.sum(per_channel))  # every second sample
    return total


class Steering:
    """``least_squares``' ``jac`` and ``callback`` for the polish: the noise stop and Broyden steps.

    ``limit``: :func:`noise_cost` of the residual (negative: no stop). scipy's trust-region loop
    computes the Jacobian at every accepted point before its callback sees it; here the Jacobian
    call itself reads the point's residual (the polish's memo holds it: no simulation) and, when
    its cost is within ``limit``, returns the last Jacobian instead of computing one, and the
    callback then stops (status -2): no Jacobian is spent on a point the polish will not leave.

    ``broyden``: at most that many Broyden rank-one updates between two computed Jacobians
    (0: every Jacobian computed). An update is taken after a step whose actual reduction of the
    cost was at least :data:`BROYDEN_RATIO` of what the last Jacobian predicted (the linear
    model held over the step); otherwise the Jacobian is computed. Every step is still accepted
    or refused on the simulated residual: a poorer Jacobian costs steps, not accuracy.

    ``exact``: the last Jacobian returned is the computed one at the last point (the intervals
    need that; :func:`eddi.mdof.refine._jacobian_at` otherwise). ``computed``, ``updated``: counts.
    """

    def __init__(self, residual, jac, limit: float, broyden: int = 0):
        self._residual, self._jac, self.limit = residual, jac, float(limit)
        self._broyden = int(broyden)
        self._last = self._at = None
        self._left = 0
        self.stopped = False
        self.crossing = None
        self.exact = True
        self.computed = self.updated = 0
        self.settled = 1.0  # the share of the last step :meth:`settle` kept

    @property
    def scipy_jac(self):
        """What ``least_squares`` takes as ``jac``: :meth:`jac`, or scipy's finite differences by name."""
        return self.jac if callable(self._jac) else self._jac

    def within(self, p: np.ndarray) -> bool:
        if self.limit < 0:
            return False
        r = self._residual(p)
        return bool(np.all(np.isfinite(r)) and float(r @ r) <= self.limit)

    def jac(self, p: np.ndarray):
        p = np.array(p, float)
        if self._last is not None and self.within(p):
            self.stopped, self.exact = True, False
            if self._at is not None and not self.within(self._at):
                self.crossing = (self._at.copy(), p.copy())
            return self._last
        if self._last is not None and self._left > 0 and self._held(p):
            f_new, f_old = self._residual(p), self._residual(self._at)
            dx = p - self._at
            self._last = self._last + np.outer(f_new - f_old - self._last @ dx, dx / float(dx @ dx))
            self._left -= 1
            self.updated += 1
            self.exact = False
        else:
            self._last = np.asarray(self._jac(p), float)
            self._left = self._broyden
            self.computed += 1
            self.exact = True
        self._at = p
        return self._last

    def settle(self, p: np.ndarray) -> np.ndarray:
        """Where the polish ends when its last step (to ``p``) crossed the noise cost from above:
        the point of that step whose cost meets ``limit`` (bisection, :data:`SETTLE_STEPS`
        simulations; the side within the noise). Else ``p`` itself (the same object).

        Morozov's stop acts at the first point within the noise, but one trust-region step can
        cross far below it: on a two-mass chain of our own (session 16, chain-62-10, 55 dB) the
        start cost 19.5 noise units, the noise 5.95, and one step ended at 4.76 - training below
        the truth's error, held out 0.0085 / 0.0073 against the truth's 0.0054 / 0.0033."""
        if not self.stopped or self.crossing is None or not np.array_equal(self.crossing[1], p):
            return p
        lo, hi = self.crossing
        for _ in range(SETTLE_STEPS):
            mid = 0.5 * (lo + hi)
            if self.within(mid):
                hi = mid
            else:
                lo = mid
        self.settled = float(np.linalg.norm(hi - self.crossing[0]) / max(np.linalg.norm(p - self.crossing[0]), 1e-300))
        return hi

    def recompute(self) -> None:
        """The next Jacobian is computed (a restart after convergence on a Broyden one)."""
        self._left = 0

    def _held(self, p: np.ndarray) -> bool:
        """The last step's actual reduction against the reduction the last Jacobian predicted."""
        f_old, f_new = self._residual(self._at), self._residual(p)
        dx = p - self._at
        if not (np.all(np.isfinite(f_new)) and np.all(np.isfinite(f_old))) or not np.any(dx):
            return False
        jd = self._last @ dx
        predicted = -(float(f_old @ jd) + 0.5 * float(jd @ jd))
        actual = 0.5 * (float(f_old @ f_old) - float(f_new @ f_new))
        return predicted > 0 and actual >= BROYDEN_RATIO * predicted

    def callback(self, intermediate_result) -> None:
        if self.stopped or (not callable(self._jac) and 0 <= self.limit
                            and 2.0 * float(intermediate_result.cost) <= self.limit):
            raise StopIteration


#: Bisections of a step that crossed the noise cost (:meth:`Steering.settle`): the end within 1/32 of the step.
SETTLE_STEPS = 5
#: A Broyden update replaces the computed Jacobian after a step that achieved at least this share
#: of the reduction the last Jacobian predicted (:class:`Steering`).
BROYDEN_RATIO = 0.5
