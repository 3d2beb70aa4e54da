"""EDDI over several records: exact coefficients from stacked energy balances."""

from __future__ import annotations

import numpy as np
import pytest

from eddi.errors import IdentificationError, TermError
from eddi.identify_many import (
    Basis, Segment, SegmentEnergy, gap_basis, identify_many, tanh_basis, term_basis,
)
from eddi.model import Effect, EquationOfMotion
from eddi.simulate import simulate

RATE = 10000.0
BASE = EquationOfMotion.create(mass=0.1, damping={"v": 0.06}, stiffness={"x": 600.0, "x^3": 2e7})


def _segments(eom: EquationOfMotion, v0s=(0.05, 0.08, 0.1), seconds: float = 3.0) -> list[Segment]:
    t = np.arange(int(seconds * RATE)) / RATE
    out = []
    for i, v0 in enumerate(v0s):
        s = simulate(eom, t, v0=v0, substeps=4)
        out.append(Segment(t, s.x, s.v, None, key=i))
    return out


def test_three_records_give_the_exact_duffing() -> None:
    fit = identify_many(_segments(BASE), 0.1, damping=["v", "x^2*v", "v^3"],
                        stiffness=["x", "x^2", "x^3"], noise=(0.0, 0.0))
    assert fit.damping["v"] == pytest.approx(0.06, rel=1e-6)
    assert abs(fit.damping["x^2*v"]) < 1e-3 and abs(fit.damping["v^3"]) < 1e-6
    assert fit.stiffness["x"] == pytest.approx(600.0, rel=1e-7)
    assert fit.stiffness["x^3"] == pytest.approx(2e7, rel=1e-6)
    assert abs(fit.stiffness["x^2"]) < 1e-3
    # one row per half cycle of every record
    assert fit.half_cycles == sum(SegmentEnergy(s, 0.1, (0.0, 0.0)).half_cycles for s in _segments(BASE))


def test_gap_basis_finds_the_contact_stiffness_and_a_fixed_model_is_kept() -> None:
    truth = BASE.with_effect(Effect(name="clearance", params={"gap_m": 1e-3, "stiffness_n_per_m": 200.0}))
    segs = _segments(truth)
    fit = identify_many(segs, 0.1, damping=["v"], stiffness=["x", "x^3", gap_basis(1e-3)], noise=(0.0, 0.0))
    assert fit.stiffness["gap(0.001)"] == pytest.approx(200.0, rel=1e-4)
    assert fit.stiffness["x"] == pytest.approx(600.0, rel=1e-6)
    # the baseline kept with its coefficients: only the contact stiffness is fitted
    kept = identify_many(segs, 0.1, damping=[], stiffness=[gap_basis(1e-3)], fixed=BASE, noise=(0.0, 0.0))
    assert kept.stiffness["gap(0.001)"] == pytest.approx(200.0, rel=1e-4)
    assert kept.damping == {}


def test_dry_friction_enters_phase_one() -> None:
    truth = BASE.with_effect(Effect(name="coulomb_friction", params={"force_n": 0.01, "velocity_scale": 1e-5}))
    fit = identify_many(_segments(truth), 0.1, damping=["v", tanh_basis(1e-5)], stiffness=["x", "x^3"],
                        noise=(0.0, 0.0))
    assert fit.damping["tanh(v/1e-05)"] == pytest.approx(0.01, rel=0.01)
    assert fit.damping["v"] == pytest.approx(0.06, rel=0.01)


def test_bad_inputs() -> None:
    t = np.arange(1000) / RATE
    x = 1e-3 * np.exp(-t)
    with pytest.raises(IdentificationError, match="zero crossings"):
        SegmentEnergy(Segment(t, x, -x), 0.1)
    with pytest.raises(IdentificationError, match="no segments"):
        identify_many([], 0.1, damping=["v"], stiffness=["x"])
    with pytest.raises(TermError, match="no potential"):
        identify_many(_segments(BASE, (0.05,), 1.0), 0.1, damping=["v"],
                      stiffness=[Basis("odd", lambda x, v: x)], noise=(0.0, 0.0))
    assert term_basis("v").potential is None and term_basis("x^3").potential is not None
