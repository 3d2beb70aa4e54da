"""``station diagnose`` on multi-channel captures names the mechanism of a lumped coupling.

The diagnosis object gets ``mechanisms`` (every nonlinear element of the lumped model: words,
value, unit, ci95, determined) and ``mechanism`` (the determined couplings between masses in
words, only under ``modal_coupling``); the printout says it under the cause. Session 13: before,
the verdict said ``modal_coupling`` with monomials only (``x1^2*x2`` ...), never which element.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from eddi.mdof.lumped import Element, LumpedFit
from station.mdof_mechanism import add_mechanisms, mechanism_lines


def _final(consts: dict, ci: dict) -> SimpleNamespace:
    fit = LumpedFit(np.array([1.0, 0.5]), consts, ci, np.zeros(2))
    return SimpleNamespace(lumped=fit)


def test_a_quadratic_spring_and_a_cubic_damper_between_masses_are_named():
    consts = {Element("k", 0, 1): 3.5e4, Element("k2", 1, 2): 5.1e5, Element("c3", 1, 2): 1.1,
              Element("k3", 0, 1): 2.0e9}
    ci = {Element("k", 0, 1): 40.0, Element("k2", 1, 2): 2.3e4, Element("c3", 1, 2): 2.0, Element("k3", 0, 1): 1e8}
    obj = {"cause": "modal_coupling"}
    add_mechanisms(obj, _final(consts, ci))
    assert obj["mechanism"] == "quadratic spring between masses 1-2"  # the damper's interval holds zero
    assert [m["name"] for m in obj["mechanisms"]] == ["cubic damper between masses 1-2",
                                                      "quadratic spring between masses 1-2",
                                                      "cubic spring from mass 1 to the ground"]
    assert [m["determined"] for m in obj["mechanisms"]] == [False, True, True]
    lines = mechanism_lines(obj)
    assert lines[0] == "Mechanism: quadratic spring between masses 1-2"
    assert "  quadratic spring between masses 1-2: k2 = 5.1e+05 +- 2.3e+04 N/m^2" in lines
    assert "  cubic damper between masses 1-2: c3 = 1.1 +- 2 N s^3/m^3 (not determined: its 95 % interval holds zero)" in lines


def test_no_mechanism_named_without_modal_coupling_or_a_lumped_model():
    obj = {"cause": "none"}
    add_mechanisms(obj, _final({Element("k3", 1, 2): 1e9}, {Element("k3", 1, 2): 1e7}))
    assert obj["mechanism"] is None and obj["mechanisms"][0]["name"] == "cubic spring between masses 1-2"
    obj = {"cause": "modal_coupling"}
    add_mechanisms(obj, SimpleNamespace(lumped=None))  # modal coordinates: no elements
    assert obj == {"cause": "modal_coupling", "mechanisms": [], "mechanism": None} and mechanism_lines(obj) == []
