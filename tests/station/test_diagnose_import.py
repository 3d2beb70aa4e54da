"""Same captures, same verdict: read as CSV, or imported with ``station import`` to HDF5.

A CSV does not say how many rows precede the trigger (``pretrigger_samples`` None). Before
session 4 ``station import`` stored 0 for it and the HDF5 reader gave 0 back, which the
conditioning read as "no rest": another noise estimate, another window, a noise floor of
0.16 instead of 0.02 and another verdict on the same null. My own captures: a 0.2 kg, 31 Hz
softening oscillator, 3 blows, 4 kHz, 48 dB.
"""

from __future__ import annotations

import math

import h5py
import numpy as np
import pytest

from eddi.conditioning import condition
from eddi.diagnosis import diagnose
from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test
from station.cli import main
from station.commands.diagnose import load_measurements

M = 0.2
K1 = M * (2 * math.pi * 31.0) ** 2
TRUTH = EquationOfMotion.create(mass=M, damping={"v": 2 * 0.006 * math.sqrt(K1 * M)},
                                stiffness={"x": K1, "x^3": -4e7})


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("imp")
    csvs = []
    for i, f in enumerate((40.0, 50.0, 60.0)):
        r = impact_test(TRUTH, f, rate_hz=4000.0, pretrigger_s=0.15, record_s=1.5, snr_db=48.0, seed=5200 + i)
        p = d / f"hit{i + 1}.csv"
        np.savetxt(p, np.column_stack([r.t, r.force_n, r.acc_m_s2]), delimiter=",", header="t,force,acc",
                   comments="", fmt="%.10g")
        csvs.append(str(p))
    h5 = d / "session.h5"
    assert main(["import", *csvs, "--out", str(h5), "--mass", str(M)]) == 0
    return csvs, str(h5)


def test_import_keeps_an_unknown_pretrigger_unknown(files) -> None:
    csvs, h5 = files
    with h5py.File(h5, "r") as f:
        caps = f["captures"]
        attrs = caps[sorted(caps)[0]].attrs
        assert int(attrs["pretrigger_known"]) == 0 and int(attrs["pretrigger_samples"]) == 0
    _, _, m_csv, _, _ = load_measurements(csvs)
    _, _, m_h5, _, _ = load_measurements([h5])
    assert [m.pretrigger_samples for m in m_csv] == [None] * 3
    assert [m.pretrigger_samples for m in m_h5] == [None] * 3


def test_zero_pretrigger_is_looked_for_like_an_unknown_one(files) -> None:
    csvs, _ = files
    _, _, (m, *_), _, _ = load_measurements(csvs)
    a = condition(m.t, acc=m.channels["acc"], force=m.channels["force"], pretrigger_samples=None)
    b = condition(m.t, acc=m.channels["acc"], force=m.channels["force"], pretrigger_samples=0)
    assert a.impact_start > 32  # the rest before the blow is found
    assert (b.impact_start, b.free_start, b.free_stop) == (a.impact_start, a.free_start, a.free_stop)
    assert b.noise_rms == a.noise_rms


def test_same_floor_and_verdict_from_csv_and_from_hdf5(files) -> None:
    csvs, h5 = files
    out = []
    for spec in (csvs, [h5]):
        recs, _, _, _, _ = load_measurements(spec)
        out.append(diagnose(recs, M, mechanisms=["coulomb_friction", "clearance"]))
    a, b = out
    assert a.noise_floor.nrmse == pytest.approx(b.noise_floor.nrmse, rel=1e-3)
    assert a.judging.nrmse == pytest.approx(b.judging.nrmse, rel=1e-3)
    assert a.cause == b.cause == "none", (a.verdict, b.verdict)
