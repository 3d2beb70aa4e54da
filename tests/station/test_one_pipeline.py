"""Every command runs the same pipeline: the same capture gives the same model and held-out error.

``station demo`` records three impacts and identifies; ``identify``, ``replay``, ``report`` and
``diagnose`` (its pipeline baseline) on the demo's session file must give the same coefficients
(bit for bit: one code path) and the same held-out nrmse, and each says what it chose.
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path
from typing import Any

import pytest

from station.cli import main
from tests.station.test_demo import demo_run


def _json(argv: list[str]) -> dict[str, Any]:
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(argv + ["--json"])
    assert code == 0
    return json.loads(buf.getvalue())


def test_identify_replay_report_demo_and_diagnose_agree(tmp_path: Path) -> None:
    demo, dobj = demo_run()
    session = str(demo / "session.h5")
    ident = _json(["identify", session])
    replay = _json(["replay", session])
    report = _json(["report", session, "--out", str(tmp_path / "rep")])
    full = _json(["diagnose", session, "--mechanisms", "coulomb_friction"])
    diag = full["pipeline_baseline"]
    # diagnose's own baseline is the pipeline's: the same model and held-out error as identify
    # (the candidates are judged against the per-fold fit, reported beside it)
    assert full["baseline"]["source"] == "pipeline"
    assert full["baseline"]["model"]["stiffness"] == ident["stiffness"]
    assert full["baseline"]["model"]["damping"] == ident["damping"]
    assert full["baseline"]["nrmse"] == ident["held_out"]["nrmse"]
    assert full["judged_baseline"]["fold_nrmse"] and full["judged_baseline"]["what"]
    models = {"demo": dobj["identified"], "identify": ident, "replay": replay["identified"],
              "report": report["identified"], "diagnose": diag["identified"]}
    errors = {"demo": dobj["validation"]["nrmse"], "identify": ident["held_out"]["nrmse"],
              "replay": replay["validation"]["nrmse"], "report": report["validation"]["nrmse"],
              "diagnose": diag["validation"]["nrmse"]}
    ref = models["demo"]
    for name, m in models.items():
        assert m["stiffness"] == ref["stiffness"], name
        assert m["damping"] == ref["damping"], name
        assert errors[name] == errors["demo"], name
        # the choices are stated, the same everywhere
        assert m["pipeline"] == ref["pipeline"], name
        # and the same warnings and conditioning, the AC-coupling check included (demo, replay and
        # report did not run identify's check: no sensor_highpass_check, no coupling warning);
        # diagnose runs it once for the whole diagnosis (its own warnings, below)
        if name != "diagnose":
            assert m["warnings"] == ident["warnings"], name
            assert m["conditioning"] == ident["conditioning"], name
    assert full["sensor_highpass_check"] == ident["conditioning"]["sensor_highpass_check"]
    p = ref["pipeline"]
    assert p["refinement"] in ("kept", "rejected") and p["judged_on"] == "held-out records (2)"
    # the refinement is kept only when it lowers the held-out error
    assert (p["nrmse_refined"] <= p["nrmse_eddi"]) == (p["refinement"] == "kept")
    assert errors["demo"] == pytest.approx(min(p["nrmse_refined"], p["nrmse_eddi"]))


def test_no_refine_is_the_plain_eddi_estimate_everywhere(tmp_path: Path) -> None:
    demo, dobj = demo_run()
    session = str(demo / "session.h5")
    ident = _json(["identify", session, "--no-refine"])
    replay = _json(["replay", session, "--no-refine"])
    assert ident["pipeline"]["refinement"] == "off" and "refinement" not in ident
    assert ident["stiffness"] == replay["identified"]["stiffness"] == dobj["eddi"]["stiffness"]
    assert ident["held_out"]["nrmse"] == pytest.approx(dobj["eddi"]["validation"]["nrmse"])
