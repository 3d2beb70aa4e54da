"""The mechanisms' regressors kept across folds (``Fitter.columns``, ``extend._extra``).

The folds of a diagnosis share most training rows and search the same grid of shapes, so a
mechanism fitted by equation error (the hysteresis, the hidden second mode) computed the same
block for every fold. They are kept by mechanism, record, shape, terms and rows: the fits are
the same bit for bit, with fewer blocks computed (docs/performance.md, session 15).
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.conditioning import condition
from eddi.diagnosis import Record
from eddi.diagnosis import extend
from eddi.diagnosis.catalogue import catalogue
from eddi.diagnosis.extend import Setup
from eddi.diagnosis.fitter import Fitter
from eddi.diagnosis.records import split
from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test

SYSTEM = EquationOfMotion.create(mass=0.1, damping={"v": 0.06}, stiffness={"x": 600.0, "x^3": 2e7})


def _records() -> list[Record]:
    out = []
    for i, f in enumerate((20.0, 25.0, 30.0)):
        r = impact_test(SYSTEM, f, rate_hz=4000.0, pretrigger_s=0.2, record_s=1.0, snr_db=40.0, seed=i)
        c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
        out.append(Record.from_conditioned(c, label=f"c{i}", pretrigger_samples=r.pretrigger_samples))
    return out


@pytest.mark.parametrize("name", ["hysteresis", "second_mode"])
def test_folds_share_blocks_and_fit_the_same(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    recs = _records()
    setup = Setup(mass=0.1, damping=("v",), stiffness=("x", "x^3"), base=None,
                  coordinate="displacement [m]", fit="equation-error")
    mech = next(m for m in catalogue() if m.name == name)
    _, _, fold_masks = split(recs, 3)
    calls = []
    real = type(mech).masked_columns

    def counted(self, sig, shape, stiffness, mask):  # type: ignore[no-untyped-def]
        calls.append(1)
        return real(self, sig, shape, stiffness, mask)

    monkeypatch.setattr(type(mech), "masked_columns", counted)
    fits, counts = [], []
    for keep in (False, True):
        fitter = Fitter([r.signal() for r in recs], setup)
        if not keep:
            fitter.columns = None  # type: ignore[assignment] # every block computed (as before)
        got, per_fold = [], []
        for masks in [*fold_masks, fold_masks[0]]:  # the last: a fold seen before (all its blocks kept)
            calls.clear()
            ff = fitter(masks)
            got.append(ff(mech, ff(None)))
            per_fold.append(len(calls))
        fits.append(got)
        counts.append(per_fold)
    plain, kept = fits
    assert all(a is not None and a.mech is not None for a in plain)
    for a, b in zip(plain, kept):
        assert a.eom.model_dump() == b.eom.model_dump()  # every coefficient and parameter bit for bit
        assert a.mech.params == b.mech.params
    # the first fold computes its blocks (once: the best shape's are asked for again at the end)
    assert 0 < counts[1][0] < counts[0][0]
    assert sum(counts[1][1:-1]) < sum(counts[0][1:-1])  # the next ones reuse the first's
    assert counts[1][-1] == 0 < counts[0][-1]  # the fold seen before computes none


def test_the_kept_blocks_are_bounded() -> None:
    cache: dict = {}
    recs = _records()
    setup = Setup(mass=0.1, damping=("v",), stiffness=("x", "x^3"), base=None,
                  coordinate="displacement [m]", fit="equation-error")
    mech = next(m for m in catalogue() if m.name == "hysteresis")
    sigs = [r.signal() for r in recs]
    masks = [np.ones(r.t.size, bool) for r in recs]
    old = extend.COLUMN_BLOCKS
    try:
        extend.COLUMN_BLOCKS = 5
        for k in range(4):  # 4 shapes x 3 records: the oldest dropped beyond 5
            extend._extra(mech, {"yield_displacement_m": 1e-4 * (k + 1), "exponent": 2.0}, sigs, masks, setup, cache)
    finally:
        extend.COLUMN_BLOCKS = old
    assert len(cache) == 5
    assert [key[2][1][1] for key in cache][-1] == pytest.approx(4e-4)  # the newest kept
