"""Session 19 (s19ident): the numbers-change protocol's tolerance, on a few records.

``benchmarks/bench_identify_protocol.py`` compares two trees on 64 records: every coefficient's
change in units of its ci95 (aim <= 0.1), the term-selection decisions and warnings identical,
the printed nrmse within 1 %. Here its comparison is checked on made-up outputs (it must see a
moved coefficient, a changed decision, a moved nrmse) and applied to three records identified
with this tree's Levenberg-Marquardt (``eddi.lsq``: since session 19 ``R`` and ``Q'f`` from one
``mode="r"`` factorisation) against scipy's MINPACK (``EDDI_LSQ=scipy``, a column-pivoted QR):
the optimum must agree to the protocol's tolerance.
"""

from __future__ import annotations

import copy
import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _protocol():
    spec = importlib.util.spec_from_file_location("bench_identify_protocol",
                                                  ROOT / "benchmarks" / "bench_identify_protocol.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _identify(rec: dict) -> dict:
    from station.commands.identify import result_object, run_identify
    from station.readers import Measurement

    meas = Measurement(t=rec["t"], channels={"force": rec["force"], "acc": rec["acc"]}, rate_hz=rec["rate"],
                       pretrigger_samples=rec["pre"], mass=rec["mass"], source="memory")
    return result_object(meas, run_identify(meas, rec["mass"], rec["damping"], rec["stiffness"]))


def test_the_comparison_sees_what_it_must():
    proto = _protocol()
    rec = proto.make_record(dict(kind="gen", system="nl_damping", rate=4000.0, snr=45.0, seed=7))
    a = _identify(rec)
    same = proto.compare(a, copy.deepcopy(a))
    assert same["same_decisions"] and same["same_text"] and same["max_z"] == 0.0 and same["nrmse_rel"] == 0.0
    moved = copy.deepcopy(a)
    term = next(iter(moved["stiffness"]))
    moved["stiffness"][term] += 0.2 * moved["ci95"]["stiffness"][term]
    assert proto.compare(a, moved)["max_z"] == pytest.approx(0.2, rel=1e-6)
    worse = copy.deepcopy(a)
    worse["validation"]["nrmse"] *= 1.05
    assert proto.compare(a, worse)["nrmse_rel"] == pytest.approx(0.05, rel=1e-6)
    warned = copy.deepcopy(a)
    warned["warnings"] = [*warned["warnings"], "a new warning"]
    assert not proto.compare(a, warned)["same_decisions"]
    dropped = copy.deepcopy(a)
    dropped["stiffness"].pop(term)
    assert not proto.compare(a, dropped)["same_decisions"]
    figure = copy.deepcopy(a)
    figure["warnings"] = [*a["warnings"], "x 1.5"]
    a2 = copy.deepcopy(a)
    a2["warnings"] = [*a["warnings"], "x 1.6"]
    c = proto.compare(a2, figure)
    assert c["same_decisions"] and not c["same_text"]  # a quoted figure moved: counted apart


@pytest.mark.parametrize("spec", [
    dict(kind="gen", system="nl_damping", rate=4000.0, snr=45.0, seed=11),
    dict(kind="gen", system="coulomb", rate=5000.0, snr=40.0, seed=12),
    dict(kind="gen", system="heavy_asym", rate=2000.0, snr=60.0, seed=13),
])
def test_this_lsq_meets_the_protocol_against_minpack(spec, monkeypatch):
    proto = _protocol()
    rec = proto.make_record(spec)
    ours = _identify(rec)
    monkeypatch.setenv("EDDI_LSQ", "scipy")
    minpack = _identify(rec)
    c = proto.compare(minpack, ours)
    assert c["same_decisions"], (proto.decisions(minpack), proto.decisions(ours))
    assert c["max_z"] <= 0.1, c
    assert c["nrmse_rel"] <= 0.01, c
