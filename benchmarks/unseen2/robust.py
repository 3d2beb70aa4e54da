"""Bad inputs of the second blind scorecard: files another lab might hand over by mistake.

Each case writes its files into the data folder and names the command a user would run
(``{d}`` is the data folder). The station must print one line on stderr and exit 2.
"""

from __future__ import annotations

import os


def _good(n=400, fs=2000.0):
    import math
    rows = ["t,force,acc"]
    for i in range(n):
        t = i / fs
        f = 30.0 * math.sin(math.pi * (t - 0.01) / 0.002) if 0.01 < t < 0.012 else 0.0
        a = 0.0 if t < 0.01 else 50 * math.exp(-2 * (t - 0.01)) * math.sin(2 * math.pi * 20 * (t - 0.01))
        rows.append(f"{t:.6f},{f:.6g},{a + 0.001 * ((i * 7919) % 13 - 6):.6g}")
    return rows


def _write(d, name, text, binary=False):
    p = os.path.join(d, name)
    with open(p, "wb" if binary else "w") as fh:
        fh.write(text)
    return name


def robust_cases(d):
    """Write the bad files into ``d``; return ``[{"id", "argv"}]`` (argv after ``station``)."""
    os.makedirs(d, exist_ok=True)
    good = _good()
    g = _write(d, "bad-good.csv", "\n".join(good) + "\n")
    cases = []

    def add(cid, argv):
        cases.append({"id": cid, "argv": argv})

    add("empty-file", ["identify", _write(d, "bad-empty.csv", ""), "--mass", "1"])
    add("header-only", ["identify", _write(d, "bad-header.csv", "t,force,acc\n"), "--mass", "1"])
    add("semicolon-csv", ["identify", _write(d, "bad-semicolon.csv", "\n".join(r.replace(",", ";") for r in good)),
                          "--mass", "1"])
    add("german-decimals", ["identify", _write(d, "bad-comma-dec.csv", "t;force;acc\n0,0;0,0;0,1\n0,001;1,0;0,2\n"),
                            "--mass", "1"])
    add("units-row", ["identify", _write(d, "bad-units.csv", good[0] + "\ns,N,m/s^2\n" + "\n".join(good[1:])),
                      "--mass", "1"])
    nan = list(good)
    nan[200] = nan[200].rsplit(",", 1)[0] + ",nan"
    add("nan-value", ["identify", _write(d, "bad-nan.csv", "\n".join(nan)), "--mass", "1"])
    gap = good[:150] + good[160:]
    add("missing-samples", ["identify", _write(d, "bad-gap.csv", "\n".join(gap)), "--mass", "1"])
    rev = [good[0]] + good[1:][::-1]
    add("time-reversed", ["identify", _write(d, "bad-rev.csv", "\n".join(rev)), "--mass", "1"])
    add("volts-column", ["identify", _write(d, "bad-volts.csv", "\n".join(["time_s,ch0_V,ch1_V"] + good[1:])),
                         "--mass", "1"])
    add("mass-negative", ["identify", g, "--mass", "-0.5"])
    add("mass-zero", ["identify", g, "--mass", "0"])
    add("mass-text", ["identify", g, "--mass", "heavy"])
    add("no-mass", ["identify", g])
    add("bad-term", ["identify", g, "--mass", "1", "--damping", "v,tanh(v)"])
    add("missing-file", ["identify", "bad-does-not-exist.csv", "--mass", "1"])
    add("directory", ["identify", ".", "--mass", "1"])
    add("binary-csv", ["identify", _write(d, "bad-binary.csv", bytes(range(256)) * 8, binary=True), "--mass", "1"])
    add("fake-h5", ["identify", _write(d, "bad-fake.h5", "not an hdf5 file\n"), "--mass", "1"])
    add("h5-capture-out-of-range", ["identify", _write(d, "bad-fake2.h5", b"\x89HDF\r\n\x1a\n" + b"\0" * 64, binary=True)
                                    + ":7", "--mass", "1"])
    add("validate-bad-json", ["validate", _write(d, "bad-model.json", "{\"mass\": 1, \"stiffness\": "), g])
    add("validate-model-missing-keys", ["validate", _write(d, "bad-model2.json", "{\"mass\": 1}"), g])
    add("validate-model-nan", ["validate", _write(d, "bad-model3.json",
                                                  "{\"mass\": 1, \"damping\": {\"v\": NaN}, \"stiffness\": {\"x\": 1e4}}"), g])
    add("diagnose-one-bad-of-two", ["diagnose", g, "bad-nan.csv", "--mass", "1"])
    add("diagnose-mechanism-typo", ["diagnose", g, g, "--mass", "1", "--mechanisms", "friction"])
    add("import-onto-input", ["import", g, "--out", g])
    add("huge-values", ["identify", _write(d, "bad-huge.csv", "\n".join(good[:100] + [good[100].rsplit(",", 1)[0]
                                                                                   + ",1e300"] + good[101:])),
                        "--mass", "1"])
    return cases
