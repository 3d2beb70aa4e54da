"""Quadratic springs and cubic dampers between masses: found, named, and not invented.

The rig (numba RK4 of the coupled equations, sensor and ADC models, 45 dB) runs a chain of our
own (0.8 + 0.3 kg; not a bench case) with one hidden element between the masses. The lumped fit
must find a quadratic (asymmetric) spring ``k2 (x1 - x2)^2`` within its 95 % interval and a cubic
damper ``c3 (v1 - v2)^3`` within 5 %, name them, and on the nulls (a linear chain; a cubic
spring between the masses) name neither. Session 13 (issue 14): before, the library knew only
dashpots, linear and cubic springs.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.mdof.lumped import Element, element_terms
from eddi.mdof.mechanisms import mechanisms, named_coupling
from eddi.mdof.model import MdofModel
from eddi.mdof.physical import identify_lumped
from eddi.mdof.validate import validate_mdof
from simulated_rig.mdof_systems import MdofSystem, mdof_impact_test
from tests.eddi.test_mdof_lumped import _records  # the same records (seeds 7.., 45 dB)

#: Hidden constants: 15 % of the link spring's force at the largest blow's peak stretch (4.4 mm),
#: the cubic damper 100 % of the link dashpot's at the peak stretch rate (1.15 m/s).
K2, C3, K3 = 5.07e5, 1.13, 1.15e8


def _system(**link) -> MdofSystem:
    return MdofSystem.model_validate({
        "name": "hidden", "masses_kg": [0.8, 0.3], "driving_point": 1, "record_s": 3.0,
        "impacts_n": [60.0, 150.0, 300.0],
        "elements": [{"between": [0, 1], "k": 35000.0, "c": 5.0},
                     {"between": [1, 2], "k": 15000.0, "c": 1.5, **link}]})


def _identify(**link):
    records = _records(_system(**link))
    ident = identify_lumped(records, ("acc1", "acc2"), "acc1")
    return ident, records, mechanisms(ident.lumped.constants, ident.lumped.ci95)


def test_the_rig_and_the_fit_write_the_new_elements_alike():
    truth = _system(k2=K2, c3=C3).model()
    for kind, value, part in (("k2", K2, truth.stiffness), ("c3", C3, truth.damping)):
        for i, terms in element_terms(Element(kind, 1, 2), 2).items():
            for text, fac in terms.items():
                assert part[i][text] == pytest.approx(value * fac, rel=1e-12)
    assert element_terms(Element("k2", 1, 2), 2)[0] == {"x1^2": 1.0, "x1*x2": -2.0, "x2^2": 1.0}
    assert element_terms(Element("c3", 1, 2), 2)[1] == {"v1^3": -1.0, "v1^2*v2": 3.0, "v1*v2^2": -3.0, "v2^3": 1.0}


def test_a_hidden_quadratic_spring_between_masses_is_named_within_its_interval():
    ident, _records_, found = _identify(k2=K2)
    k2 = ident.lumped.constants[Element("k2", 1, 2)]
    half = ident.lumped.ci95[Element("k2", 1, 2)]
    assert abs(k2 - K2) <= half and half < 0.1 * K2
    assert named_coupling(found) == "quadratic spring between masses 1-2"
    assert "quadratic spring between masses 1-2 (k2 = " in ident.model.notes
    # the model JSON (the same schema, no new field) loads back, predicts every channel of a
    # held-out blow (200 N, not trained on) and drives the rig like the truth
    loaded = MdofModel.from_json(ident.model.to_json())
    system = _system(k2=K2)
    held = _records(system.model_copy(update={"impacts_n": (200.0,)}))[0]
    assert max(validate_mdof(loaded, held).channel_nrmse.values()) < 0.05
    truth = mdof_impact_test(system, 200.0, snr_db=None).truth_a
    rig = mdof_impact_test(system, 200.0, snr_db=None, model=loaded).truth_a
    assert np.sqrt(np.mean((rig - truth) ** 2)) < 0.05 * np.sqrt(np.mean(truth**2))


def test_a_hidden_cubic_damper_between_masses_is_named_within_5_percent():
    ident, _records_, found = _identify(c3=C3)
    assert ident.lumped.constants[Element("c3", 1, 2)] == pytest.approx(C3, rel=0.05)
    assert named_coupling(found) == "cubic damper between masses 1-2"
    assert ident.model.damping[0]["v1^2*v2"] == pytest.approx(-3 * C3, rel=0.05)


@pytest.mark.parametrize("link, name", [({}, ""), ({"k3": K3}, "cubic spring between masses 1-2")])
def test_nulls_keep_their_names(link, name):
    ident, _records_, found = _identify(**link)
    assert named_coupling(found) == name
    assert not [m for m in found if m.kind in ("k2", "c3") and m.determined]
