#!/usr/bin/env python3
"""Generate the sixth blind scorecard's records and its manifest (truth the scorer reads).

    python benchmarks/unseen6/generate.py --out /tmp/unseen6 --seed 61 --quick

Every case draws its parameters (mass from grams to tonnes, frequency, damping, rate, noise, sensor
chain, file format, hammer tip, levels) from a generator seeded by (--seed, case id); the case kinds
are listed in README.md. Nothing is imported from the station.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import zlib

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import badinputs  # noqa: E402
import cases  # noqa: E402


def rng_for(seed, cid):
    return np.random.default_rng([seed, zlib.crc32(cid.encode())])


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="folder to write (created)")
    p.add_argument("--seed", type=int, required=True, help="every draw follows from it")
    p.add_argument("--quick", action="store_true", help="the quick subset (README.md)")
    p.add_argument("--only", default="", help="comma-separated case id prefixes (development)")
    a = p.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    man = {"seed": a.seed, "quick": a.quick, "diagnose": [], "ident": [], "mdof": [], "campaign": [],
           "robust": []}
    t0 = time.time()
    for cid, kind, maker, quick in cases.CASES:
        if a.quick and not quick:
            continue
        if a.only and not any(cid.startswith(k) for k in a.only.split(",")):
            continue
        case = maker(rng_for(a.seed, cid), cid, a.out)
        case["id"] = cid
        man[kind].append(case)
        print(f"[{time.time() - t0:5.1f} s] {cid}", file=sys.stderr, flush=True)
    good = next((c for c in man["ident"]), None)
    man["robust"] = badinputs.make(rng_for(a.seed, "bad"), a.out, a.quick, good)
    with open(os.path.join(a.out, "manifest.json"), "w") as fh:
        json.dump(man, fh, indent=1, default=_json)
    print(f"wrote {sum(len(v) for v in man.values() if isinstance(v, list))} cases to {a.out} "
          f"in {time.time() - t0:.0f} s", file=sys.stderr)
    return 0


def _json(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(type(o))


if __name__ == "__main__":
    sys.exit(main())
