"""Sessions stream their records: never all in memory, the same result as with all read at once."""

from __future__ import annotations

import gc
import weakref
from pathlib import Path

import numpy as np
import pytest

from simulated_rig.bench import impact_test
from station.errors import InputFileError
from station.readers import read_measurement
from station.records import Records
from station.session import read_all, run_session

FORCES = (40.0, 80.0, 120.0, 160.0, 60.0)


@pytest.fixture(scope="module")
def csvs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    d = tmp_path_factory.mktemp("records")
    paths = []
    for i, force in enumerate(FORCES):
        r = impact_test("paper-duffing", force, rate_hz=5000.0, pretrigger_s=0.1, record_s=1.5, seed=10 + i)
        p = d / f"r{i}.csv"
        np.savetxt(p, np.column_stack((r.t, r.force_n, r.acc_m_s2)), delimiter=",", header="t,force,acc",
                   comments="", fmt="%.10g")
        paths.append(p)
    return paths


def test_a_session_holds_at_most_two_records_and_matches_the_all_at_once_run(csvs: list[Path]) -> None:
    alive: list[weakref.ref] = []
    most = 0

    def counting_read(spec: str):  # type: ignore[no-untyped-def]
        nonlocal most
        gc.collect()
        alive[:] = [w for w in alive if w() is not None]
        meas = read_measurement(spec)
        alive.append(weakref.ref(meas))
        most = max(most, len(alive))
        return meas

    recs = Records([str(p) for p in csvs], read=counting_read)
    assert most == 1  # the check at construction reads them one at a time
    assert recs.sources == tuple(str(p) for p in csvs)
    streamed = run_session(recs, 1.0, damping="v", stiffness="x,x^3", refine=False)
    assert most <= 2, most  # the fit record, and one held-out record at a time
    eager = run_session(tuple(read_all([str(p) for p in csvs])), 1.0, damping="v", stiffness="x,x^3", refine=False)
    assert streamed.fit_index == eager.fit_index == FORCES.index(80.0)  # the median peak force
    assert streamed.fit.model.eom.stiffness == eager.fit.model.eom.stiffness
    assert [c.nrmse for c in streamed.held_out] == [c.nrmse for c in eager.held_out]
    assert [c.peak_force_n for c in streamed.held_out] == [c.peak_force_n for c in eager.held_out]
    assert streamed.sources == eager.sources


def test_a_bad_record_is_refused_before_any_identification(csvs: list[Path], tmp_path: Path) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("t,acc\n0,1\n0.001,x\n")
    with pytest.raises(InputFileError, match="bad.csv"):
        read_all([str(csvs[0]), str(bad)])


def test_a_session_given_its_records_conditioned_gives_the_same_result(csvs: list[Path]) -> None:
    from station.errors import ConfigError
    from station.session import condition_measurement

    meas = tuple(read_all([str(p) for p in csvs]))
    conds = [condition_measurement(m) for m in meas]
    given = run_session(meas, 1.0, damping="v", stiffness="x,x^3", refine=False, conditioned=conds)
    own = run_session(meas, 1.0, damping="v", stiffness="x,x^3", refine=False)
    assert given.fit_index == own.fit_index
    assert given.fit.model.eom.stiffness == own.fit.model.eom.stiffness
    assert [c.nrmse for c in given.held_out] == [c.nrmse for c in own.held_out]
    with pytest.raises(ConfigError, match="4 conditioned records for 5"):
        run_session(meas, 1.0, damping="v", stiffness="x,x^3", refine=False, conditioned=conds[:4])
