"""Bad inputs of the seventh scorecard: each must end in one line on stderr and exit 2, no traceback, the
inputs untouched (``tolerant``: a result with exit 0 is also right, e.g. a file some tools read).

``make`` writes the files and returns the manifest entries: ``argv`` (run in the data folder),
``protect`` (files that must stay byte-identical), optionally ``setup`` (station commands run first),
``truncate`` ([source, copy, fraction]: the scorer copies the first ``fraction`` of the source's bytes) and
``expect_rc`` (a good input that must give a result: exit 0). New kinds against unseen5/unseen6.
"""

from __future__ import annotations

import os

import numpy as np


def _good(rng):
    """A small good record (t, force, acc) in SI, from a damped sine and a half-sine blow."""
    fs = float(rng.choice([1024, 2000, 4096]))
    fn = rng.uniform(8, 60)
    t = np.arange(-int(0.05 * fs), int(40 / fn * fs)) / fs
    w = 2 * np.pi * fn
    acc = np.where(t > 0, -w * np.exp(-0.01 * w * t) * np.sin(w * t), 0.0) + rng.normal(0, 1e-3, len(t))
    width = 0.1 / fn
    force = np.where((t >= 0) & (t < width), np.sin(np.pi * np.clip(t, 0, width) / width), 0.0) * 100
    return t, force, acc


def _csv(path, header, rows, fmt="{:.9g}", delim=","):
    with open(path, "w") as fh:
        fh.write(header + "\n" + "".join(delim.join(fmt.format(v) for v in r) + "\n" for r in rows))


