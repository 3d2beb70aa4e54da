"""``station identify`` checks the hammer impulse against the momentum the response shows.

A response in g under an m/s^2 label, or an accelerometer mounted upside down, is invisible to
the free decay's fit (the linear coefficients do not depend on scale or sign; a cubic spring
absorbs g^2) and to a validation driven by the force fused with ``m a``: found by the blind
unseen7 set (session 11), a cubic coefficient 96x off with held-out nrmse 0.010 and no warning.
The check names the fault (JSON ``conditioning.impulse_check.fault`` and a warning) and stays
silent on a clean record; the same check runs in the campaign (one answer from every command).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from station.cli import main
from station.impulse_check import G, classify
from tests.eddi.impact_cases import SYSTEMS, impact_record


def _csv(tmp_path: Path, name: str, scale: float, system: str = "nl_damping", seed: int = 3) -> Path:
    r = impact_record(system, snr_db=45.0, seed=seed)
    p = tmp_path / f"{name}.csv"
    np.savetxt(p, np.column_stack((r.t, r.force, scale * r.acc)), delimiter=",", header="t,force,acc",
               comments="", fmt="%.9g")
    return p


def _identify(path: Path, mass: float, capsys: pytest.CaptureFixture[str]) -> dict:
    code = main(["identify", str(path), "--mass", str(mass), "--json"])
    out, err = capsys.readouterr()
    assert code in (0, 1), err
    return json.loads(out)


@pytest.mark.parametrize(("scale", "fault", "words"), [(1 / G, "g_as_si", "in g"), (-1.0, "sign", "upside down")])
def test_a_slipped_response_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str], scale: float,
                                     fault: str, words: str) -> None:
    obj = _identify(_csv(tmp_path, fault, scale), SYSTEMS["nl_damping"]["mass"], capsys)
    chk = obj["conditioning"]["impulse_check"]
    assert chk["fault"] == fault
    assert abs(chk["impulse_momentum_ratio"]) == pytest.approx(G if fault == "g_as_si" else 1.0, rel=0.02)
    assert any(words in w for w in obj["warnings"])
    # the force-driven misfit is the slip's: no AC-coupling claim on top
    assert not any("AC-coupled" in w for w in obj["warnings"])


def test_a_clean_record_is_silent_and_a_mass_error_is_said(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _csv(tmp_path, "clean", 1.0, "paper_do", 4)
    obj = _identify(path, SYSTEMS["paper_do"]["mass"], capsys)
    chk = obj["conditioning"]["impulse_check"]
    assert chk["fault"] is None and chk["impulse_momentum_ratio"] == pytest.approx(1.0, abs=0.01)
    assert not any("hammer impulse" in w for w in obj["warnings"])
    obj = _identify(path, 0.93 * SYSTEMS["paper_do"]["mass"], capsys)
    assert obj["conditioning"]["impulse_check"]["fault"] == "scale"
    assert any("gives a mass of 0.81" in w for w in obj["warnings"])


def test_classify() -> None:
    assert classify(1.01) == "" and classify(0.975) == "" and classify(1.03) == ""
    assert classify(1.04) == "scale" and classify(0.9) == "scale"
    assert classify(9.6) == "g_as_si" and classify(1 / 9.9) == "si_as_g"
    assert classify(-0.3) == "sign"


def test_validate_says_it_too(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``station validate`` checks the impulse at the model's mass: a right model on a record in g
    gets the same warning identify gives, and a clean record none."""
    clean = _csv(tmp_path, "clean", 1.0, "paper_do", 4)
    model = tmp_path / "model.json"
    model.write_text(json.dumps(_identify(clean, SYSTEMS["paper_do"]["mass"], capsys)["model"]))
    code = main(["validate", str(model), str(clean), str(_csv(tmp_path, "in_g", 1 / G, "paper_do", 4)), "--json"])
    obj = json.loads(capsys.readouterr().out)
    assert code == 0
    ok, in_g = obj["records"]
    assert not any("hammer impulse" in w for w in ok["warnings"])
    assert any("recorded in g under an SI" in w for w in in_g["warnings"])
