"""The folds' agreement on the coupling force (:mod:`eddi.mdof.agreement`, session 20): exact figures."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from eddi.mdof.agreement import AGREEMENT_LEAST, coupling_acceleration, coupling_agreement
from eddi.mdof.model import MdofModel
from eddi.mdof.terms import parse_multi_term


def _model(k3: float, mass=(2.0, 0.5), shapes=((1.0, 0.0), (0.0, 1.0)), own: float = 0.0) -> MdofModel:
    """A two-mass model in physical coordinates with a cubic spring ``k3 (x1 - x2)^3`` between the
    masses (its cross terms; ``own``: a cubic spring to the ground on mass 1, no coupling)."""
    eq1 = {"x1": 1e4, "x1^3": k3 + own, "x1^2*x2": -3 * k3, "x1*x2^2": 3 * k3, "x2^3": -k3}
    eq2 = {"x2": 1e4, "x2^3": k3, "x1^3": -k3, "x1^2*x2": 3 * k3, "x1*x2^2": -3 * k3}
    return MdofModel.create(coordinates="physical", mass=mass, input=(1.0, 0.0), damping=({"v1": 1.0}, {"v2": 1.0}),
                            stiffness=(eq1, eq2), channels=("acc1", "acc2"), shapes=shapes, driving_point="acc1")


def _record(seed: int) -> SimpleNamespace:
    t = np.linspace(0.0, 2.0, 4000)
    g = np.random.default_rng(seed)
    x = np.vstack([np.exp(-t) * np.sin(30 * t + g.uniform()), 0.4 * np.exp(-2 * t) * np.sin(71 * t)]) * 1e-2
    return SimpleNamespace(x=x, v=np.gradient(x, t, axis=1), window=(100, 3900))


def test_the_coupling_acceleration_is_the_cross_terms_over_the_mass() -> None:
    r = _record(1)
    m = _model(2e6)
    d = r.x[:, 100:3900]
    want = 2e6 * (-3 * d[0] ** 2 * d[1] + 3 * d[0] * d[1] ** 2 - d[1] ** 3) / 2.0  # eq 1, x1^3 is its own term
    assert np.allclose(coupling_acceleration(m, r)[0], want, rtol=1e-12)
    # a cubic spring to the ground is no coupling: no acceleration from it
    assert np.allclose(coupling_acceleration(_model(0.0, own=5e6), r), 0.0)


def test_folds_that_identify_one_coupling_agree_and_folds_that_flip_it_do_not() -> None:
    recs = [_record(s) for s in range(3)]
    assert coupling_agreement([_model(2e6), _model(2e6), _model(2e6)], recs) > 0.999
    # scatter of +-20 % about one coupling: still one force
    assert coupling_agreement([_model(1.6e6), _model(2.4e6), _model(2e6)], recs) > 0.95
    # h3-lin2's pattern (session 20): the folds' coefficients change sign
    got = coupling_agreement([_model(2e6), _model(-1.8e6), _model(0.3e6)], recs)
    assert got < AGREEMENT_LEAST
    # two folds that cancel exactly have no common force
    assert coupling_agreement([_model(2e6), _model(-2e6)], recs) < 1e-12


def test_the_measure_is_coordinate_free() -> None:
    """A fold in scaled coordinates (shapes 2x, masses and coefficients rescaled to the same physics)
    gives the same channel acceleration."""
    r = _record(4)
    k3, s = 2e6, 2.0
    phys = _model(k3)
    # q = x / s: m x'' + F(x) = 0 becomes (m s) q'' + F(s q) = 0: a term of degree d scales by s^d
    def eq(coefs: dict) -> dict:
        return {t: v * s ** parse_multi_term(t, 2).degree for t, v in coefs.items()}

    scaled = MdofModel.create(coordinates="modal", mass=tuple(s * m for m in phys.mass), input=phys.input,
                              damping=tuple({k: v * s for k, v in d.items()} for d in phys.damping),
                              stiffness=tuple(eq(d) for d in phys.stiffness), channels=phys.channels,
                              shapes=((s, 0.0), (0.0, s)), driving_point="acc1")
    assert np.allclose(coupling_acceleration(scaled, r), coupling_acceleration(phys, r), rtol=1e-9)
    assert coupling_agreement([phys, scaled], [r]) > 1 - 1e-9


def test_fewer_than_two_folds_with_a_finite_force_is_not_judged() -> None:
    r = _record(5)
    assert np.isnan(coupling_agreement([_model(2e6)], [r]))
    assert np.isnan(coupling_agreement([_model(0.0), _model(0.0)], [r]))  # no coupling force at all
