"""The measurement-chain checks on nulls across damping, frequency and hammer tip (session 10).

The chain's findings (``eddi.diagnosis.chain.inspect``: clipping, double hit, base motion, a
mass that disagrees with the hammer impulse) each forbid ``none`` and a name (loop step 5),
so a finding on a null is a false alarm whatever the fits say. Session 9 changed the
impulse-mass check (the damper's impulse during the blow, ``2 zeta w1 dx``, joined the
spring's) after a blind 141 Hz, 2.5 % damped null was called a mass error; the calibration
nulls (``bench_diagnose_calibration.py``) are lightly damped (0.1-1 %) and slow (8-80 Hz), so
they hardly exercise it. This benchmark runs only the chain checks (no fits: milliseconds
per record, so hundreds of sets) on nulls drawn over the range the correction is for:

* mass 0.01-10 kg, natural frequency 3-200 Hz, damping ratio 0.1-8 % (log-uniform), a weak
  soft or hard cubic spring (frequency shift up to +-5 % at the strongest blow);
* hammer tip steel / plastic / rubber (0.2 / 1 / 3 ms contact), sample rate 1-40 kHz with
  at least 10 samples per cycle; SNR 30-60 dB; 3 captures, or 6 from two rig seeds;
  blows spread 1.5x;

and, on the same records, the check's power: the mass stated 5 % too large and 5 % too
small must each be reported (``impulse_mass``). Printed: findings on the nulls (the false
alarms this check alone causes) against the count, the largest |impulse/momentum - 1|
against the tolerance (a ratio: how close the worst null comes), per tip and per band of
``w1 T`` (the pulse's share of a radian), and the detection rate of the +-5 % errors.

    python benchmarks/bench_diagnose_chain_nulls.py --seeds 0-199 --jobs 1 --out chain-nulls.jsonl
    python benchmarks/bench_diagnose_chain_nulls.py --summary chain-nulls.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

TIPS = ("steel", "plastic", "rubber")
RATES = (1000.0, 2000.0, 5000.0, 10000.0, 20000.0, 40000.0)


def null_records(seed: int) -> tuple[list, dict]:
    """One null set drawn from ``seed`` (module notes) and what was drawn."""
    from eddi.conditioning import condition
    from eddi.diagnosis import Record
    from eddi.model import EquationOfMotion
    from simulated_rig.bench import impact_test
    from simulated_rig.hammer import TIP_PULSE_WIDTH_S, HammerSpec

    rng = np.random.default_rng(70_000 + seed)
    mass = float(np.exp(rng.uniform(np.log(0.01), np.log(10.0))))
    f1 = float(np.exp(rng.uniform(np.log(3.0), np.log(200.0))))
    zeta = float(np.exp(rng.uniform(np.log(0.001), np.log(0.08))))
    tip = str(rng.choice(TIPS))
    rate = float(rng.choice([r for r in RATES if r >= 10 * f1]))
    snr = float(rng.uniform(30.0, 60.0))
    runs = 2 if rng.random() < 0.35 else 1
    shift = float(rng.uniform(-0.05, 0.05))
    k1 = mass * (2 * math.pi * f1) ** 2
    c = 2 * zeta * math.sqrt(k1 * mass)
    top = 30.0 * mass / 0.1
    lin = EquationOfMotion.create(mass=mass, damping={"v": c}, stiffness={"x": k1})
    hammer = HammerSpec(tip=tip)
    amp = float(np.max(np.abs(impact_test(lin, top, rate_hz=rate, pretrigger_s=0.01, record_s=min(0.5, 5 / f1),
                                          snr_db=None, hammer=hammer, seed=0).truth_x)))
    # cubic term for the wanted frequency shift at the strongest blow (shift ~ 3 k3 A^2 / (8 k1))
    eom = EquationOfMotion.create(mass=mass, damping={"v": c},
                                  stiffness={"x": k1, "x^3": 8 * shift * k1 / (3 * amp ** 2)})
    cycles = min(40.0, 4.0 / (2 * math.pi * zeta))  # ~ to the noise at 40 dB, at most 40 cycles
    record_s = min(max(cycles, 6.0) / f1, 64_000 / rate)
    recs = []
    for run in range(runs):
        for i, lev in enumerate((1 / 1.5, 1 / 1.22, 1.0)):
            r = impact_test(eom, top * lev, rate_hz=rate, pretrigger_s=0.05, record_s=record_s, snr_db=snr,
                            hammer=hammer, seed=100_000 * run + 1000 * seed + 10 * i + 9)
            cnd = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
            recs.append(Record.from_conditioned(cnd, label=f"run {run + 1} impact {i + 1}",
                                                pretrigger_samples=r.pretrigger_samples))
    pulse = TIP_PULSE_WIDTH_S[tip]
    return recs, {"mass_kg": mass, "f1_hz": f1, "zeta": zeta, "tip": tip, "pulse_s": pulse, "rate_hz": rate,
                  "snr_db": snr, "captures": len(recs), "shift": shift, "record_s": record_s,
                  "w1T": 2 * math.pi * f1 * pulse, "pulse_samples": pulse * rate}


def case(seed: int) -> dict:
    from eddi.diagnosis.chain import impulse_mass_ratio, inspect, measured_frequency

    t0 = time.process_time()
    try:
        recs, info = null_records(seed)
    except Exception as exc:  # a set the rig or the conditioning refuses is reported, not hidden
        return {"seed": seed, "error": f"{type(exc).__name__}: {exc}"}
    m = info["mass_kg"]
    f_meas = measured_frequency(recs)
    null = [[s.kind, {k: float(v) for k, v in s.values.items()}] for s in inspect(recs, m, info["f1_hz"])]
    ratio = impulse_mass_ratio(recs, m)
    found = {f"{e:+g}": any(s.kind == "impulse_mass" for s in inspect(recs, m * (1 + e), info["f1_hz"]))
             for e in (0.05, -0.05)}
    return {"seed": seed, **info, "f_measured_hz": f_meas, "findings": null, "impulse_mass": ratio,
            "error_found": found, "cpu_s": time.process_time() - t0}


def summary(path: str) -> None:
    from eddi.diagnosis.chain import IMPULSE_MASS_TOLERANCE

    rows = [json.loads(s) for s in open(path) if s.strip()]
    bad = [r for r in rows if "error" in r]
    rows = [r for r in rows if "error" not in r]
    if bad:
        print(f"refused: {len(bad)} (" + "; ".join(f"seed {r['seed']}: {r['error']}" for r in bad) + ")")
    if not rows:
        return
    alarms = [r for r in rows if r["findings"]]
    print(f"null sets: {len(rows)} ({sum(r['captures'] == 6 for r in rows)} of six captures from two rig seeds); "
          f"masses {min(r['mass_kg'] for r in rows):.3g}-{max(r['mass_kg'] for r in rows):.3g} kg, "
          f"{min(r['f1_hz'] for r in rows):.1f}-{max(r['f1_hz'] for r in rows):.1f} Hz, damping ratio "
          f"{100 * min(r['zeta'] for r in rows):.2f}-{100 * max(r['zeta'] for r in rows):.2f} %, "
          f"SNR {min(r['snr_db'] for r in rows):.1f}-{max(r['snr_db'] for r in rows):.1f} dB")
    print(f"chain findings on the nulls (each a false alarm): {len(alarms)}/{len(rows)}"
          + (" (" + "; ".join(f"seed {r['seed']}: {','.join(k for k, _ in r['findings'])}" for r in alarms) + ")"
             if alarms else ""))
    tol = 100 * IMPULSE_MASS_TOLERANCE
    print(f"|impulse/momentum - 1| against the tolerance ({tol:g} %), and the +-5 % mass errors reported:")
    groups = [(f"tip {t}", [r for r in rows if r["tip"] == t]) for t in TIPS]
    groups += [(f"w1 T {a:g}-{b:g} rad", [r for r in rows if a <= r["w1T"] < b])
               for a, b in ((0, 0.1), (0.1, 0.3), (0.3, 1.0), (1.0, 10.0))]
    groups += [(f"damping {a:g}-{b:g} %", [r for r in rows if a <= 100 * r["zeta"] < b])
               for a, b in ((0.1, 0.5), (0.5, 2.0), (2.0, 8.1))]
    groups += [("pulse < 3 samples", [r for r in rows if r["pulse_samples"] < 3]), ("all", rows)]
    for name, g in groups:
        dev = [100 * abs(r["impulse_mass"][0] - 1) for r in g if r.get("impulse_mass")]
        if not dev:
            continue
        plus = sum(r["error_found"]["+0.05"] for r in g)
        minus = sum(r["error_found"]["-0.05"] for r in g)
        print(f"   {name:<22} sets {len(g):>4}: median {np.median(dev):.2f} %, max {max(dev):.2f} % "
              f"({max(dev) / tol:.2f}x the tolerance); +5 % found {plus}/{len(g)}, -5 % found {minus}/{len(g)}")
    cpu = [r["cpu_s"] for r in rows]
    print(f"CPU per set median {np.median(cpu):.2f} s, max {max(cpu):.2f} s, total {sum(cpu):.0f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--seeds", default="0-99", help="seeds, e.g. 0-199 or 3,7 (default: %(default)s)")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (default: %(default)s)")
    ap.add_argument("--out", metavar="FILE", help="append JSON lines here")
    ap.add_argument("--summary", metavar="FILE", help="print the rates of an earlier run")
    args = ap.parse_args()
    if args.summary:
        try:
            summary(args.summary)
        except OSError as exc:
            ap.exit(2, f"{ap.prog}: error: {exc}\n")
        return
    try:
        seeds = [s for part in args.seeds.split(",")
                 for s in (range(int(part.split("-")[0]), int(part.split("-")[1]) + 1) if "-" in part
                           else [int(part)])]
    except ValueError:
        ap.error(f"--seeds: not a list of seeds or ranges: {args.seeds!r}")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    np.seterr(all="ignore")
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        for row in pool.map(case, seeds):
            line = json.dumps(row)
            print(line, flush=True)
            if args.out:
                with open(args.out, "a") as fh:
                    fh.write(line + "\n")


if __name__ == "__main__":
    main()
