"""Bad inputs of the ninth scorecard: each must end in one line on stderr and a non-zero exit (2), no traceback,
the inputs untouched; ``tolerant``: a result with exit 0 is also right (a file or an option some tools take),
``check_mass``: with exit 0 the JSON's mass must be this [kg]. Kinds new against unseen2-7 and the 165 of
docs/bad-inputs.md (unseen7's entry format: ``argv``, ``protect``, optional ``setup``).
"""

from __future__ import annotations

import json
import os

import numpy as np


def _good(rng):
    """A small good record (t, force, acc) in SI: a 0.2-3 kg linear oscillator struck by a half-sine."""
    fs = float(rng.choice([1024, 2000, 4096]))
    fn = rng.uniform(8, 60)
    m = rng.uniform(0.2, 3.0)
    w = 2 * np.pi * fn
    X = 1e-3
    t = np.arange(-int(0.05 * fs), int(40 / fn * fs)) / fs
    z = 0.01
    wd = w * np.sqrt(1 - z * z)
    x = np.where(t > 0, X * np.exp(-z * w * t) * np.sin(wd * t), 0.0)
    acc = np.where(t > 0, X * np.exp(-z * w * t) * ((z * w) ** 2 * np.sin(wd * t) - 2 * z * w * wd * np.cos(wd * t)
                                                    - wd * wd * np.sin(wd * t)), 0.0)
    width = 4.0 / fs
    force = np.where((t > -width / 2) & (t < width / 2), np.cos(np.pi * t / width), 0.0)  # centred on t = 0
    force = force * m * wd * X * np.pi / (2 * width)
    acc = acc + force / m  # the blow accelerates the mass (its impulse is the momentum after it)
    acc = acc + rng.normal(0, 1e-3 * np.abs(acc).max(), len(t))
    return t, force, acc, m, x


def _csv(path, header, rows, fmt="{:.9g}", delim=",", newline="\n"):
    with open(path, "w", newline="") as fh:
        fh.write(header + newline + "".join(delim.join(fmt.format(v) for v in r) + newline for r in rows))


def make(rng, out, quick, mdof_file=None):
    t, f, a, m, _ = _good(rng)
    rows = np.column_stack([t, f, a])
    mass = f"{m:.4g}"
    M = ["--mass", mass]
    P = lambda name: os.path.join(out, name)  # noqa: E731
    _csv(P("bad-good.csv"), "t,force,acc", rows)
    cases = []

    def add(cid, argv, protect=(), full_only=False, tolerant=False, **kw):
        if quick and full_only:
            return
        cases.append({"id": cid, "argv": argv, "protect": list(protect), "tolerant": tolerant, **kw})

    grams = f"{1000 * float(mass):.6g}g"  # the lab writes the unit after the number
    add("mass-with-unit", ["identify", "bad-good.csv", "--mass", grams, "--json"], ["bad-good.csv"], tolerant=True,
        check_mass=float(mass))
    import pyuff
    if os.path.exists(P("bad-rates.uff")):
        os.remove(P("bad-rates.uff"))
    half = t[::2]  # the response saved at half the force's rate by a second analyser
    sets = [pyuff.prepare_58(binary=0, id1="force", id2="NONE", id3="NONE", id4="NONE", id5="NONE", func_type=1,
                             load_case_id=1, rsp_node=1, rsp_dir=3, ref_node=1, ref_dir=3, abscissa_spacing=1,
                             ordinate_spec_data_type=13, orddenom_spec_data_type=0, x=t, data=f),
            pyuff.prepare_58(binary=0, id1="acc", id2="NONE", id3="NONE", id4="NONE", id5="NONE", func_type=1,
                             load_case_id=1, rsp_node=2, rsp_dir=3, ref_node=1, ref_dir=3, abscissa_spacing=1,
                             ordinate_spec_data_type=12, orddenom_spec_data_type=0, x=half, data=a[::2])]
    pyuff.UFF(P("bad-rates.uff")).write_sets(sets, mode="add")
    add("uff-rates-differ", ["identify", "bad-rates.uff", *M], ["bad-rates.uff"], tolerant=True)
    add("same-capture-twice", ["diagnose", "bad-good.csv", "bad-good.csv", *M], ["bad-good.csv"], tolerant=True)
    model = {"schema_version": 1, "mass": float(mass), "damping": {"v": float("nan")},
             "stiffness": {"x": float(m * (2 * np.pi * 20) ** 2)}, "effects": [], "coordinate": "displacement [m]"}
    with open(P("bad-model-nan.json"), "w") as fh:
        json.dump(model, fh)
    add("model-coefficient-nan", ["validate", "bad-model-nan.json", "bad-good.csv"],
        ["bad-model-nan.json", "bad-good.csv"])
    if mdof_file:
        add("driving-point-unknown", ["diagnose", mdof_file, "--driving-point", "acc_nowhere"], [mdof_file])
    add("campaign-validate-no-model", ["campaign", "bad-good.csv", "--out", "bad-cv-out", "--task", "validate", *M,
                                       "--workers", "1"], ["bad-good.csv"])
    _csv(P("bad-cr-only.csv"), "t,force,acc", rows, newline="\r")  # a classic Mac OS export
    add("cr-line-ends", ["identify", "bad-cr-only.csv", *M], ["bad-cr-only.csv"], tolerant=True)
    from scipy.io import savemat
    savemat(P("bad-v4.mat"), {"fs": np.array([[1 / (t[1] - t[0])]]), "force": f.reshape(-1, 1),
                              "acceleration": a.reshape(-1, 1)}, format="4")
    add("mat-v4", ["identify", "bad-v4.mat", *M], ["bad-v4.mat"], tolerant=True)
    add("campaign-scheduler-down", ["campaign", "bad-good.csv", "--out", "bad-sched-out", *M, "--scheduler",
                                    "tcp://127.0.0.1:9"], ["bad-good.csv"])
    return cases
