"""Poor fits on short, coarse, noisy captures: is `none` ever given over a baseline a mechanism beats?

Session 12 (issue 10 follow-up, "never `none` above the noise floor"). Two blind sets read
`Cause: none` over a poor fit: a heavy (775 kg), low-frequency (8 Hz), coarsely sampled
(512 Hz), noisy single-DOF set with a clearance, four 3.8 s captures, whose noise floor was
almost all ``d_pred`` (how far the baseline's own ill-determined refit moves under another
draw of the noise). This family draws cases of that character, built here without the blind
files:

* mass 0.5-1000 kg (log-uniform), f1 2-20 Hz, damping ratio 0.5-3 %, a polynomial spring
  (``x`` plus a soft or hard ``x^3``: the frequency moves -3..+10 % at the largest blow);
* 256 / 512 / 1000 / 2000 Hz sampling (at least 12 samples per cycle), 20-40 dB, 2-5
  captures of 15-40 cycles each (at most 4 s), blows spread 1.3-2x, a rubber tip;
* hidden: ``clearance`` (a contact spring beyond half the typical amplitude, 0.1-0.3 of
  ``k1 A`` there), ``preload`` (``F0 sign(x)``, 0.05-0.15 ``k1 A``), ``coulomb_friction``
  (0.01-0.03 ``k1 A``), or nothing (``null``: the same draws, the polynomial spring alone).

Each case runs the pipeline and the loop as ``station diagnose`` does and prints one JSON line
(cause, whether the text is a plain ``none``, the floor's parts, the best candidate).

    python benchmarks/bench_diagnose_floor.py --kinds clearance,null --seeds 100-119 --jobs 2 --out F.jsonl
    python benchmarks/bench_diagnose_floor.py --summary F.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

KINDS = ("clearance", "preload", "coulomb_friction", "null")


def recipe(kind: str, seed: int, snr_range: tuple[float, float] = (20.0, 40.0)) -> tuple[list, dict]:
    """The records of one case (``kind`` hidden, drawn from ``seed``) and what was drawn.
    ``snr_range``: the noise drawn in [20, 40] dB is mapped onto it (the same system otherwise)."""
    from eddi.conditioning import condition
    from eddi.diagnosis import Record
    from eddi.model import EquationOfMotion
    from simulated_rig.bench import impact_test
    from simulated_rig.hammer import HammerSpec
    from simulated_rig.systems import hide_effect

    rng = np.random.default_rng(50_000 + seed)  # the same system for every kind of a seed
    mass = float(np.exp(rng.uniform(np.log(0.5), np.log(1000.0))))
    f1 = float(rng.uniform(2.0, 20.0))
    zeta = float(rng.uniform(0.005, 0.03))
    rates = [r for r in (256.0, 512.0, 1000.0, 2000.0) if r >= 12 * f1]
    rate = float(rng.choice(rates))
    snr = float(rng.uniform(20.0, 40.0))
    snr = snr_range[0] + (snr - 20.0) / 20.0 * (snr_range[1] - snr_range[0])
    captures = int(rng.integers(2, 6))
    record_s = min(float(rng.uniform(15.0, 40.0)) / f1, 4.0)
    spread = float(rng.uniform(1.3, 2.0))
    shift = float(rng.uniform(-0.03, 0.10))
    mag = float(rng.uniform(0.0, 1.0))  # the hidden effect's strength within its range
    k1 = mass * (2 * math.pi * f1) ** 2
    top = 2000.0 * mass / 10.0  # a rubber-tip blow of ~0.2 m/s on any mass
    hammer = HammerSpec(tip="rubber")
    lin = EquationOfMotion.create(mass=mass, damping={"v": 2 * zeta * math.sqrt(k1 * mass)}, stiffness={"x": k1})
    r0 = impact_test(lin, top, rate_hz=4000.0, pretrigger_s=0.01, record_s=min(1.0, 2.0 / f1), snr_db=None,
                     hammer=hammer, seed=0)
    amp, vel = float(np.max(np.abs(r0.truth_x))), float(np.max(np.abs(r0.truth_v)))
    k3 = shift * 8 * k1 / (3 * amp ** 2)  # ~shift of the frequency at the top blow's amplitude
    eom = EquationOfMotion.create(mass=mass, damping={"v": 2 * zeta * math.sqrt(k1 * mass)},
                                  stiffness={"x": k1, "x^3": k3})
    truth, strength = eom, 0.0
    if kind == "clearance":
        strength = 0.1 + 0.2 * mag
        truth = hide_effect(eom, "clearance", strength, seed, amplitude_m=amp, velocity_m_s=vel)
    elif kind == "coulomb_friction":
        strength = 0.01 + 0.02 * mag
        truth = hide_effect(eom, "coulomb_friction", strength, seed, amplitude_m=amp, velocity_m_s=vel)
    elif kind == "preload":
        strength = 0.05 + 0.1 * mag
        truth = eom.model_copy(update={"stiffness": {**eom.stiffness, "sign(x)": strength * k1 * amp}})
    elif kind != "null":
        raise ValueError(f"unknown kind {kind!r}")
    levels = list(np.geomspace(1.0 / spread, 1.0, captures))
    rng.shuffle(levels)
    recs = []
    for i, lev in enumerate(levels):
        r = impact_test(truth, top * float(lev), rate_hz=rate, pretrigger_s=0.3, record_s=record_s, snr_db=snr,
                        hammer=hammer, seed=1000 * seed + 10 * i + 1)
        c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
        recs.append(Record.from_conditioned(c, label=f"impact {i + 1}", pretrigger_samples=r.pretrigger_samples))
    return recs, {"mass_kg": mass, "f1_hz": f1, "zeta": zeta, "rate_hz": rate, "snr_db": snr, "captures": captures,
                  "record_s": record_s, "spread": spread, "shift": shift, "strength": strength}


def run_case(args: tuple) -> dict:
    kind, seed, snr_range = args
    from eddi.diagnosis import diagnose
    from eddi.diagnosis.pipeline_base import pipeline_baseline
    from eddi.terms import DEFAULT_STIFFNESS

    t0 = time.process_time()
    try:
        recs, info = recipe(kind, seed, snr_range)
        pipe = pipeline_baseline(recs, info["mass_kg"], stiffness=DEFAULT_STIFFNESS)
        d = diagnose(recs, info["mass_kg"], stiffness=DEFAULT_STIFFNESS, pipeline=pipe)
    except Exception as exc:  # a refusal is a result too
        return {"kind": kind, "seed": seed, "error": f"{type(exc).__name__}: {exc}", "cpu_s": time.process_time() - t0}
    fl = d.noise_floor
    tried = [c for c in d.candidates if not c.skipped and c.model is not None]
    return {"kind": kind, "seed": seed, **info, "cause": d.cause,
            "plain_none": d.verdict.startswith("Cause: none.") and not any("uncertain" in n for n in d.notes),
            "judged": d.judging.nrmse, "judged_fold": list(d.judging.fold_nrmse),
            "pipeline": d.pipeline.nrmse if d.pipeline is not None else None,
            "floor": fl.nrmse, "floor_fold": list(fl.fold_nrmse), "cond": list(fl.part_conditioning_nrmse),
            "data_floor": fl.data_nrmse, "data_fold": list(fl.data_fold_nrmse),
            "pred": list(fl.prediction_nrmse), "chain": list(fl.chain_nrmse), "partial": d.partial,
            "candidates": [[c.name, round(c.nrmse, 5), [round(v, 5) for v in c.fold_nrmse], round(c.gain, 4),
                            c.reference, c.wins_every_part, c.consistent, bool(c.contradicted)] for c in tried],
            "symptoms": {s.kind: s.values for s in d.symptoms if s.kind in ("frequency_bias", "energy_mismatch", "growth",
                                                                               "low_frequency_drift")},
            "notes": list(d.notes), "verdict": d.verdict, "cpu_s": time.process_time() - t0}


def parse_seeds(spec: str) -> list[int]:
    out = []
    for part in spec.split(","):
        a, _, b = part.strip().partition("-")
        out += list(range(int(a), int(b) + 1)) if b else [int(a)]
    return out


def summary(path: str) -> None:
    rows = [json.loads(s) for s in open(path) if s.strip()]
    for kind in KINDS:
        got = [r for r in rows if r["kind"] == kind]
        if not got:
            continue
        causes: dict[str, int] = {}
        for r in got:
            c = r.get("cause", "error")
            c = "none (plain)" if c == "none" and r.get("plain_none") else ("none (uncertain)" if c == "none" else c)
            causes[c] = causes.get(c, 0) + 1
        print(f"{kind}: {len(got)} cases: " + ", ".join(f"{k} {v}" for k, v in sorted(causes.items())))
        for r in got:
            if "error" in r:
                print(f"   seed {r['seed']}: {r['error']}")
                continue
            best = max(r["candidates"], key=lambda c: 1 - c[1] / r["judged"] if c[5] else -9, default=None)
            print(f"   seed {r['seed']:>5} {r['mass_kg']:7.1f} kg {r['f1_hz']:5.1f} Hz {r['rate_hz']:5.0f} Hz "
                  f"{r['snr_db']:4.1f} dB {r['captures']} cap -> {r['cause']:<18}{'plain' if r['plain_none'] else '':6}"
                  f"judged {r['judged']:.3g} floor {r['floor']:.3g} data {r.get('data_floor', r['floor']):.3g} "
                  f"(pred {np.mean(r['pred']):.3g} cond "
                  f"{np.mean(r['cond']):.3g}) best {best[0] if best else '-'} "
                  f"{(1 - best[1] / r['judged']) if best else 0:+.2f}{'' if not best or best[6] else ' inconsistent'}"
                  f"{'' if not best or best[5] else ' loses a part'} cpu {r['cpu_s']:.0f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--seeds", default="100-104")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", metavar="FILE")
    ap.add_argument("--snr", default="20,40", metavar="LO,HI",
                    help="the noise range in dB (the drawn value mapped onto it; default 20,40)")
    ap.add_argument("--summary", metavar="FILE")
    args = ap.parse_args()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    np.seterr(all="ignore")
    if args.summary:
        summary(args.summary)
        return
    lo, hi = (float(v) for v in args.snr.split(","))
    tasks = [(k, s, (lo, hi)) for s in parse_seeds(args.seeds) for k in args.kinds.split(",")]
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        for row in pool.map(run_case, tasks):
            line = json.dumps(row)
            print(line, flush=True)
            if args.out:
                with open(args.out, "a") as fh:
                    fh.write(line + "\n")


if __name__ == "__main__":
    main()
