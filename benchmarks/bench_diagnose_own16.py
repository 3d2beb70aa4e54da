"""Own hidden-effect families of session 16 (s16ee): other masses, rates and noise than the calibration's ladders.

    python benchmarks/bench_diagnose_own16.py SET on|off OUT [SEEDS]

SET: ``ownA`` (tuning: looked at while building), ``ownB``, ``ownC`` (held out). ``on|off``: the switch
:data:`eddi.diagnosis.settings.EXTEND_JUDGED` (where a fold is judged with its equation-error contender, the
candidates are fitted by the fold's procedure, session 17; ``off``: the session-15 rule) for a same-run before / after. SEEDS: e.g. ``1,2``.
The cases are the calibration's ladder cases (``bench_diagnose_calibration.ladder_case``) on these systems,
two rungs per mechanism and a null (``amplitude_damping`` 0); each row (appended to OUT as JSON) holds the
verdict at the default factor and strong cut (docs/diagnosis.md, "Session 16").
"""
import sys, json, math
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
import numpy as np
sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_diagnose_calibration as B

OWN = {
    # tuning: what I looked at while building
    "ownA": {"mass": 0.2, "k1": 0.2 * (2 * math.pi * 9.0) ** 2, "k3": -2e5, "zeta": 0.005, "rate": 10000.0,
             "snr": 38.0, "record_s": 3.0, "mode_ratio": 2.4},
    # held out: never run before the code was frozen
    "ownB": {"mass": 0.6, "k1": 0.6 * (2 * math.pi * 6.0) ** 2, "k3": 4e5, "zeta": 0.004, "rate": 15000.0,
             "snr": 33.0, "record_s": 4.5, "mode_ratio": 2.5},
    "ownC": {"mass": 0.05, "k1": 0.05 * (2 * math.pi * 15.0) ** 2, "k3": -1e6, "zeta": 0.007, "rate": 8000.0,
             "snr": 42.0, "record_s": 2.5, "mode_ratio": 2.3},
}
CASES = [("amplitude_damping", 0.0), ("amplitude_damping", 0.06), ("amplitude_damping", 0.2),
         ("asymmetric_stiffness", 0.02), ("asymmetric_stiffness", 0.06), ("quadratic_damping", 0.06),
         ("coulomb_friction", 0.01), ("clearance", 0.06), ("sensor_highpass", 0.5), ("sensor_highpass", 1.2)]


def one(args):
    setn, name, mag, seed, on = args
    from eddi.diagnosis.settings import EXTEND_JUDGED
    EXTEND_JUDGED["on"] = on
    B.SETS.update(OWN)
    np.seterr(all="ignore")
    row = B.ladder_case((setn, name, mag, seed, (3.5,)))
    keep = {k: row.get(k) for k in ("set", "mechanism", "magnitude", "seed", "ratio", "baseline_nrmse", "data_floor",
                                     "partial", "cpu_s", "error", "pipeline_nrmse")}
    keep["cause"] = row.get("causes", {}).get("3.5|0.6")
    keep["cands"] = (row.get("candidates") or [])[:3]
    keep["on"] = on
    return keep


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 epilog="Example: python benchmarks/bench_diagnose_own16.py ownC off rows.jsonl 1,2")
    ap.add_argument("set", choices=sorted(OWN), help="ownA (tuning), ownB / ownC (held out)")
    ap.add_argument("switch", choices=("on", "off"), help="settings.EXTEND_JUDGED for a same-run before / after")
    ap.add_argument("out", help="JSON lines appended here")
    ap.add_argument("seeds", nargs="?", default="1,2", help="comma-separated seeds (default 1,2)")
    args = ap.parse_args()
    setn, flag, out = args.set, args.switch, args.out
    seeds = [int(s) for s in args.seeds.split(",")]
    tasks = [(setn, n, m, s, flag == "on") for n, m in CASES for s in seeds]
    with ProcessPoolExecutor(2) as pool:
        for row in pool.map(one, tasks):
            line = json.dumps(row)
            print(line, flush=True)
            with open(out, "a") as fh:
                fh.write(line + "\n")
