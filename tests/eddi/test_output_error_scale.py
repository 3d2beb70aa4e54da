"""OutputErrorProblem's parameter scales: each term's peak taken term by term (session 18) is the
peak of evaluate()'s columns, bit for bit; the nuisance scales from one max |y|."""

from __future__ import annotations

import numpy as np
import pytest

from eddi.model import EquationOfMotion
from eddi.output_error import OutputErrorProblem
from eddi.simulate import simulate
from eddi.terms import evaluate

EOM = EquationOfMotion.create(mass=0.815, damping={"v": 0.196, "x^2*v": 1.0e-9, "v^3": 9.96},
                              stiffness={"x": 390.0, "x^2": 0.0, "x^3": 1.3e7, "abs(x)*x": 1e-12})


@pytest.mark.parametrize("channel", ["a", "v", "x"])
def test_scales_are_the_evaluate_columns_peaks(channel):
    t = np.arange(60000) / 10000.0
    sim = simulate(EOM, t, x0=0.0, v0=0.3)
    y = {"a": sim.a, "v": sim.v, "x": sim.x}[channel]
    prob = OutputErrorProblem(EOM, t, sim.x, sim.v, y, channel)
    terms = EOM.damping_terms() + EOM.stiffness_terms()
    step = max(1, t.size // 20000)
    peak = np.max(np.abs(evaluate(terms, sim.x[::step], sim.v[::step])), axis=0)
    f_scale = EOM.mass * float(np.max(np.abs(y if channel == "a" else np.gradient(sim.v, t))))
    floor = 1e-3 * f_scale / np.where(peak > 0, peak, 1.0)
    assert prob.floor.tobytes() == floor.tobytes()
    c0 = np.array([EOM.damping[tm.text] for tm in EOM.damping_terms()] + [EOM.stiffness[tm.text] for tm in EOM.stiffness_terms()])
    assert np.array_equal(prob.scale[:-3], np.maximum(np.abs(c0), floor))
    assert prob.scale[-1] == max(1e-3 * float(np.max(np.abs(y))), 1e-300)
