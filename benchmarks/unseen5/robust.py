"""Bad inputs of kinds the fourth scorecard did not try, and the commands a user would run on them.

Each case: ``argv`` (after ``station``, run in the data folder), ``protect`` (files that must be
byte-identical afterwards), ``needs_h5`` (the scorer first imports ``robust-good.csv`` into
``robust-good.h5`` with ``station import``, an ordinary user step, not judged), ``timeout`` [s],
``links`` (symbolic or hard links the scorer makes just before the command: [kind, target, name]),
``tolerant`` (a valid-but-unusual input: reading it (exit 0) or refusing it in one line both pass).
"""

from __future__ import annotations

import gzip
import json
import os
import shutil


def _rows(path):
    with open(path) as fh:
        return fh.read().splitlines()


def _put(out, name, lines):
    with open(os.path.join(out, name), "w") as fh:
        fh.write("\n".join(lines) + "\n")
    return name


def write(out, seed, man, quick):  # noqa: ARG001 (seed: every file here is cut from seeded records)
    base = man["ident"][0]
    src = os.path.join(out, base["files"]["held"])
    good = "robust-good.csv"
    shutil.copyfile(src, os.path.join(out, good))
    fit = base["files"]["fit"]
    tr = base["truth"]
    mass = f"{tr['mass']:.6g}"
    lines = _rows(src)
    head, body = lines[0], lines[1:]
    found = []

    def add(cid, argv, protect=(), needs_h5=False, timeout=120, links=(), tolerant=False):
        found.append({"id": cid, "argv": [str(a) for a in argv], "protect": list(protect),
                      "needs_h5": needs_h5, "timeout": timeout, "links": list(links), "tolerant": tolerant})

    M = ["--mass", mass]
    # two records pasted into one file (`cat a.csv b.csv > ab.csv`): a header in the middle
    add("concatenated-csv", ["identify", _put(out, "bad-concat.csv", lines + _rows(os.path.join(out, fit))), *M])
    # a record cut mid-write: the last line is half a row
    cut = body[-1].split(",")
    add("cut-last-line", ["identify", _put(out, "bad-cut.csv", [head] + body[:-1] + [cut[0] + "," + cut[1][:3]]), *M])
    # a gzip-compressed record under a .csv.gz name
    with gzip.open(os.path.join(out, "bad-record.csv.gz"), "wt") as fh:
        fh.write("\n".join(lines) + "\n")
    add("gzip-record", ["identify", "bad-record.csv.gz", *M])
    # a symbolic link to itself
    loop = os.path.join(out, "bad-loop.csv")
    if os.path.lexists(loop):
        os.remove(loop)
    os.symlink("bad-loop.csv", loop)
    add("symlink-loop", ["identify", "bad-loop.csv", *M])
    add("mass-decimal-comma", ["identify", good, "--mass", mass.replace(".", ",") if "." in mass else mass + ",5"])
    add("mass-minus-zero", ["identify", good, "--mass", "-0.0"])
    add("route-unknown", ["identify", good, *M, "--route", "sideways"])
    add("adc-filter-sinc0", ["identify", good, *M, "--adc-filter", "sinc0"])
    add("adc-filter-name", ["identify", good, *M, "--adc-filter", "butterworth"])
    add("stiffness-with-v", ["identify", good, *M, "--stiffness", "x,x*v"])
    add("stiffness-empty", ["identify", good, *M, "--stiffness", ""])
    add("fit-out-of-range", ["identify", good, fit, *M, "--fit", "5"])
    add("mechanism-unknown", ["diagnose", good, fit, *M, "--mechanisms", "warp_drive"])
    add("margin-above-one", ["diagnose", good, fit, *M, "--margin", "1.5"])
    add("h5-index-fraction", ["identify", "robust-good.h5:0.5", *M], needs_h5=True)
    add("validate-no-record", ["validate", "robust-model.json"])
    # outputs that reach an input by another name: a symbolic link, a dotted path, a hard link
    add("import-onto-symlink-of-input", ["import", good, "--out", "bad-alias.h5", *M], protect=[good],
        links=[["symlink", good, "bad-alias.h5"]])
    os.makedirs(os.path.join(out, "bad-sub"), exist_ok=True)
    add("savemodel-onto-dotted-model", ["diagnose", good, "--model", "robust-model.json", "--save-model",
                                        "bad-sub/../robust-model.json"], protect=["robust-model.json"])
    add("export-onto-hardlink-of-input", ["export", "robust-good.h5", "--uff", "bad-hard.uff"],
        protect=["robust-good.h5"], needs_h5=True, links=[["hard", "robust-good.h5", "bad-hard.uff"]])
    # a spreadsheet's export: byte-order mark and CRLF line ends (reading it or one clean line)
    with open(os.path.join(out, "robust-bom-crlf.csv"), "w", newline="") as fh:
        fh.write("\ufeff" + "\r\n".join(lines) + "\r\n")
    add("bom-crlf-either", ["identify", "robust-bom-crlf.csv", *M], tolerant=True)
    _models(out, tr, good, mass, add)
    if man["mdof"]:
        _mdof(out, man["mdof"][0], add)
    if not quick:
        fifo = os.path.join(out, "bad-fifo.csv")
        if os.path.lexists(fifo):
            os.remove(fifo)
        os.mkfifo(fifo)
        add("fifo-input", ["identify", "bad-fifo.csv", *M], timeout=60)
    return found


