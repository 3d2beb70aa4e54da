"""Bad inputs of the tenth scorecard: each must end in one line on stderr and a non-zero exit (2), no traceback,
the inputs untouched; ``tolerant``: a result with exit 0 is also right (a file or an option some tools take),
``check_mass``: with exit 0 the JSON's mass must be this [kg]. Kinds new against unseen2-9 and
docs/bad-inputs.md (unseen7's entry format: ``argv``, ``protect``, optional ``setup``).
"""

from __future__ import annotations

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

    import pyuff
    if os.path.exists(P("bad-frf.uff")):
        os.remove(P("bad-frf.uff"))
    freq = np.linspace(0.0, 200.0, 401)
    w = 2 * np.pi * freq
    wn = 2 * np.pi * 30.0
    H = -w * w / (m * (wn * wn - w * w + 2j * 0.01 * wn * w))  # accelerance of a 30 Hz oscillator
    sets = [pyuff.prepare_58(binary=0, id1="FRF 2:+Z/1:+Z", id2="NONE", id3="NONE", id4="NONE", id5="NONE",
                             func_type=4, load_case_id=1, rsp_node=2, rsp_dir=3, ref_node=1, ref_dir=3,
                             abscissa_spacing=1, abscissa_spec_data_type=18, ordinate_spec_data_type=12,
                             orddenom_spec_data_type=13, x=freq, data=H)]
    pyuff.UFF(P("bad-frf.uff")).write_sets(sets, mode="add")
    add("uff-frf-not-time", ["identify", "bad-frf.uff", *M], ["bad-frf.uff"])
    add("mass-unicode-minus", ["identify", "bad-good.csv", "--mass", "\u2212" + mass], ["bad-good.csv"])
    with open(P("bad-latin1.csv"), "w", encoding="latin-1") as fh:  # a German PC's export, not UTF-8
        fh.write("Zeit [s];Kraft [N];Beschleunigung [m/s\u00b2]\n")
        fh.write("".join(";".join(f"{v:.9g}".replace(".", ",") for v in r) + "\n" for r in rows))
    add("latin1-superscript-units", ["identify", "bad-latin1.csv", *M, "--json"], ["bad-latin1.csv"], tolerant=True,
        check_mass=float(mass))
    from scipy.io import savemat
    savemat(P("bad-complex.mat"), {"fs": 1 / (t[1] - t[0]), "force": f, "acceleration": a * np.exp(0.3j)})
    add("mat-complex-channel", ["identify", "bad-complex.mat", *M], ["bad-complex.mat"])
    _csv(P("bad-noforce.csv"), "t,force,acc", np.column_stack([t, 0 * f, a]))  # the hammer's cable unplugged
    add("force-channel-flat-zero", ["identify", "bad-noforce.csv", *M], ["bad-noforce.csv"], tolerant=True)
    add("import-highpass-negative", ["import", "bad-good.csv", "--out", "bad-hp.h5", *M, "--sensor-highpass", "-3"],
        ["bad-good.csv"])
    add("replay-csv-through-device", ["replay", "bad-good.csv", "--through-device", *M], ["bad-good.csv"])
    with open(P("bad-commas.csv"), "w") as fh:  # a comma delimiter AND decimal commas: ambiguous
        fh.write("t,force,acc\n" + "".join(",".join(f"{v:.6f}".replace(".", ",") for v in r) + "\n" for r in rows))
    add("comma-delimiter-and-decimal-comma", ["identify", "bad-commas.csv", *M], ["bad-commas.csv"])
    _csv(P("bad-half.csv"), "t,force,acc", rows[::2])  # the same bench at half the rate
    add("import-rate-differs", ["import", "bad-half.csv", "--out", "bad-sess.h5", *M], ["bad-half.csv"],
        setup=[["import", "bad-good.csv", "--out", "bad-sess.h5", *M]])
    return cases
