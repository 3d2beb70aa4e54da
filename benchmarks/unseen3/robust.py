"""Bad inputs (e): each must end in exactly one line on stderr and exit 2, never a traceback, and
must not change any file it was pointed at (``protect``: SHA-256 before and after).

Files are written by ``make_files``; the truncated HDF5 files are made by ``score.py`` at run time
(``setup: "h5"``) from a good capture imported with ``station import``, since this generator
writes no HDF5 itself.
"""

from __future__ import annotations

import json
import os

import numpy as np

import records
import sensors
from design import amp, w, write


def make_files(out, rng):
    """A good 1-DOF record, a good two-sensor record, and damaged copies; model JSONs of wrong types."""
    m, f_hz = 0.7, 40.0
    a = amp(m, f_hz, 50.0, 1e-3)
    system = records.sdof(m, k=m * w(f_hz) ** 2, k3=0.1 * m * w(f_hz) ** 2 / a ** 2, c=2 * 0.006 * m * w(f_hz))
    cols, _ = records.impact_record(system, 50.0, 1e-3, 5000, 1.2, rng=rng, chains=[sensors.Chain()])
    cols = records.name_columns(cols, {("acc", 0): "acc"})
    write(out, "bad-good.csv", cols, 5000, digits=6)
    n = len(cols["acc"])
    nan_f = dict(cols, force=np.where(np.arange(n) == n // 2, np.nan, cols["force"]))
    write(out, "bad-nan-force-mid.csv", nan_f, 5000, digits=6)
    nan_a = dict(cols, acc=np.where(np.arange(n) == n // 3, np.nan, cols["acc"]))
    write(out, "bad-nan-acc-mid.csv", nan_a, 5000, digits=6)
    two = dict(cols, acc1=cols["acc"], acc2=np.where(np.arange(n) == n // 2, np.nan, 0.5 * cols["acc"]))
    two.pop("acc")
    write(out, "bad-nan-acc2-mid.csv", two, 5000, digits=6, order=["t", "force", "acc1", "acc2"])
    with open(os.path.join(out, "bad-good.csv")) as fh:
        lines = fh.read().splitlines()
    lines[len(lines) // 2] = lines[len(lines) // 2].split(",")[0] + ",," + lines[len(lines) // 2].split(",")[2]
    with open(os.path.join(out, "bad-empty-field.csv"), "w") as fh:
        fh.write("\n".join(lines) + "\n")
    good = {"schema_version": 1, "mass": m, "damping": {"v": 2 * 0.006 * m * w(f_hz)},
            "stiffness": {"x": m * w(f_hz) ** 2}}
    wrong = {
        "mass-string": dict(good, mass="0.7"),
        "mass-list": dict(good, mass=[0.7]),
        "damping-list": dict(good, damping=[1.0, 2.0]),
        "coef-string": dict(good, stiffness={"x": "4.4e4"}),
        "coef-null": dict(good, stiffness={"x": None}),
        "term-number": dict(good, stiffness={"7": 1.0}),
        "schema-99": dict(good, schema_version=99),
        "top-array": [good],
        "mdof-mass-scalar": {"kind": "mdof", "schema_version": 2, "coordinates": "physical", "mass": 1.0,
                             "input": [1.0], "damping": [{"v1": 1.0}], "stiffness": [{"x1": 1e4}],
                             "channels": ["acc1"], "shapes": [[1.0]]},
        "mdof-shapes-wrong": {"kind": "mdof", "schema_version": 2, "coordinates": "physical", "mass": [1.0, 1.0],
                              "input": [1.0, 0.0], "damping": [{"v1": 1.0}, {"v2": 1.0}],
                              "stiffness": [{"x1": 1e4}, {"x2": 1e4}], "channels": ["acc1", "acc2"],
                              "shapes": [[1.0, 0.0, 3.0]]},
    }
    for name, model in wrong.items():
        with open(os.path.join(out, f"bad-model-{name}.json"), "w") as fh:
            json.dump(model, fh)
    with open(os.path.join(out, "bad-model-good.json"), "w") as fh:
        json.dump(good, fh)


def cases():
    """Each: id, argv (run in the data folder), optional setup and files to protect."""
    c = []
    add = c.append
    add({"id": "h5-truncated-half", "setup": "h5:0.5", "argv": ["identify", "bad-trunc-0.5.h5", "--json"]})
    add({"id": "h5-truncated-tail", "setup": "h5:-700", "argv": ["identify", "bad-trunc--700.h5", "--json"]})
    add({"id": "h5-truncated-validate", "setup": "h5:0.5",
         "argv": ["validate", "bad-model-good.json", "bad-trunc-0.5.h5", "--json"]})
    add({"id": "h5-truncated-diagnose", "setup": "h5:0.5", "argv": ["diagnose", "bad-trunc-0.5.h5", "--json"]})
    add({"id": "h5-truncated-replay", "setup": "h5:-700", "argv": ["replay", "bad-trunc--700.h5", "--json"]})
    add({"id": "csv-nan-force-mid", "argv": ["identify", "bad-nan-force-mid.csv", "--mass", "0.7"]})
    add({"id": "csv-nan-acc-mid-diagnose", "argv": ["diagnose", "bad-nan-acc-mid.csv", "bad-good.csv",
                                                     "--mass", "0.7"]})
    add({"id": "csv-nan-acc2-mid", "argv": ["diagnose", "bad-nan-acc2-mid.csv", "bad-nan-acc2-mid.csv"]})
    add({"id": "csv-empty-field", "argv": ["identify", "bad-empty-field.csv", "--mass", "0.7"]})
    add({"id": "csv-nan-import", "argv": ["import", "bad-nan-force-mid.csv", "--out", "_bad-nan.h5"]})
    for name in ("mass-string", "mass-list", "damping-list", "coef-string", "coef-null", "term-number",
                 "schema-99", "top-array", "mdof-mass-scalar", "mdof-shapes-wrong"):
        add({"id": f"model-{name}", "argv": ["validate", f"bad-model-{name}.json", "bad-good.csv"]})
    add({"id": "model-wrong-types-diagnose", "argv": ["diagnose", "bad-good.csv", "--model",
                                                       "bad-model-coef-string.json"]})
    add({"id": "out-eq-in-import", "argv": ["import", "bad-good.csv", "--out", "bad-good.csv", "--mass", "0.7"],
         "protect": ["bad-good.csv"]})
    add({"id": "out-eq-in-save-model", "argv": ["diagnose", "bad-good.csv", "--mass", "0.7", "--save-model",
                                                 "bad-good.csv"], "protect": ["bad-good.csv"]})
    add({"id": "out-eq-model-save", "argv": ["diagnose", "bad-good.csv", "--model", "bad-model-good.json",
                                              "--save-model", "bad-model-good.json"],
         "protect": ["bad-model-good.json"]})
    add({"id": "out-report-over-input", "argv": ["report", "bad-good.csv", "--out", "bad-good.csv", "--mass", "0.7"],
         "protect": ["bad-good.csv"]})
    add({"id": "out-unwritable-import", "argv": ["import", "bad-good.csv", "--out", "/proc/unseen3/x.h5",
                                                 "--mass", "0.7"]})
    add({"id": "out-unwritable-report", "argv": ["report", "bad-good.csv", "--out", "/proc/unseen3-rep",
                                                 "--mass", "0.7"]})
    add({"id": "out-unwritable-model", "argv": ["diagnose", "bad-good.csv", "--mass", "0.7", "--save-model",
                                                "/proc/unseen3/m.json"]})
    add({"id": "out-under-a-file", "argv": ["import", "bad-good.csv", "--out", "bad-good.csv/sub/x.h5",
                                            "--mass", "0.7"], "protect": ["bad-good.csv"]})
    add({"id": "out-report-under-a-file", "argv": ["diagnose", "bad-good.csv", "--mass", "0.7", "--report",
                                                   "bad-good.csv/rep"], "protect": ["bad-good.csv"]})
    return c
