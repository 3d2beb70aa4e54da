#!/usr/bin/env python3
"""Generate the thirteenth blind scorecard's records and its manifest (truth the scorer reads).

    python benchmarks/unseen13/generate.py --out /tmp/unseen13 --seed SEED --quick

Every case draws its parameters (mass from 20 g to 2.5 t, frequency, damping, rate from 1 to 102.4 kHz, noise,
sensor chain, file format, hammer tip, levels) from a generator seeded by (--seed, case id); the families are
listed in README.md, the kinds in cases.py and badinputs.py. Nothing is imported from the station.
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


FAMILY = {"diagnose": "D", "ident": "I", "grow": "G", "mdof": "M"}


def label_of(cid, kind):
    """The neutral label of a case: its family's letter and its place among the family's cases."""
    same = [c for c, k, _, _ in cases.CASES if k == kind]
    return f"{FAMILY[kind]}{same.index(cid) + 1}"


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
    man = {"seed": a.seed, "quick": a.quick, **{k: [] for k in FAMILY}, "robust": [], "first": []}
    t0 = time.time()
    for cid, kind, maker, quick in cases.CASES:
        if a.quick and not quick:
            continue
        if a.only and not any(cid.startswith(k) for k in a.only.split(",")):
            continue
        # files carry a neutral label (D1, I3, ...: family and place), never the case id, so that neither the
        # station's messages nor a listing of the data folder tell what is hidden; the draws follow the id
        label = label_of(cid, kind)
        case = maker(rng_for(a.seed, cid), label.lower(), a.out)
        case["id"] = cid
        case["label"] = label
        man[kind].append(case)
        print(f"[{time.time() - t0:5.1f} s] {cid}", file=sys.stderr, flush=True)
    if not a.only or "bad" in a.only.split(","):
        man["robust"] = badinputs.make(rng_for(a.seed, "bad"), a.out, a.quick, man["mdof"])
    if not a.only or "first" in a.only.split(","):
        man["first"] = badinputs.first(a.out)
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
