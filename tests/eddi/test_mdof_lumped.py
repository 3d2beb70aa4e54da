"""Lumped masses, springs and dashpots from N accelerometers and a force, no mass given.

The rig (real numba RK4 of the coupled equations, sensor and ADC models, 45 dB) runs a chain
of our own (not one of the built-in systems the method was measured on) with a cubic spring
between the masses whose constant is hidden from the identification; it must come back
within 3 %, the masses within 2 %, and with the spring absent no cubic spring is found.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.mdof.lumped import Element, element_terms
from eddi.mdof.physical import identify_lumped
from simulated_rig.mdof_systems import MdofSystem, mdof_impact_test
from station.mdof_data import condition_multichannel
from station.readers import Measurement


def _system(k3: float) -> MdofSystem:
    return MdofSystem.model_validate({
        "name": "hidden", "masses_kg": [0.8, 0.3], "driving_point": 1, "record_s": 3.0,
        "impacts_n": [60.0, 150.0, 300.0],
        "elements": [{"between": [0, 1], "k": 35000.0, "c": 5.0},
                     {"between": [1, 2], "k": 15000.0, "k3": k3, "c": 1.5}]})


def _records(system: MdofSystem) -> list:
    out = []
    for k, peak in enumerate(system.impacts_n):
        rec = mdof_impact_test(system, peak, seed=7 + k, snr_db=45.0)
        meas = Measurement(t=rec.t, channels=rec.columns(), rate_hz=rec.rate_hz,
                           pretrigger_samples=rec.pretrigger_samples, mass=None, source=f"{peak} N", metadata={})
        out.append(condition_multichannel(meas))
    return out


def test_a_cubic_spring_between_masses_expands_to_the_rigs_monomials():
    truth = _system(1.3e10).model()
    terms = element_terms(Element("k3", 1, 2), 2)
    for i in range(2):
        for text, fac in terms[i].items():
            assert truth.stiffness[i][text] == pytest.approx(1.3e10 * fac, rel=1e-12)
    assert element_terms(Element("k", 0, 2), 2) == {1: {"x2": 1.0}}  # ground spring: one end
    assert element_terms(Element("c", 1, 2), 2) == {0: {"v1": 1.0, "v2": -1.0}, 1: {"v1": -1.0, "v2": 1.0}}


def test_a_hidden_cubic_coupling_is_found_within_3_percent_with_no_mass_given():
    k3 = float(np.random.default_rng(14).uniform(0.8e10, 2.5e10))  # hidden from the identification
    system = _system(k3)
    ident = identify_lumped(_records(system), ("acc1", "acc2"), "acc1")
    got = _constants(ident)
    assert got[("k3", 1, 2)] == pytest.approx(k3, rel=0.03)
    assert ident.model.mass == pytest.approx((0.8, 0.3), rel=0.02)
    assert got[("k", 0, 1)] == pytest.approx(35000.0, rel=0.02)
    assert got[("k", 1, 2)] == pytest.approx(15000.0, rel=0.03)
    # no cubic spring to ground (a spurious one would carry the coupling's force)
    assert abs(got.get(("k3", 0, 1), 0.0)) < 0.03 * k3 and abs(got.get(("k3", 0, 2), 0.0)) < 0.03 * k3
    # the coupling's monomials carry a finite 95 % interval (jackknife over contiguous blocks:
    # an extrapolation in amplitude, so wide) that holds the truth
    half = ident.model.stiffness_ci95[0]["x2^3"]
    assert 0.0 < half < 0.25 * k3 and abs(got[("k3", 1, 2)] - k3) <= half


def test_silent_on_a_linear_chain():
    ident = identify_lumped(_records(_system(0.0)), ("acc1", "acc2"), "acc1")
    got = _constants(ident)
    # the cubic force a spurious k3 would add at the records' amplitude, against the linear spring's
    x = max(float(np.max(np.abs(r.x))) for r in _records(_system(0.0))[-1:])
    for kind in (("k3", 1, 2), ("k3", 0, 1), ("k3", 0, 2)):
        assert abs(got.get(kind, 0.0)) * x**3 < 0.01 * 15000.0 * x
    assert ident.model.mass == pytest.approx((0.8, 0.3), rel=0.02)


def _constants(ident) -> dict[tuple, float]:
    """Element constants back from the model's monomials (two masses, physical coordinates)."""
    s1, s2 = ident.model.stiffness
    k3_12 = -s1.get("x2^3", 0.0)
    k_12 = -s1.get("x2", 0.0)
    return {("k3", 1, 2): k3_12, ("k", 1, 2): k_12, ("k", 0, 1): s1.get("x1", 0.0) - k_12,
            ("k3", 0, 1): s1.get("x1^3", 0.0) - k3_12, ("k3", 0, 2): s2.get("x2^3", 0.0) - k3_12}
