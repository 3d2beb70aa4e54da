"""Bad inputs: each must end in one line on stderr and exit 2, no traceback, inputs untouched.

``make`` writes the files (from a good record of an identification case, re-written here) and returns
the manifest entries: ``argv`` (run in the data folder), ``protect`` (files that must stay
byte-identical).
"""

from __future__ import annotations

import os

import numpy as np


def _good(rng, out, good):
    """A small good record (t, force, acc) in SI, from a damped sine and a half-sine blow."""
    fs = float(rng.choice([1000, 2048, 5000]))
    fn = rng.uniform(8, 60)
    t = np.arange(-int(0.05 * fs), int(40 / fn * fs)) / fs
    w = 2 * np.pi * fn
    acc = np.where(t > 0, -w * np.exp(-0.01 * w * t) * np.sin(w * t), 0.0) + rng.normal(0, 1e-3, len(t))
    width = 0.1 / fn
    force = np.where((t >= 0) & (t < width), np.sin(np.pi * np.clip(t, 0, width) / width), 0.0) * 100
    return t, force, acc


def _csv(path, header, rows):
    with open(path, "w") as fh:
        fh.write(header + "\n" + "".join(",".join(f"{v:.9g}" for v in r) + "\n" for r in rows))


def make(rng, out, quick, good_case):
    t, f, a = _good(rng, out, good_case)
    rows = np.column_stack([t, f, a])
    mass = f"{rng.uniform(0.2, 3.0):.4g}"
    P = lambda name: os.path.join(out, name)  # noqa: E731
    _csv(P("bad-good.csv"), "t,force,acc", rows)
    cases = []

    def add(cid, argv, protect=(), full_only=False):
        if quick and full_only:
            return
        cases.append({"id": cid, "argv": argv, "protect": list(protect)})

    with open(P("bad-header-only.csv"), "w") as fh:
        fh.write("Time [s];Force [N];Acceleration [g]\n")
    add("header-only", ["identify", "bad-header-only.csv", "--mass", mass], ["bad-header-only.csv"])
    r2 = [list(r) for r in rows]
    r2[len(r2) // 2] = r2[len(r2) // 2][:2]
    with open(P("bad-ragged.csv"), "w") as fh:
        fh.write("t,force,acc\n" + "".join(",".join(f"{v:.9g}" for v in r) + "\n" for r in r2))
    add("ragged-row", ["diagnose", "bad-ragged.csv", "bad-good.csv", "--mass", mass], ["bad-ragged.csv"])
    r3 = rows.copy()
    i = len(r3) // 3
    r3[i, 0], r3[i + 1, 0] = r3[i + 1, 0], r3[i, 0]
    _csv(P("bad-time-swap.csv"), "t,force,acc", r3)
    add("time-not-monotonic", ["identify", "bad-time-swap.csv", "--mass", mass], ["bad-time-swap.csv"])
    _csv(P("bad-volts.csv"), "Time [s],Force [N],Acceleration [mV]", rows)
    add("volts-column", ["identify", "bad-volts.csv", "--mass", mass], ["bad-volts.csv"])
    add("mass-negative", ["identify", "bad-good.csv", "--mass", "-" + mass], ["bad-good.csv"])
    add("mass-nan", ["diagnose", "bad-good.csv", "--mass", "nan"], ["bad-good.csv"])
    from scipy.io import savemat
    savemat(P("bad-nochannels.mat"), {"x": a, "notes": "ring-down of bracket 4"})
    add("mat-no-channels", ["identify", "bad-nochannels.mat", "--mass", mass], ["bad-nochannels.mat"])
    import pyuff
    uf = pyuff.UFF(P("bad-one-case.uff"))
    uf.write_sets([pyuff.prepare_58(binary=0, id1="acc", id2="NONE", id3="NONE", id4="NONE", id5="NONE", func_type=1, load_case_id=1, rsp_node=1, rsp_dir=3,
                                    ref_node=1, ref_dir=3, abscissa_spacing=1,
                                    ordinate_spec_data_type=12, orddenom_spec_data_type=0, x=t, data=a)], mode="overwrite")
    with open(P("bad-one-case.uff"), "rb") as fh:
        blob = fh.read()
    with open(P("bad-trunc.uff"), "wb") as fh:
        fh.write(blob[: len(blob) // 2])
    add("uff-truncated", ["identify", "bad-trunc.uff", "--mass", mass], ["bad-trunc.uff"])
    open(P("bad-empty.csv"), "w").close()
    add("empty-file", ["validate", "bad-model.json", "bad-empty.csv"], ["bad-empty.csv"], full_only=True)
    os.makedirs(P("bad-a-folder"), exist_ok=True)
    add("folder-as-record", ["identify", "bad-a-folder", "--mass", mass])
    add("unknown-term", ["identify", "bad-good.csv", "--mass", mass, "--damping", "v,sin(x)"], ["bad-good.csv"])
    with open(P("bad-model.json"), "w") as fh:
        fh.write('{"mass": 1.0, "damping": {"v": 0.3}, "stiffness": {"x": ')
    add("model-truncated", ["validate", "bad-model.json", "bad-good.csv"], ["bad-model.json", "bad-good.csv"])
    r4 = rows.copy()
    r4[len(r4) // 4, 2] = np.inf
    _csv(P("bad-inf.csv"), "t,force,acc", r4)
    add("inf-value", ["diagnose", "bad-inf.csv", "bad-good.csv", "--mass", mass], ["bad-inf.csv"])
    with open(P("bad-garbage.h5"), "wb") as fh:
        fh.write(rng.bytes(4096))
    add("h5-garbage", ["diagnose", "bad-garbage.h5", "--mass", mass], ["bad-garbage.h5"])
    r5 = rows.copy()
    r5[:, 2] = 0.0
    _csv(P("bad-dead-sensor.csv"), "t,force,acc", r5)
    add("dead-sensor", ["identify", "bad-dead-sensor.csv", "--mass", mass], ["bad-dead-sensor.csv"])
    with open(P("bad-plainfile"), "w") as fh:
        fh.write("keep me\n")
    add("campaign-out-is-file", ["campaign", "bad-good.csv", "--out", "bad-plainfile", "--mass", mass,
                                 "--workers", "1"], ["bad-plainfile", "bad-good.csv"], full_only=True)
    add("driving-point-unknown", ["diagnose", "bad-good.csv", "--driving-point", "acc_roof", "--mass", mass],
        ["bad-good.csv"], full_only=True)
    add("capture-out-of-range", ["identify", "bad-one-case.uff:7", "--mass", mass], ["bad-one-case.uff"],
        full_only=True)
    add("identify-out-onto-input", ["import", "bad-good.csv", "--out", "bad-good.csv"], ["bad-good.csv"],
        full_only=True)
    return cases
