"""Bad inputs: files made from a good record, and the commands a user would run on them.

Each case: ``argv`` (after ``station``, run in the data folder), ``protect`` (files that must be
byte-identical afterwards), ``needs_h5`` (the scorer first imports ``robust-good.csv`` into
``robust-good.h5`` with ``station import``, an ordinary user step, not judged).
"""

from __future__ import annotations

import json
import os
import shutil

import cases


def _rows(path):
    with open(path) as fh:
        return fh.read().splitlines()


def _put(out, name, lines):
    with open(os.path.join(out, name), "w") as fh:
        fh.write("\n".join(lines) + "\n")
    return name


def write(out, seed, man):
    r = cases.rng(seed, "robust")
    base = man["ident"][0]
    src = os.path.join(out, base["files"]["held"])
    good = "robust-good.csv"
    shutil.copyfile(src, os.path.join(out, good))
    mass = f"{base['truth']['mass']:.6g}"
    lines = _rows(src)
    head, body = lines[0], lines[1:]
    cols = head.split(",")
    ia = cols.index("acc")
    mid = len(body) // 2 + int(r.integers(-50, 50))

    def edit(i, col, val):
        b = list(body)
        f = b[i].split(",")
        f[col] = val
        b[i] = ",".join(f)
        return b

    out_cases = []

    def add(cid, argv, protect=(), needs_h5=False):
        out_cases.append({"id": cid, "argv": argv, "protect": list(protect), "needs_h5": needs_h5})

    M = ["--mass", mass]
    add("nan-acc", ["identify", _put(out, "bad-nan.csv", [head] + edit(mid, ia, "nan")), *M])
    add("inf-force", ["identify", _put(out, "bad-inf.csv", [head] + edit(mid, cols.index("force"), "inf")), *M])
    add("huge-acc", ["identify", _put(out, "bad-huge.csv", [head] + edit(mid, ia, "1e308")), *M])
    add("text-cell", ["identify", _put(out, "bad-text.csv", [head] + edit(mid, ia, "n/a?")), *M])
    keep = [i for i, c in enumerate(cols) if c != "acc"]
    add("no-response", ["identify", _put(out, "bad-noacc.csv",
                                         [",".join(cols[i] for i in keep)]
                                         + [",".join(ln.split(",")[i] for i in keep) for ln in body]), *M])
    add("header-only", ["identify", _put(out, "bad-header.csv", [head]), *M])
    b = list(body)
    b[mid:mid + 40] = b[mid:mid + 40][::-1]
    add("time-backwards", ["identify", _put(out, "bad-tback.csv", [head] + b), *M])
    it = cols.index("t")
    add("time-constant", ["identify", _put(out, "bad-tconst.csv",
                                           [head] + [",".join("0.5" if i == it else v for i, v in
                                                              enumerate(ln.split(","))) for ln in body]), *M])
    add("dup-column", ["identify", _put(out, "bad-dup.csv", [head.replace("force", "acc")] + body), *M])
    with open(os.path.join(out, "bad-garbage.csv"), "wb") as fh:
        fh.write(bytes(r.integers(0, 256, 3000, dtype=int).astype("uint8")))
    add("binary-csv", ["identify", "bad-garbage.csv", *M])
    with open(os.path.join(out, "bad-garbage.h5"), "wb") as fh:
        fh.write(b"\x89HDF\r\n\x1a\n" + bytes(r.integers(0, 256, 2000, dtype=int).astype("uint8")))
    add("garbage-h5", ["identify", "bad-garbage.h5:0", *M])
    add("missing-file", ["identify", "no-such-record.csv", *M])
    os.makedirs(os.path.join(out, "bad-dir.csv"), exist_ok=True)
    add("directory", ["identify", "bad-dir.csv", *M])
    add("mass-negative", ["identify", good, "--mass", "-" + mass])
    add("mass-nan", ["identify", good, "--mass", "nan"])
    add("unknown-term", ["identify", good, *M, "--stiffness", "x,x^q"])
    add("h5-index", ["identify", "robust-good.h5:9", *M], needs_h5=True)
    _models_and_outputs(out, man, good, mass, add)
    return out_cases


def _models_and_outputs(out, man, good, mass, add):
    """Bad model JSON, outputs onto inputs, and two-sensor records."""
    M = ["--mass", mass]
    model = {"schema_version": 1, "mass": float(mass), "damping": {"v": 0.1},
             "stiffness": {"x": 1000.0}, "effects": []}
    with open(os.path.join(out, "bad-model-trunc.json"), "w") as fh:
        fh.write(json.dumps(model)[:40])
    add("model-truncated", ["validate", "bad-model-trunc.json", good])
    with open(os.path.join(out, "bad-model-negmass.json"), "w") as fh:
        json.dump({**model, "mass": -float(mass)}, fh)
    add("model-neg-mass", ["validate", "bad-model-negmass.json", good])
    with open(os.path.join(out, "bad-model-strk.json"), "w") as fh:
        json.dump({**model, "stiffness": {"x": "stiff"}}, fh)
    add("model-string-k", ["validate", "bad-model-strk.json", good])
    with open(os.path.join(out, "bad-model-nanc.json"), "w") as fh:
        fh.write(json.dumps({**model, "damping": {"v": 1.0}}).replace("1.0", "NaN", 1))
    add("model-nan-coef", ["validate", "bad-model-nanc.json", good])
    add("import-onto-input", ["import", good, "--out", good, *M], protect=[good])
    add("savemodel-onto-input", ["diagnose", good, *M, "--save-model", good], protect=[good])
    add("export-onto-input", ["export", "robust-good.h5", "--uff", "robust-good.h5"],
        protect=["robust-good.h5"], needs_h5=True)
    if man["mdof"]:
        mf = os.path.join(out, man["mdof"][0]["files"]["train"][0])
        ml = _rows(mf)
        mc = ml[0].split(",")
        mb = list(ml[1:])
        f = mb[len(mb) // 3].split(",")
        f[-1] = ""
        mb[len(mb) // 3] = ",".join(f)
        add("mdof-empty-cell", ["diagnose", _put(out, "bad-mdof-empty.csv", [ml[0]] + mb),
                                man["mdof"][0]["files"]["train"][1]])
        with open(os.path.join(out, "robust-model.json"), "w") as fh:
            json.dump(model, fh)  # a valid model: the CSV is what is wrong
        add("mdof-missing-channel", ["validate", "robust-model.json",
                                     _put(out, "bad-mdof-cols.csv",
                                          [",".join(mc[:2])] + [",".join(x.split(",")[:2]) for x in ml[1:]])])
