"""Input handling and the first run of the thirteenth scorecard.

Bad inputs (``make``): each must end in one line on stderr and a non-zero exit (2), no traceback, the inputs
untouched; ``check_coef`` with ``expect_rc`` 0: a layout docs/capture-format.md documents, which must be read
and give the SI file's stiffness within the tolerance. Entries as unseen11's (``argv``, ``protect``, optional
``setup`` and ``truncate``). The kinds are new against unseen2-12: a run of NaN in the response (a cable
unplugged for a moment), a response channel missing, a header with no rows, an HDF5 session cut short, another
tool's HDF5 layout with groups per channel, an output path onto an input (import, diagnose --save-model, export
--uff onto its session, --sep005 onto a CSV capture), a multi-channel capture missing one accelerometer
validated against the model of all its channels, a comma delimiter with decimal commas, and two layouts
the docs say are read: a semicolon / decimal-comma export in ms, kN and g (units in brackets) and a binary UFF58
with the response in g.

The first run (``first``): ``station --help`` and ``station demo --out DIR`` exit 0; the demo writes its
session, model and report (docs/demo.md).
"""

from __future__ import annotations

import os

import numpy as np

G = 9.80665


def _good(rng):
    """A good record (t, force, acc) in SI: a 0.2-3 kg linear oscillator struck by a half-cosine."""
    fs = float(rng.choice([2000, 2048, 4096, 5000]))
    fn = rng.uniform(10, 50)
    m = rng.uniform(0.2, 3.0)
    w = 2 * np.pi * fn
    X = 1e-3
    t = np.arange(-int(0.05 * fs), int(40 / fn * fs)) / fs
    z = 0.01
    wd = w * np.sqrt(1 - z * z)
    acc = np.where(t > 0, X * np.exp(-z * w * t) * ((z * w) ** 2 * np.sin(wd * t) - 2 * z * w * wd * np.cos(wd * t)
                                                    - wd * wd * np.sin(wd * t)), 0.0)
    width = 6.0 / fs
    force = np.where((t > -width / 2) & (t < width / 2), np.cos(np.pi * t / width), 0.0)
    force = force * m * wd * X * np.pi / (2 * width)
    acc = acc + force / m
    acc = acc + rng.normal(0, 1e-3 * np.abs(acc).max(), len(t))
    return t, force, acc, m, fs, m * w * w


def _csv(path, header, rows, fmt="{:.9g}", delim=",", comma=False):
    with open(path, "w", newline="", encoding="utf-8") as fh:
        fh.write(header + "\n")
        for r in rows:
            vals = [fmt.format(v) for v in r]
            fh.write(delim.join(v.replace(".", ",") for v in vals) if comma else delim.join(vals))
            fh.write("\n")