def make(rng, out, quick, mdof_file=None):
    t, f, a = _good(rng)
    rows = np.column_stack([t, f, a])
    mass = f"{rng.uniform(0.2, 3.0):.4g}"
    M = ["--mass", mass]
    P = lambda name: os.path.join(out, name)  # noqa: E731
    _csv(P("bad-good.csv"), "t,force,acc", rows)
    cases = []

    def add(cid, argv, protect=(), full_only=False, tolerant=False):
        if quick and full_only:
            return
        cases.append({"id": cid, "argv": argv, "protect": list(protect), "tolerant": tolerant})

    _csv(P("bad-strain.csv"), "Time [s],Force [N],Strain [ue]", np.column_stack([t, f, a * 3.1]))
    add("strain-gauge-only", ["identify", "bad-strain.csv", *M], ["bad-strain.csv"])
    _csv(P("bad-force-only.csv"), "t,force", np.column_stack([t, f]))
    add("force-only", ["identify", "bad-force-only.csv", *M], ["bad-force-only.csv"])
    _csv(P("bad-two-acc.csv"), "t,force,acc,acc", np.column_stack([t, f, a, -a]))
    add("response-twice", ["identify", "bad-two-acc.csv", *M], ["bad-two-acc.csv"])
    _csv(P("bad-time-zero.csv"), "t,force,acc", np.column_stack([0 * t, f, a]))
    add("time-all-zero", ["identify", "bad-time-zero.csv", *M], ["bad-time-zero.csv"])
    _csv(P("bad-six-rows.csv"), "t,force,acc", rows[len(rows) // 10: len(rows) // 10 + 6])
    add("six-rows", ["diagnose", "bad-six-rows.csv", "bad-good.csv", *M], ["bad-six-rows.csv", "bad-good.csv"])
    with open(P("bad-nan-tail.csv"), "w") as fh:
        fh.write("t,force,acc\n")
        for i, r in enumerate(rows):
            fh.write(f"{r[0]:.9g},{r[1]:.9g}," + (f"{r[2]:.9g}" if i < len(rows) // 3 else "NaN") + "\n")
    add("nan-tail-text", ["identify", "bad-nan-tail.csv", *M], ["bad-nan-tail.csv"])
    import h5py
    with h5py.File(P("bad-foreign.h5"), "w") as h:
        h.create_dataset("data", data=rows)
        h.attrs["instrument"] = "other vendor"
    add("h5-foreign-layout", ["identify", "bad-foreign.h5", *M], ["bad-foreign.h5"])
    with open(P("bad-model-list.json"), "w") as fh:
        fh.write("[1.0, 2.0]\n")
    add("model-is-list", ["validate", "bad-model-list.json", "bad-good.csv"], ["bad-model-list.json", "bad-good.csv"])
    os.makedirs(P("bad-empty-folder"), exist_ok=True)
    add("campaign-empty-folder", ["campaign", "bad-empty-folder", "--out", "bad-empty-out", *M, "--workers", "1"])
    add("campaign-workers-zero", ["campaign", "bad-good.csv", "--out", "bad-w0-out", *M, "--workers", "0"],
        ["bad-good.csv"])
    add("mass-inf", ["identify", "bad-good.csv", "--mass", "inf"], ["bad-good.csv"])
    _csv(P("bad-reversed.csv"), "t,force,acc", rows[::-1])
    add("time-reversed", ["identify", "bad-reversed.csv", *M], ["bad-reversed.csv"])
    with open(P("bad-utf16.csv"), "w", encoding="utf-16") as fh:  # Excel's "Unicode text"
        fh.write("t,force,acc\n" + "".join(f"{r[0]:.9g},{r[1]:.9g},{r[2]:.9g}\n" for r in rows))
    add("utf16-excel", ["identify", "bad-utf16.csv", *M], ["bad-utf16.csv"], tolerant=True)
    from scipy.io import savemat
    savemat(P("bad-lengths.mat"), {"fs": float(1 / (t[1] - t[0])), "force": f, "acceleration": a[: len(a) * 2 // 3]})
    add("mat-channel-lengths-differ", ["identify", "bad-lengths.mat", *M], ["bad-lengths.mat"])
    import pyuff
    if os.path.exists(P("bad-force-only.uff")):
        os.remove(P("bad-force-only.uff"))
    pyuff.UFF(P("bad-force-only.uff")).write_sets([pyuff.prepare_58(
        binary=0, id1="force", id2="NONE", id3="NONE", id4="NONE", id5="NONE", func_type=1, load_case_id=1,
        rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3, abscissa_spacing=1, ordinate_spec_data_type=13,
        orddenom_spec_data_type=0, x=t, data=f)], mode="add")
    add("uff-force-only", ["identify", "bad-force-only.uff", *M], ["bad-force-only.uff"])
    # the station's own session, cut mid-write (a copy truncated by the scorer after `station import`)
    cases.append({"id": "h5-session-cut", "argv": ["diagnose", "bad-cut-session.h5", *M], "protect": [],
                  "tolerant": False, "setup": [["import", "bad-good.csv", "--out", "bad-session.h5", *M]],
                  "truncate": ["bad-session.h5", "bad-cut-session.h5", 0.6]})
    name = "bad ring-down Prüfstand 3.csv"  # a good record: spaces and umlauts in the name must work
    _csv(P(name), "t,force,acc", rows)
    cases.append({"id": "unicode-spaces-name-must-work", "argv": ["identify", name, *M], "protect": [name],
                  "tolerant": False, "expect_rc": 0})
    if mdof_file:
        add("driving-point-is-force", ["diagnose", mdof_file, "--driving-point", "force"], [mdof_file])
    _csv(P("bad-dup-time.csv"), "t,force,acc", np.column_stack([np.repeat(t[::2], 2)[:len(t)], f, a]))
    add("time-steps-repeat", ["identify", "bad-dup-time.csv", *M], ["bad-dup-time.csv"], full_only=True)
    add("damping-term-typo", ["identify", "bad-good.csv", *M, "--damping", "v,x^2v"], ["bad-good.csv"],
        full_only=True)
    add("gain-tolerance-negative", ["diagnose", "bad-good.csv", *M, "--gain-tolerance", "-3"], ["bad-good.csv"],
        full_only=True)
    add("clock-ppm-text", ["diagnose", "bad-good.csv", *M, "--clock-ppm", "fast"], ["bad-good.csv"],
        full_only=True)
    return cases
