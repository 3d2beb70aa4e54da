"""Bad inputs of the eleventh scorecard: each must end in one line on stderr and a non-zero exit (2), no traceback,
the inputs untouched; ``tolerant``: a result with exit 0 is also right (a file some tools take), ``check_mass``:
with exit 0 the JSON's mass must be this [kg]. Kinds new against unseen2-10 (unseen7's entry format: ``argv``,
``protect``, optional ``setup``).
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
    acc = np.where(t > 0, X * np.exp(-z * w * t) * ((z * w) ** 2 * np.sin(wd * t) - 2 * z * w * wd * np.cos(wd * t)
                                                    - wd * wd * np.sin(wd * t)), 0.0)
    width = 4.0 / fs
    force = np.where((t > -width / 2) & (t < width / 2), np.cos(np.pi * t / width), 0.0)
    force = force * m * wd * X * np.pi / (2 * width)
    acc = acc + force / m
    acc = acc + rng.normal(0, 1e-3 * np.abs(acc).max(), len(t))
    return t, force, acc, m, fs


def _csv(path, header, rows, fmt="{:.9g}", delim=",", newline="\n", footer=""):
    with open(path, "w", newline="", encoding="utf-8") as fh:
        fh.write(header + newline + "".join(delim.join(fmt.format(v) for v in r) + newline for r in rows) + footer)


def make(rng, out, quick, mdof_file=None):
    t, f, a, m, fs = _good(rng)
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

    # a logger that stamps each row with the wall clock (hh:mm:ss.ffffff), not seconds from the trigger
    with open(P("bad-clock.csv"), "w") as fh:
        fh.write("Time;Force [N];Acceleration [m/s^2]\n")
        for tt, ff, aa in rows:
            s = 36000.0 + 41 * 60 + 7 + tt + 0.5
            fh.write(f"{int(s // 3600):02d}:{int(s % 3600 // 60):02d}:{s % 60:09.6f};{ff:.9g};{aa:.9g}\n")
    add("wall-clock-time-column", ["identify", "bad-clock.csv", *M, "--json"], ["bad-clock.csv"], tolerant=True,
        check_mass=float(mass))
    # a column whose unit is not its quantity's (velocity units under an acceleration name)
    _csv(P("bad-unitclash.csv"), "Time [s],Force [N],Acceleration [mm/s]", rows)
    add("unit-not-of-quantity", ["identify", "bad-unitclash.csv", *M], ["bad-unitclash.csv"])
    # a software export that closes with a footer of statistics
    _csv(P("bad-footer.csv"), "t,force,acc", rows,
         footer="End of data\nMax;%.6g;%.6g\nRMS;%.6g;%.6g\n" % (f.max(), a.max(), np.sqrt(np.mean(f ** 2)),
                                                               np.sqrt(np.mean(a ** 2))))
    add("footer-statistics", ["identify", "bad-footer.csv", *M, "--json"], ["bad-footer.csv"], tolerant=True,
        check_mass=float(mass))
    add("highpass-above-nyquist", ["identify", "bad-good.csv", *M, "--sensor-highpass", f"{fs * 3:.0f}"],
        ["bad-good.csv"])
    # the hammer missed: the force channel holds its noise only, the response a small random motion
    _csv(P("bad-missed.csv"), "t,force,acc", np.column_stack([t, rng.normal(0, 1e-3, len(t)),
                                                              rng.normal(0, 1e-3, len(t))]))
    add("hammer-missed", ["identify", "bad-missed.csv", *M], ["bad-missed.csv"])
    add("import-mass-differs", ["import", "bad-good.csv", "--out", "bad-sess11.h5", "--mass", f"{2 * m:.4g}"],
        ["bad-good.csv"], setup=[["import", "bad-good.csv", "--out", "bad-sess11.h5", *M]])
    _csv(P("bad-twoforce.csv"), "t,Force 1 [N],Force 2 [N],acc", np.column_stack([t, f, 0.7 * f, a]))
    add("two-force-columns", ["identify", "bad-twoforce.csv", *M], ["bad-twoforce.csv"])
    _csv(P("bad-superscript.csv"), "Time [s];Force [N];Acceleration [m/s\u00b2]", rows, delim=";")
    add("utf8-superscript-unit", ["identify", "bad-superscript.csv", *M, "--json"], ["bad-superscript.csv"],
        tolerant=True, check_mass=float(mass))
    add("diagnose-highpass-text", ["diagnose", "bad-good.csv", *M, "--sensor-highpass", "0,5 Hz"],
        ["bad-good.csv"], full_only=True)
    return cases
