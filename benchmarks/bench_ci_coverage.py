"""Coverage of the pipeline's 95 % intervals (``ci95``) over seeds.

For each system and seed an impact record is simulated (``tests/eddi/impact_cases.py``:
half-sine hammer, force + accelerometer, white noise at ``--snr`` dB, 24-bit), conditioned
(``Pipeline.condition``) and identified by the pipeline with the system's own terms (``Pipeline(damping=...,
stiffness=...)``, as ``station identify --damping ... --stiffness ...`` does). For every true
coefficient, ``z = (c - c_true) / (ci95 / 1.96)``; the interval covers when ``|z| <= 1.96``.

Printed per system and overall: coverage (nominal 0.95) with its 95 % Wilson interval (the
z of one record are correlated, so the interval is somewhat optimistic), the RMS of ``z``
(1 for honest standard errors) and the mean half width relative to ``|c_true|``, split by
what the pipeline returned:

* ``refined``: the output-error fit (interval: its covariance ``s^2 (J^T J)^-1``);
* ``EDDI``: EDDI's estimate (refinement rejected by the validation, or ``--no-refine``;
  interval: its distance from the output-error fit plus that fit's interval,
  :func:`eddi.refine.bounded_intervals`).

Systems: the three nulls of ``tests/eddi/test_term_selection.py`` and the four of
``impact_cases.SYSTEMS`` (40 dB, 4 kHz, 2 s unless given).

Run: ``python benchmarks/bench_ci_coverage.py [--seeds 40] [--snr 40] [--no-refine] [--systems ...]``
(~0.1-0.5 s per record).
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
from tests.eddi.impact_cases import SYSTEMS, impact_record  # noqa: E402

NULLS = {
    "null_duffing": dict(mass=0.05, damping={"v": 0.3}, stiffness={"x": 800.0, "x^3": 2.0e8}, peak_n=35.0),
    "null_quadratic": dict(mass=0.2, damping={"v": 0.5}, stiffness={"x": 3000.0, "x^2": 4.0e5}, peak_n=40.0),
    "null_nl_damping": dict(mass=0.3, damping={"v": 0.45, "x^2*v": 1.0e4}, stiffness={"x": 1700.0}, peak_n=180.0),
}
CASES = {**NULLS, **SYSTEMS}


def wilson(k: int, n: int) -> tuple[float, float]:
    """95 % Wilson score interval of a proportion ``k / n`` (scipy.stats.binomtest; the coverage
    benchmarks share this one)."""
    if n == 0:
        return (math.nan, math.nan)
    from scipy.stats import binomtest

    ci = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
    return float(ci.low), float(ci.high)


def run_case(spec: dict, seeds: range, snr_db: float, refine: bool, rate_hz: float,
             duration_s: float) -> dict[str, list[tuple[float, float]]]:
    """``{"refined": [(z, half/|c|), ...], "EDDI": [...]}`` over seeds and true terms."""
    out: dict[str, list[tuple[float, float]]] = {"refined": [], "EDDI": []}
    pipe = Pipeline(damping=tuple(spec["damping"]), stiffness=tuple(spec["stiffness"]), refine=refine)
    for seed in seeds:
        r = impact_record(spec, rate_hz=rate_hz, duration_s=duration_s, pretrigger_s=0.2, snr_db=snr_db, seed=seed)
        res = pipe.fit(pipe.condition(r.t, acc=r.acc, force=r.force), spec["mass"])
        kind = "refined" if res.choices.refinement == "kept" else "EDDI"
        for group in ("damping", "stiffness"):
            for term, c in spec[group].items():
                half = res.ci95[group][term]
                out[kind].append(((getattr(res.model.eom, group)[term] - c) / (half / 1.959964), half / abs(c)))
    return out


def summary(rows: list[tuple[float, float]]) -> str:
    if not rows:
        return f"{'-':>32}"
    z = np.abs(np.array([r[0] for r in rows]))
    k, n = int(np.sum(z <= 1.959964)), z.size
    lo, hi = wilson(k, n)
    rel = float(np.mean([r[1] for r in rows]))
    return f"{k / n:5.3f} [{lo:.2f}, {hi:.2f}] n={n:<4d} rms z {math.sqrt(float(np.mean(z**2))):5.2f} half {rel:7.1e}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=40, help="seeds per system (default 40: seeds 0..39)")
    ap.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    ap.add_argument("--snr", type=float, default=40.0, help="SNR [dB] of both channels (default 40)")
    ap.add_argument("--rate", type=float, default=4000.0, help="sample rate [Hz] (default 4000)")
    ap.add_argument("--duration", type=float, default=2.0, help="record length [s] (default 2)")
    ap.add_argument("--no-refine", action="store_true", help="the pipeline with --no-refine (EDDI's estimate)")
    ap.add_argument("--systems", nargs="+", default=list(CASES), choices=list(CASES), metavar="NAME",
                    help=f"systems (default: all of {', '.join(CASES)})")
    args = ap.parse_args()
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    print(f"ci95 coverage, nominal 0.95: {len(seeds)} seeds x {len(args.systems)} systems, {args.snr:g} dB, "
          f"{args.rate:g} Hz x {args.duration:g} s, {'--no-refine' if args.no_refine else 'default pipeline'} "
          f"(load average {os.getloadavg()[0]:.1f})")
    print(f"{'system':<16} {'returned':<8} coverage [Wilson 95 %]  n      rms z   mean half/|c|")
    total: dict[str, list[tuple[float, float]]] = {"refined": [], "EDDI": []}
    t0 = time.perf_counter()
    for name in args.systems:
        res = run_case(CASES[name], seeds, args.snr, not args.no_refine, args.rate, args.duration)
        for kind, rows in res.items():
            total[kind] += rows
            if rows:
                print(f"{name:<16} {kind:<8} {summary(rows)}", flush=True)
    print("-" * 88)
    for kind, rows in total.items():
        print(f"{'all':<16} {kind:<8} {summary(rows)}")
    print(f"{'all':<16} {'both':<8} {summary(total['refined'] + total['EDDI'])}")
    print(f"({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
