"""The output-error problem serves a simulation asked for again at the same point from memory.

``refine_output_error`` asks for the residual at the optimum up to three more times (the
fit's last evaluation, the nrmse, the covariance); each is the same deterministic RK4 pass.
The memory must give the same bits and never a stale answer: another point, another window
or other active terms simulate again.
"""

from __future__ import annotations

import numpy as np

import eddi.sensitivity as sensitivity
from eddi.conditioning import condition
from eddi.output_error import OutputErrorProblem as _OutputError
from tests.eddi.impact_cases import SYSTEMS, impact_record
from eddi.model import EquationOfMotion


def _problem() -> _OutputError:
    spec = SYSTEMS["paper_do"]
    r = impact_record("paper_do", snr_db=45.0, seed=2)
    cond = condition(r.t, acc=r.acc, force=r.force)
    w0, w1 = cond.window
    eom = EquationOfMotion.create(mass=spec["mass"], damping=spec["damping"], stiffness=spec["stiffness"])
    return _OutputError(eom, cond.t[w0:w1], cond.x[w0:w1], cond.v[w0:w1], cond.a[w0:w1], "a")


def test_a_repeated_point_is_served_from_memory_bit_for_bit(monkeypatch) -> None:
    prob = _problem()
    runs = []
    real = sensitivity.free_response_sensitivities

    def counted(*args, **kwargs):
        runs.append(args[2])
        return real(*args, **kwargs)

    monkeypatch.setattr(sensitivity, "free_response_sensitivities", counted)
    n = prob.n
    p = prob.p0.copy()
    r1 = prob.residual(p, n)
    r2 = prob.residual(p.copy(), n)
    assert np.array_equal(r1, r2) and len(runs) == 1 and prob.count == 2
    r2[:] = 0.0  # the caller's copy: the memory is not changed through it
    assert np.array_equal(prob.residual(p, n), r1) and len(runs) == 1
    # another point, another window, other active terms: simulated again, and different
    q = p.copy()
    q[0] *= 1.01
    assert not np.array_equal(prob.residual(q, n), r1) and len(runs) == 2
    assert prob.residual(p, n // 2).size == n // 2 and len(runs) == 3
    prob.active = prob.active[1:]
    assert not np.array_equal(prob.residual(p[1:], n), r1) and len(runs) == 4


def test_the_jacobian_pass_serves_the_residual_at_its_point(monkeypatch) -> None:
    """least_squares asks for the Jacobian at its optimum after a rejected trial step (the last
    simulation was elsewhere); that pass integrates the response too, and the residual asked for
    next at the optimum (the nrmse, the covariance) is served from it: the same bits as a fresh
    simulation, one RK4 pass fewer per refinement (session 12)."""
    prob = _problem()
    runs = []
    real = sensitivity.free_response_sensitivities

    def counted(*args, **kwargs):
        runs.append(args[2])
        return real(*args, **kwargs)

    monkeypatch.setattr(sensitivity, "free_response_sensitivities", counted)
    n = prob.n
    p = prob.p0.copy()
    q = p.copy()
    q[0] *= 1.01
    prob.residual(q, n)  # the rejected trial step: the last simulation is at q
    jac = prob.sensitivities(p, n)
    assert jac is not None and len(runs) == 2
    r = prob.residual(p, n)
    assert len(runs) == 2 and prob.count == 3 and not prob.diverged
    # the same bits as a problem that simulates p afresh, and the Jacobian at p is still served
    fresh = _problem()
    assert np.array_equal(r, fresh.residual(p, n)) and len(runs) == 3
    assert np.array_equal(prob.sensitivities(p, n), jac) and len(runs) == 3


def test_the_accepted_point_before_a_rejected_trial_is_still_remembered(monkeypatch) -> None:
    """Levenberg-Marquardt's pattern at its end: an accepted point p, a rejected trial q, then
    least_squares asks for the Jacobian at p and the caller for the residual at p: the pass p had
    serves both (two simulations remembered, :data:`eddi.output_error.MEMORY`); a third point
    forgets the oldest."""
    from eddi.output_error import MEMORY

    assert MEMORY == 2
    prob = _problem()
    runs = []
    real = sensitivity.free_response_sensitivities

    def counted(*args, **kwargs):
        runs.append(args[2])
        return real(*args, **kwargs)

    monkeypatch.setattr(sensitivity, "free_response_sensitivities", counted)
    n = prob.n
    p = prob.p0.copy()
    q, r = p.copy(), p.copy()
    q[0] *= 1.01
    r[0] *= 0.99
    res_p = prob.residual(p, n)
    jac_p = prob.sensitivities(p, n)
    prob.residual(q, n)
    assert len(runs) == 2
    assert np.array_equal(prob.sensitivities(p, n), jac_p) and len(runs) == 2
    assert np.array_equal(prob.residual(p, n), res_p) and len(runs) == 2 and not prob.diverged
    prob.residual(r, n)  # remembered now: p (served last) and r; q forgotten
    assert len(runs) == 3
    prob.residual(p, n)
    assert len(runs) == 3
    prob.residual(q, n)
    assert len(runs) == 4