def _models(out, tr, good, mass, add):
    """A valid model (the truth) and bad ones; outputs that would destroy an input or a file."""
    model = {"schema_version": 1, "mass": tr["mass"], "damping": dict(tr["damping"]),
             "stiffness": dict(tr["stiffness"]), "effects": []}
    with open(os.path.join(out, "robust-model.json"), "w") as fh:
        json.dump(model, fh)
    with open(os.path.join(out, "bad-model-future.json"), "w") as fh:
        json.dump({**model, "schema_version": 999}, fh)
    add("model-future-schema", ["validate", "bad-model-future.json", good])
    with open(os.path.join(out, "bad-model-effect.json"), "w") as fh:
        json.dump({**model, "effects": [{"name": "warp_drive", "params": {"strength": 1.0}}]}, fh)
    add("model-unknown-effect", ["validate", "bad-model-effect.json", good])
    with open(os.path.join(out, "bad-model-vstiff.json"), "w") as fh:
        json.dump({**model, "stiffness": {**model["stiffness"], "v": 1.0}}, fh)
    add("model-v-in-stiffness", ["validate", "bad-model-vstiff.json", good])
    with open(os.path.join(out, "bad-model-extra.json"), "w") as fh:
        json.dump({**model, "masss": 1.0}, fh)
    add("model-misspelt-key", ["validate", "bad-model-extra.json", good])
    add("savemodel-onto-model", ["diagnose", good, "--model", "robust-model.json",
                                 "--save-model", "robust-model.json"], protect=["robust-model.json"])
    add("report-onto-model", ["diagnose", good, "--mass", mass, "--report", "robust-model.json"],
        protect=["robust-model.json", good])


def _mdof(out, case, add):
    """Multi-channel captures a user gets wrong."""
    tr0, tr1 = case["files"]["train"][:2]
    rows = _rows(os.path.join(out, tr0))
    cols = rows[0].split(",")
    # a dead accelerometer: its channel reads exactly zero
    dead = cols.index(case["columns"][-1])
    body = []
    for ln in rows[1:]:
        f = ln.split(",")
        f[dead] = "0"
        body.append(",".join(f))
    add("mdof-dead-channel", ["diagnose", _put(out, "bad-mdof-dead.csv", [rows[0]] + body), tr1])
    # one capture lost a channel: captures with different sensor sets in one diagnose
    keep = [i for i, c in enumerate(cols) if c != case["columns"][-1]]
    sub = [",".join(ln.split(",")[i] for i in keep) for ln in rows]
    add("mdof-channel-sets-differ", ["diagnose", _put(out, "bad-mdof-fewer.csv", sub), tr1])
    add("mdof-driving-point-unknown", ["diagnose", tr0, tr1, "--driving-point", "acc_roof"])
