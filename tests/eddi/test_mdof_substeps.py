"""RK4 sub-steps of the MDOF simulation from the states met (eddi.mdof.simulate.trajectory_substeps).

Session 13 measured a three-mass diagnose whose polish ran 22-43 sub-steps per sample: the old bound
(``auto_substeps``) adds every equation's stiffness magnitudes with every coordinate at its own peak
at once. These tests derive the count from the physics of a chain (its tangent stiffness along the
trajectory), not from the code, and check the accuracy against a fine reference.
"""

from __future__ import annotations

import math

import numpy as np

from eddi.mdof.simulate import TRAJECTORY_MARGIN, auto_substeps, simulate_mdof, trajectory_substeps
from simulated_rig.mdof_systems import MdofSystem

DT = 1.0 / 5000.0
MASSES = np.array([1.0, 0.5, 2.0])
K = (4e5, 3e5, 5e5)  # ground-1, 1-2, 2-3 [N/m]


def _chain(k3: float) -> MdofSystem:
    return MdofSystem.model_validate({
        "name": "three", "masses_kg": MASSES.tolist(), "driving_point": 2, "record_s": 0.3, "impacts_n": [200.0],
        "elements": [{"between": [0, 1], "k": K[0]}, {"between": [1, 2], "k": K[1]},
                     {"between": [2, 3], "k": K[2], "k3": k3}]})


def _top_omega(k23: float) -> float:
    """Largest natural frequency [rad/s] of the chain with the 2-3 spring's tangent constant ``k23``."""
    k = np.array([[K[0] + K[1], -K[1], 0.0], [-K[1], K[1] + k23, -k23], [0.0, -k23, k23]])
    return float(np.sqrt(np.max(np.linalg.eigvals(k / MASSES[:, None]).real)))


def test_linear_chain_takes_the_top_modes_steps_not_the_row_sums():
    model = _chain(0.0).model()
    states = 1e-3 * np.random.default_rng(0).standard_normal((3, 50))
    expected = math.ceil(DT * _top_omega(K[2]) / 0.05)  # 220 Hz top mode at 5 kHz: 6
    assert expected == 6
    assert trajectory_substeps(model, DT, states) == expected
    t = np.arange(400) * DT
    assert simulate_mdof(model, t, x0=np.array([1e-3, 0, 0]), states=states).substeps == expected
    assert auto_substeps(model, DT, 1e-3) == 8  # the old bound (row sums of |K| / m), for the record


def test_cubic_chain_steps_follow_the_tangent_stiffness_along_the_trajectory_and_stay_accurate():
    k3 = 2e12  # a 2-3 cubic spring [N/m^3]
    model = _chain(k3).model()
    t = np.arange(1500) * DT
    x0 = np.array([0.0, 2e-4, -2e-4])
    fine = simulate_mdof(model, t, x0=x0, substeps=200)
    states = fine.x  # the states the simulation meets (a record of this model would give these)
    d = TRAJECTORY_MARGIN * np.max(np.abs(states[1] - states[2]))  # the 2-3 spring's stretch, with the margin
    expected = math.ceil(DT * _top_omega(K[2] + 3 * k3 * d**2) / 0.05)
    assert trajectory_substeps(model, DT, states) == expected
    assert expected < auto_substeps(model, DT, np.max(np.abs(states), axis=1))  # the old bound: opposite peaks
    sim = simulate_mdof(model, t, x0=x0, states=states)
    assert sim.substeps == expected
    err = np.max(np.linalg.norm(sim.x - fine.x, axis=1) / np.linalg.norm(fine.x, axis=1))
    # RK4 at h omega <= 0.05 against 200 sub-steps: 2.5e-6 at these 11 (1.3e-6 at the old bound's 13), far
    # below any channel's noise floor (the polish weighs errors by floors >= 1e-3)
    assert err < 5e-6


def test_linear_chain_counts_from_one_state_with_the_same_result(monkeypatch):
    """A model whose stiffness is linear has the same Jacobian at every state: the count is taken from
    one (session 18: ~11 ms of eigenvalues per simulation of a linear lumped baseline on a 3 s record),
    and equals the count over every state; a cubic chain still looks at every state."""
    import eddi.mdof.simulate as sim

    states = 1e-3 * np.random.default_rng(1).standard_normal((3, 9000))  # three chunks of 4096
    seen = []
    plain = np.linalg.eigvals

    def counted(a):
        seen.append(np.asarray(a).shape[0])
        return plain(a)

    monkeypatch.setattr(sim.np.linalg, "eigvals", counted)
    linear = _chain(0.0).model()
    assert sim._linear_stiffness(linear) and not sim._linear_stiffness(_chain(2e12).model())
    got = trajectory_substeps(linear, DT, states)
    assert seen == [1]  # one state, one 3 x 3 matrix (the old code: 4096 + 4096 + 808 of them)
    monkeypatch.setattr(sim, "_linear_stiffness", lambda model: False)
    seen.clear()
    assert trajectory_substeps(linear, DT, states) == got == 6  # every state: the same count
    assert seen == [4096, 4096, 808]
    monkeypatch.undo()
    monkeypatch.setattr(sim.np.linalg, "eigvals", counted)
    seen.clear()
    trajectory_substeps(_chain(2e12).model(), DT, states)
    assert seen == [4096, 4096, 808]