def make(rng, out, quick, mdof=()):
    t, f, a, m, fs, k = _good(rng)
    rows = np.column_stack([t, f, a])
    mass = f"{m:.6g}"
    M = ["--mass", mass]
    P = lambda name: os.path.join(out, name)  # noqa: E731
    _csv(P("bad-good.csv"), "t,force,acc", rows)
    cases = []

    def add(cid, argv, protect=(), full_only=False, **kw):
        if quick and full_only:
            return
        cases.append({"id": cid, "argv": argv, "protect": list(protect), "tolerant": False, **kw})

    # a run of NaN in the response: the cable unplugged for 20-60 ms in the ring-down
    a_nan = a.copy()
    start = int(np.searchsorted(t, 0.0)) + int(rng.uniform(0.1, 0.4) * (len(t) - np.searchsorted(t, 0.0)))
    a_nan[start:start + int(rng.uniform(0.02, 0.06) * fs)] = np.nan
    _csv(P("bad-nanrun.csv"), "t,force,acc", np.column_stack([t, f, a_nan]))
    add("nan-run", ["identify", "bad-nanrun.csv", *M, "--json"], ["bad-nanrun.csv"])
    # the response channel missing: only the hammer was plugged in
    _csv(P("bad-forceonly.csv"), "Time [s],Force [N]", np.column_stack([t, f]))
    add("response-missing", ["identify", "bad-forceonly.csv", *M], ["bad-forceonly.csv"])
    # a header and no rows (the logger stopped before the trigger)
    with open(P("bad-headeronly.csv"), "w") as fh:
        fh.write("t,force,acc\n")
    add("header-only", ["diagnose", "bad-headeronly.csv", "bad-good.csv", *M], ["bad-headeronly.csv", "bad-good.csv"])
    # an HDF5 session cut short (copied while a save was running): the scorer imports, then truncates a copy
    add("truncated-h5", ["identify", "bad-cut.h5:0", *M], ["bad-good.csv"],
        setup=[["import", "bad-good.csv", "--out", "bad-whole.h5", *M]], truncate=["bad-whole.h5", "bad-cut.h5",
                                                                                  float(rng.uniform(0.3, 0.7))])
    # another tool's HDF5: one group per channel with its data and units (not the station's layout)
    import h5py
    with h5py.File(P("bad-foreign.h5"), "w") as h:
        h.attrs["creator"] = "DAQ Express 4.2"
        h.attrs["sample_rate"] = fs
        for name, y, unit in (("Force", f, "N"), ("Accel", a, "m/s^2")):
            g = h.create_group(f"Channel_{name}")
            g.create_dataset("data", data=y)
            g.attrs["unit"] = unit
            g.attrs["dt"] = 1.0 / fs
    add("foreign-h5", ["identify", "bad-foreign.h5", *M], ["bad-foreign.h5"])
    # an output path onto an input: the capture must survive
    add("import-onto-input", ["import", "bad-good.csv", "--out", "bad-good.csv", *M], ["bad-good.csv"])
    _csv(P("bad-second.csv"), "t,force,acc", np.column_stack([t, 0.7 * f, 0.7 * a]))
    add("save-model-onto-input", ["diagnose", "bad-good.csv", "bad-second.csv", *M, "--save-model", "bad-second.csv"],
        ["bad-good.csv", "bad-second.csv"])
    # a documented layout: semicolons, decimal commas, ms, kN and g, the units in brackets
    _csv(P("bad-eu.csv"), "Time [ms];Force [kN];Acceleration [g]",
         np.column_stack([t * 1e3, f / 1e3, a / G]), delim=";", comma=True)
    add("eu-export-read", ["identify", "bad-eu.csv", *M, "--damping", "v", "--stiffness", "x", "--json"],
        ["bad-eu.csv"], expect_rc=0, check_coef={"x": [float(k), 0.02]})
    # UFF58 (docs/capture-format.md reads it): binary, the force in N and the response in g by its unit label
    import pyuff
    if os.path.exists(P("bad-uff.uff")):
        os.remove(P("bad-uff.uff"))
    sets = [pyuff.prepare_58(binary=1, id1=f"{name} pt{node}", id2="bench", id3="NONE", id4="NONE", id5="NONE",
                             func_type=1, load_case_id=1, rsp_ent_name="bench", rsp_node=node, rsp_dir=3,
                             ref_ent_name="bench", ref_node=1, ref_dir=3, abscissa_spacing=1,
                             abscissa_spec_data_type=17, abscissa_axis_units_lab="s", ordinate_spec_data_type=typ,
                             ordinate_axis_units_lab=unit, orddenom_spec_data_type=0,
                             ordinate_len_unit_exp=0 if typ == 13 else 1, ordinate_force_unit_exp=1 if typ == 13 else 0,
                             x=t - t[0], data=y)
            for name, node, typ, unit, y in (("Force", 1, 13, "N", f), ("Acceleration", 2, 12, "g", a / G))]
    pyuff.UFF(P("bad-uff.uff")).write_sets(sets, mode="add")
    add("uff58-read", ["identify", "bad-uff.uff", *M, "--damping", "v", "--stiffness", "x", "--json"],
        ["bad-uff.uff"], expect_rc=0, check_coef={"x": [float(k), 0.02]})
    # a comma delimiter and decimal commas together (ambiguous: the row has more fields than the header)
    _csv(P("bad-commacomma.csv"), "t,force,acc", rows, comma=True)
    add("comma-and-decimal-comma", ["identify", "bad-commacomma.csv", *M], ["bad-commacomma.csv"])
    # an export onto its own session, and a SEP-005 file onto a CSV capture
    add("export-onto-session", ["export", "bad-sess.h5", "--uff", "bad-sess.h5"], ["bad-sess.h5"],
        setup=[["import", "bad-good.csv", "--out", "bad-sess.h5", *M]])
    add("sep005-onto-csv", ["export", "bad-sess2.h5", "--sep005", "bad-good.csv"], ["bad-good.csv"],
        setup=[["import", "bad-good.csv", "--out", "bad-sess2.h5", *M]])
    # a multi-channel capture with one accelerometer missing, validated against the model of all channels
    src = next((c for c in mdof if c.get("missing_copy")), None)
    if src:
        add("mdof-channel-missing", ["validate", "bad-mdof-model.json", src["missing_copy"]], [src["missing_copy"]],
            setup=[["diagnose", *src["files"]["train"], "--save-model", "bad-mdof-model.json", "--driving-point",
                    src["driving_point"]]], setup_rc=[0, 1], setup_limit=600)
    # a CSV cut in the middle of a row (the logger's disk filled up)
    blob = open(P("bad-good.csv")).read()
    with open(P("bad-cutrow.csv"), "w") as fh:
        fh.write(blob[: int(len(blob) * rng.uniform(0.6, 0.9))].rstrip("\n")[:-3])
    add("csv-cut-mid-row", ["identify", "bad-cutrow.csv", *M, "--json"], ["bad-cutrow.csv"], full_only=True,
        tolerant=True)
    return cases


def first(out):
    """The first run: help and the demo."""
    return [{"id": "help", "argv": ["--help"], "stdout_words": [r"usage", r"identify"], "limit_cpu_s": 60},
            {"id": "demo", "argv": ["demo", "--out", "first-demo"], "limit_cpu_s": 300,
             "expect_files": ["first-demo/session.h5", "first-demo/model.json", "first-demo/report/index.html"]}]
