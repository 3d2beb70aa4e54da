"""eddi.diagnosis.diagnose: the work that needs only the judged baseline runs in the mapper."""

from __future__ import annotations

import json

import pytest

import eddi.diagnosis.loop as loop
from eddi.diagnosis import diagnose
from tests.eddi.diagnose_cases import DAMPING, STIFFNESS, rig_records


def test_symptoms_are_computed_inside_the_mapper(monkeypatch: pytest.MonkeyPatch) -> None:
    """The baseline's symptoms (held-out simulations compared cycle by cycle: ~0.13 s of CPU on
    the double beam) are the last item of the candidates' map, not work done in turn after it;
    the diagnosis is the same as with the plain loop (within-cycle comparisons included)."""
    recs = rig_records(3, effects=[{"name": "coulomb_friction", "params": {"force_n": 0.006}}], record_s=1.5)
    kw = dict(damping=DAMPING, stiffness=STIFFNESS)
    plain = diagnose(recs, 0.1, **kw)
    depth = [0]
    position: list[int] = [0, 0]  # the item being run and the map's item count
    where: list[tuple[bool, int, int]] = []
    real = loop.baseline_symptoms

    def recorded(*args, **kwargs):  # type: ignore[no-untyped-def]
        where.append((depth[0] > 0, position[0], position[1]))
        return real(*args, **kwargs)

    def mapper(fn, items):  # type: ignore[no-untyped-def]
        depth[0] += 1
        items = list(items)
        out = []
        try:
            for i, x in enumerate(items):
                position[:] = [i, len(items)]
                out.append(fn(x))
            return out
        finally:
            depth[0] -= 1

    monkeypatch.setattr(loop, "baseline_symptoms", recorded)
    mapped = diagnose(recs, 0.1, mapper=mapper, **kw)
    # inside the candidates' map, its last item (short: it fills a process's end)
    assert len(where) == 1 and where[0][0] and where[0][1] == where[0][2] - 1 > len(plain.parts)
    assert (json.dumps([c.within_cycle for c in mapped.candidates], sort_keys=True)  # NaN z: as text
            == json.dumps([c.within_cycle for c in plain.candidates], sort_keys=True))
    assert mapped.symptoms == plain.symptoms and len(plain.symptoms) >= 3
    assert mapped.cause == plain.cause and mapped.verdict == plain.verdict
    assert [c.fold_nrmse for c in mapped.candidates] == [c.fold_nrmse for c in plain.candidates]
