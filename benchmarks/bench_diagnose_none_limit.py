"""How far above the noise floor the baseline of a NULL lands (session 18, helper s18none).

A null hides nothing outside the model class the diagnosis fits (the default libraries: a cubic
spring and ``x^2 v`` damping are library terms, so they are still nulls). Each set is drawn from
its seed over a wider range than the calibration's nulls (``bench_diagnose_calibration.py``, which
sit mostly at the minimum floor): mass 0.05-200 kg (log-uniform), natural frequency 4-60 Hz,
damping ratio 0.2-3 %, a soft or hard cubic spring (frequency shift up to +-8 % at the strongest
blow), ``x^2 v`` damping in a third of the sets, sample rate 1-50 kHz (at least 25 samples per
cycle), SNR 28-50 dB (noisy: where the floor is above its minimum), 3 or 4 captures, the response
measured as acceleration with the force (a velocity channel made the same way was refused by the
conditioner: too few acceleration zero crossings above the noise). Each row holds
``judged_ratio`` (the judged baseline's mean held-out nrmse over the floor of the data, what the
``none`` limit is applied to) and the verdict at each factor of ``--factors``.

    python benchmarks/bench_diagnose_none_limit.py --seeds 0-39 --jobs 2 --out none-nulls.jsonl
    python benchmarks/bench_diagnose_none_limit.py --family noisy --seeds 0-19 --jobs 2 --out none-nulls.jsonl
    python benchmarks/bench_diagnose_none_limit.py --summary none-nulls.jsonl

Seeds 0-39 were looked at while the limit was set (docs/diagnosis.md, "Session 18"); 100-139 were
run only after it was fixed.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_diagnose_calibration as B  # noqa: E402

RATES = (1000.0, 2000.0, 5000.0, 10000.0, 20000.0, 50000.0)
FACTORS = (1.25, 1.5, 1.75, 2.0, 2.5, 3.0, 3.5)


#: Families: ``wide`` (the ranges of the module notes) and ``noisy`` (SNR 20-32 dB, damping ratio
#: 0.1-1 %: long, lightly damped, noisy records, where the floor is well above its minimum, as on
#: the blind records of session 18 with floors 0.08 and 0.15).
FAMILIES = {"wide": {"snr": (28.0, 50.0), "zeta": (0.002, 0.03), "offset": 90_000},
            "noisy": {"snr": (20.0, 32.0), "zeta": (0.001, 0.01), "offset": 95_000}}


def null_set(seed: int, family: str = "wide") -> tuple[list, dict]:
    """The records of one null set of ``family`` and what was drawn (module notes)."""
    from eddi.conditioning import condition
    from eddi.diagnosis import Record
    from eddi.model import EquationOfMotion
    from simulated_rig.bench import impact_test

    fam = FAMILIES[family]
    rng = np.random.default_rng(fam["offset"] + seed)
    mass = float(np.exp(rng.uniform(np.log(0.05), np.log(200.0))))
    f1 = float(np.exp(rng.uniform(np.log(4.0), np.log(60.0))))
    zeta = float(np.exp(rng.uniform(*np.log(fam["zeta"]))))
    rate = float(rng.choice([r for r in RATES if r >= 25 * f1 and r <= 2000 * f1] or [RATES[-1]]))
    snr = float(rng.uniform(*fam["snr"]))
    shift = float(rng.uniform(-0.08, 0.08))
    drag = bool(rng.random() < 1 / 3)
    rng.random()  # (was a velocity-sensor draw: the conditioner refuses a noisy velocity channel)
    sensor = "acc"
    captures = int(rng.choice((3, 4)))
    k1 = mass * (2 * math.pi * f1) ** 2
    c = 2 * zeta * math.sqrt(k1 * mass)
    top = 30.0 * mass / 0.1
    lin = EquationOfMotion.create(mass=mass, damping={"v": c}, stiffness={"x": k1})
    probe = impact_test(lin, top, rate_hz=rate, pretrigger_s=0.01, record_s=min(0.5, 5 / f1), snr_db=None, seed=0)
    amp = float(np.max(np.abs(probe.truth_x)))
    damping = {"v": c, **({"x^2*v": 0.3 * c / amp ** 2} if drag else {})}
    eom = EquationOfMotion.create(mass=mass, damping=damping,
                                  stiffness={"x": k1, "x^3": 8 * shift * k1 / (3 * amp ** 2)})
    cycles = min(60.0, 5.0 / (2 * math.pi * zeta))
    record_s = min(max(cycles, 8.0) / f1, 20_000 / rate)
    levels = (1 / 1.5, 1 / 1.22, 1.0, 1 / 1.1)[:captures]
    recs = []
    for i, lev in enumerate(levels):
        r = impact_test(eom, top * lev, rate_hz=rate, pretrigger_s=0.1, record_s=record_s, snr_db=snr,
                        seed=1000 * seed + 10 * i + 3)
        cnd = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
        recs.append(Record.from_conditioned(cnd, label=f"impact {i + 1}", pretrigger_samples=r.pretrigger_samples))
    return recs, {"mass_kg": mass, "f1_hz": f1, "zeta": zeta, "rate_hz": rate, "snr_db": snr, "shift": shift,
                  "drag": drag, "sensor": sensor, "captures": captures, "record_s": record_s}


def case(args: tuple[int, str]) -> dict:
    seed, family = args
    np.seterr(all="ignore")
    try:
        recs, info = null_set(seed, family)
        row, cpu = B._diagnose(recs, info["mass_kg"], FACTORS)
    except Exception as exc:  # a set the rig, the conditioning or the loop refuses is reported, not hidden
        return {"seed": seed, "family": family, "error": f"{type(exc).__name__}: {exc}"}
    keep = {k: row.get(k) for k in ("ratio", "baseline_nrmse", "data_floor", "floor", "pipeline_nrmse",
                                     "causes", "partial", "symptoms", "floor_parts")}
    keep["judged_ratio"] = row["baseline_nrmse"] / row["data_floor"]
    return {"seed": seed, "family": family, **info, **keep, "cpu_s": cpu}


def summary(path: str) -> None:
    rows = [json.loads(line) for line in open(path)]
    ok = [r for r in rows if "error" not in r]
    ratio = np.array([r["judged_ratio"] for r in ok])
    print(f"{len(ok)} null sets ({len(rows) - len(ok)} refused); judged baseline / floor of the data: "
          f"median {np.median(ratio):.2f}, 95th {np.quantile(ratio, 0.95):.2f}, 99th {np.quantile(ratio, 0.99):.2f}, "
          f"max {ratio.max():.2f}; floors {min(r['data_floor'] for r in ok):.3g}-{max(r['data_floor'] for r in ok):.3g}")
    for f in FACTORS:
        causes = [r["causes"].get(f"{f:g}|0.6", "?") for r in ok]
        print(f"  factor {f:g}: none {sum(c == 'none' for c in causes)}, unexplained "
              f"{sum(c == 'unexplained' for c in causes)}, named {sum(c not in ('none', 'unexplained') for c in causes)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="0-39", help="e.g. 0-39 or 100,101")
    ap.add_argument("--family", choices=sorted(FAMILIES), default="wide")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", help="append JSON lines here")
    ap.add_argument("--summary", metavar="FILE", help="print the distribution of earlier runs")
    a = ap.parse_args()
    if a.summary:
        summary(a.summary)
        return
    seeds = [int(s) for s in a.seeds.split(",")] if "-" not in a.seeds else \
        list(range(int(a.seeds.split("-")[0]), int(a.seeds.split("-")[1]) + 1))
    with ProcessPoolExecutor(a.jobs) as ex:
        for row in ex.map(case, [(s, a.family) for s in seeds]):
            line = json.dumps(row)
            print(line, flush=True)
            if a.out:
                with open(a.out, "a") as fh:
                    fh.write(line + "\n")


if __name__ == "__main__":
    main()
