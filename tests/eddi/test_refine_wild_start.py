"""A wild starting model is integrated with the simulator's step cap, not with millions of steps.

Found on a blind record (236 kg, 400 Hz, a steady tone under the ring-down): the IEPE check's
refit through a bad corner gave EDDI a model whose tangent stiffness at the record's amplitude
oscillates ~10^5 times faster than the record can show; the output-error problem asked
1.2e6 RK4 steps per sample (7.6e9 in all) and `station identify` ran for minutes. The
simulator caps its sub-steps at :data:`eddi.simulate.MAX_SUBSTEPS`; the refinement's problem
now does the same: such a start costs what a sound one does, and where its wild terms matter it
diverges at once and is judged as any diverged model.
"""

from __future__ import annotations

import numpy as np

from eddi.conditioning import condition
from eddi.model import EquationOfMotion
from eddi.output_error import OutputErrorProblem
from eddi.simulate import MAX_SUBSTEPS, local_angular_frequency
from tests.eddi.impact_cases import SYSTEMS, impact_record


def _record():
    r = impact_record("paper_do", snr_db=45.0, seed=2)
    cond = condition(r.t, acc=r.acc, force=r.force)
    w0, w1 = cond.window
    return cond.t[w0:w1], cond.x[w0:w1], cond.v[w0:w1], cond.a[w0:w1]


def test_a_wild_start_is_integrated_with_the_simulators_cap() -> None:
    spec = SYSTEMS["paper_do"]
    t, x, v, a = _record()
    x_amp = float(np.max(np.abs(x)))
    # a quintic spring that, at the record's peak, is 1e12 times the linear one
    k5 = 1e12 * spec["stiffness"]["x"] / x_amp**4
    wild = EquationOfMotion.create(mass=spec["mass"], damping=spec["damping"],
                                   stiffness={**spec["stiffness"], "x^5": k5})
    dt = float(t[1] - t[0])
    assert dt * local_angular_frequency(wild, x_amp, float(np.max(np.abs(v)))) / 0.1 > 100 * MAX_SUBSTEPS
    prob = OutputErrorProblem(wild, t, x, v, a, "a")
    assert prob.substeps == MAX_SUBSTEPS
    assert int(np.max(prob.steps)) == MAX_SUBSTEPS
    # 64 steps per sample (the start is in the decayed half, where the linear spring rules)
    out = prob.simulated(prob.p0, prob.n)
    assert out.shape == (prob.n,) and np.all(np.isfinite(out))


def test_a_sound_model_keeps_its_own_steps() -> None:
    spec = SYSTEMS["paper_do"]
    t, x, v, a = _record()
    eom = EquationOfMotion.create(mass=spec["mass"], damping=spec["damping"], stiffness=spec["stiffness"])
    prob = OutputErrorProblem(eom, t, x, v, a, "a")
    assert 1 <= prob.substeps < MAX_SUBSTEPS
    prob.simulated(prob.p0, prob.n)
    assert not prob.diverged
