"""The ``sensor_highpass`` corner search serves corner 0 (the records as conditioned) from the
diagnosis' own fitter: no second fitter of the same records, and the same diagnosis bit for bit
(session 11b, issue 13: one of the ~8 corner fits of the search, ~1/8 of its CPU)."""

from __future__ import annotations

import json

import eddi.diagnosis.highpass as hp
import eddi.diagnosis.loop as loop
from eddi.diagnosis import diagnose
from tests.eddi.diagnose_cases import SYSTEM, rig_records


def test_corner_zero_reuses_the_diagnosis_fitter_and_changes_nothing(monkeypatch) -> None:
    recs = rig_records(3, highpass_hz=0.5)
    built: list[float] = []
    fitter = hp._CornerSearch.fitter

    def counting(self, fc):  # type: ignore[no-untyped-def]
        if fc not in self.fitters and fc not in self.variants:
            built.append(fc)
        return fitter(self, fc)

    monkeypatch.setattr(hp._CornerSearch, "fitter", counting)
    got = diagnose(recs, SYSTEM.mass, mechanisms=["sensor_highpass"])
    cand = next(c for c in got.candidates if c.name == "sensor_highpass")
    assert not cand.skipped and cand.params["corner_hz"] > 0
    assert built and 0.0 not in built  # corner 0 came from the diagnosis' fitter
    # without the diagnosis' fitter: a fitter of its own for corner 0, the same answer
    built.clear()
    plain = hp.sensor_highpass
    monkeypatch.setattr(loop, "sensor_highpass", lambda *a, base=None, **k: plain(*a, **k))
    ref = diagnose(recs, SYSTEM.mass, mechanisms=["sensor_highpass"])
    assert 0.0 in built
    assert json.dumps(got.to_dict(), sort_keys=True) == json.dumps(ref.to_dict(), sort_keys=True)
