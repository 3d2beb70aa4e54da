"""Term selection with the default library on short, heavily damped records (issue 9).

Each case is an oscillator of one kind (``lin``: linear; ``hard`` / ``soft``: cubic
stiffness reaching +80 % / -25 % of the linear force at ~1 mm; ``quad``: quadratic stiffness,
30 %; ``drag``: cubic damping), mass, natural frequency, damping ratio 3-15 %, sample rate
5-40 kHz and SNR 30-55 dB, hit by a 2 ms half sine to ~1 mm (``tests/eddi/impact_cases.py``:
force + accelerometer, 24-bit, white noise at the SNR of the ring-down); the record lasts
until ~8 time constants of the decay (at most 4 s) after a 0.2 s pre-trigger. The pipeline
runs with the DEFAULT library (``v, x^2*v, v^3`` / ``x .. x^5``) and must find the true terms.

Two sets: ``tune`` (the cases the selection was developed on) and ``held`` (kept out of that
loop; report them separately). Printed per case over seeds: records with a spurious term
kept, records with a true term dropped, records whose validation diverged, the median and
worst coefficient error (mean ``|c / c_true - 1|`` over the true terms, a dropped term
counting 1) and the coverage of the true coefficients by ``ci95`` (a dropped true term does
not cover), then the totals.

Run: ``python benchmarks/bench_term_selection.py [--set tune|held|both] [--seeds 10]``
(~0.1-0.3 s per record).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from eddi.fit_record import Pipeline  # noqa: E402
from tests.eddi.impact_cases import impact_record  # noqa: E402

#: (kind, mass [kg], natural frequency [Hz], damping ratio, rate [Hz], SNR [dB])
TUNE = [
    ("lin", 0.3, 31.0, 0.08, 10e3, 45.0),
    ("hard", 0.3, 31.0, 0.12, 10e3, 45.0),
    ("lin", 1.0, 12.0, 0.05, 5e3, 40.0),
    ("hard", 0.1, 60.0, 0.10, 20e3, 35.0),
    ("lin", 0.5, 25.0, 0.15, 10e3, 50.0),
    ("soft", 2.0, 8.0, 0.03, 5e3, 45.0),
    ("quad", 0.2, 40.0, 0.06, 20e3, 45.0),
    ("drag", 0.4, 20.0, 0.04, 10e3, 40.0),
]
HELD = [
    ("lin", 0.7, 18.0, 0.09, 8e3, 38.0),
    ("hard", 0.05, 90.0, 0.07, 40e3, 50.0),
    ("hard", 1.5, 10.0, 0.13, 5e3, 42.0),
    ("soft", 0.25, 45.0, 0.11, 20e3, 30.0),
    ("quad", 0.8, 22.0, 0.035, 10e3, 55.0),
    ("drag", 0.15, 50.0, 0.05, 25e3, 33.0),
    ("lin", 3.0, 6.0, 0.10, 5e3, 30.0),
]
#: Peak displacement the hammer aims at [m]; pulse width [s].
X_PEAK, PULSE_S = 1e-3, 2e-3


def system(kind: str, mass: float, hz: float, zeta: float) -> dict:
    """The true model and hammer peak of one case."""
    w = 2 * math.pi * hz
    k = mass * w**2
    c = 2 * zeta * math.sqrt(k * mass)
    damping, stiffness = {"v": c}, {"x": k}
    if kind == "hard":
        stiffness["x^3"] = 0.8 * k / X_PEAK**2
    elif kind == "soft":
        stiffness["x^3"] = -0.25 * k / X_PEAK**2
    elif kind == "quad":
        stiffness["x^2"] = 0.3 * k / X_PEAK
    elif kind == "drag":
        damping["v^3"] = 0.5 * c / (w * X_PEAK) ** 2
    peak = mass * w * X_PEAK / (2 * PULSE_S / math.pi)  # half-sine impulse = m v0
    return dict(mass=mass, damping=damping, stiffness=stiffness, peak_n=peak)


def run_case(case: tuple, seeds: list[int]) -> dict[str, list]:
    """Per seed: spurious kept, true dropped, diverged, error, covered flags."""
    kind, mass, hz, zeta, rate, snr = case
    spec = system(kind, mass, hz, zeta)
    duration = min(4.0, 8.0 / (zeta * 2 * math.pi * hz)) + 0.2
    pipe = Pipeline()
    out: dict[str, list] = {"spurious": [], "dropped": [], "diverged": [], "error": [], "covered": []}
    for seed in seeds:
        r = impact_record(spec, rate_hz=rate, duration_s=duration, pretrigger_s=0.2, pulse_s=PULSE_S,
                          snr_db=snr, seed=seed)
        res = pipe.fit(pipe.condition(r.t, acc=r.acc, force=r.force), mass)
        eom = res.model.eom
        errs = []
        for group in ("damping", "stiffness"):
            got = getattr(eom, group)
            for term, c in spec[group].items():
                errs.append(abs(got[term] / c - 1) if term in got else 1.0)
                half = res.ci95[group].get(term)
                out["covered"].append(term in got and half is not None and abs(got[term] - c) <= half)
        out["spurious"].append(any(t not in spec[g] for g in ("damping", "stiffness") for t in getattr(eom, g)))
        out["dropped"].append(any(t not in getattr(eom, g) for g in ("damping", "stiffness") for t in spec[g]))
        out["diverged"].append(bool(res.validation.diverged))
        out["error"].append(float(np.mean(errs)))
    return out


def report(name: str, cases: list[tuple], seeds: list[int]) -> None:
    print(f"\n== {name} set: default library, seeds {seeds[0]}..{seeds[-1]} ==")
    print(f"{'case':<34}{'spurious':>9}{'dropped':>8}{'diverged':>9}{'median err':>11}{'worst err':>10}"
          f"{'ci95 cover':>11}")
    tot: dict[str, list] = {"spurious": [], "dropped": [], "diverged": [], "error": [], "covered": []}
    for case in cases:
        out = run_case(case, seeds)
        for k in tot:
            tot[k] += out[k]
        kind, mass, hz, zeta, rate, snr = case
        label = f"{kind} {mass:g} kg {hz:g} Hz {100 * zeta:g}% {rate / 1e3:g} kHz {snr:g} dB"
        print(f"{label:<34}{sum(out['spurious']):>9}{sum(out['dropped']):>8}{sum(out['diverged']):>9}"
              f"{np.median(out['error']):>11.2e}{max(out['error']):>10.2e}{np.mean(out['covered']):>11.3f}", flush=True)
    n = len(tot["error"])
    print(f"{'all (' + str(n) + ' records)':<34}{sum(tot['spurious']):>9}{sum(tot['dropped']):>8}"
          f"{sum(tot['diverged']):>9}{np.median(tot['error']):>11.2e}{max(tot['error']):>10.2e}"
          f"{np.mean(tot['covered']):>11.3f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--set", choices=("tune", "held", "both"), default="both", help="which cases (default: both)")
    ap.add_argument("--seeds", type=int, default=10, help="seeds per case, from --first-seed (default: 10)")
    ap.add_argument("--first-seed", type=int, default=0, help="first noise seed (default: 0)")
    args = ap.parse_args(argv)
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    t0 = time.process_time()
    print(f"load average {os.getloadavg()[0]:.1f}")
    if args.set in ("tune", "both"):
        report("tune", TUNE, seeds)
    if args.set in ("held", "both"):
        report("held-out", HELD, seeds)
    print(f"\n({time.process_time() - t0:.0f} s CPU)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
