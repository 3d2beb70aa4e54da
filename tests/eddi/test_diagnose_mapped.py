"""eddi.diagnosis.diagnose: the work that needs only the judged baseline runs in the mapper."""

from __future__ import annotations

import pytest

import eddi.diagnosis.loop as loop
from eddi.diagnosis import diagnose
from tests.eddi.diagnose_cases import DAMPING, STIFFNESS, rig_records


def test_symptoms_are_computed_inside_the_mapper_with_the_same_result(monkeypatch: pytest.MonkeyPatch) -> None:
    """The baseline's symptoms (held-out simulations compared cycle by cycle: ~0.13 s of CPU on
    the double beam) are an item of the candidates' map, not work done in turn after it; the
    diagnosis is the same as with the plain loop."""
    recs = rig_records(3, effects=[{"name": "coulomb_friction", "params": {"force_n": 0.006}}], record_s=1.5)
    kw = dict(damping=DAMPING, stiffness=STIFFNESS)
    plain = diagnose(recs, 0.1, **kw)
    depth = [0]
    where: list[bool] = []
    real = loop.baseline_symptoms

    def recorded(*args, **kwargs):  # type: ignore[no-untyped-def]
        where.append(depth[0] > 0)
        return real(*args, **kwargs)

    def mapper(fn, items):  # type: ignore[no-untyped-def]
        depth[0] += 1
        try:
            return [fn(x) for x in items]
        finally:
            depth[0] -= 1

    monkeypatch.setattr(loop, "baseline_symptoms", recorded)
    mapped = diagnose(recs, 0.1, mapper=mapper, **kw)
    assert where == [True]
    assert mapped.symptoms == plain.symptoms and len(plain.symptoms) >= 3
    assert mapped.cause == plain.cause and mapped.verdict == plain.verdict
    assert [c.fold_nrmse for c in mapped.candidates] == [c.fold_nrmse for c in plain.candidates]
