"""Coefficient errors vs ci95 on single-DOF oscillators with asymmetric (``x^2``) stiffness.

Builds ``m x'' + c1 v + c2 x^2 v + k1 x + k2 x^2 + k3 x^3 = F`` on the simulated rig
(:func:`simulated_rig.bench.impact_test`, half-sine plastic hammer, force + IEPE accelerometer),
with ``k1 = m (2 pi f)^2``, ``c1 = 2 zeta m 2 pi f``, ``c2 = nl c1 / A^2``, ``k2 = 2 off k1 / A``
(the free response's mean offset ~ ``off`` of the amplitude ``A``) and ``k3 = hard k1 / A^2``;
the hammer's peak force is scaled so the first swing is about ``A``. Each case is identified with
the true library (``eddi.fit_record.Pipeline``, as ``station identify --damping 'v,x^2*v'
--stiffness 'x,x^2,x^3'``), EDDI alone (``--no-refine``) and refined, over seeds; prints each
coefficient's error [%], its ci95 half-width [%] and ``z = err / (ci95 / 1.96)``.

Example: ``PYTHONPATH=$PWD python benchmarks/bench_asym.py --seeds 3 --snr 50``
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from eddi.fit_record import Pipeline  # noqa: E402
from eddi.model import EquationOfMotion  # noqa: E402
from simulated_rig.bench import default_sensors, impact_test  # noqa: E402
from simulated_rig.sensors import accelerometer  # noqa: E402

DAMPING = ("v", "x^2*v")
STIFFNESS = ("x", "x^2", "x^3")
#: name: (mass [kg], f [Hz], A [m], off, hard, zeta, nl, rate [Hz])
CASES = {
    "m0.3-f20": (0.3, 20.0, 2e-3, 0.03, 0.1, 0.01, 1.0, 10000.0),
    "m0.1-f40-weaknl": (0.1, 40.0, 1e-3, 0.05, 0.1, 0.01, 0.2, 20000.0),
    "m1-f5": (1.0, 5.0, 5e-3, 0.05, 0.05, 0.02, 0.5, 5000.0),
    "m0.5-f12-strongoff": (0.5, 12.0, 3e-3, 0.08, 0.1, 0.005, 0.3, 8000.0),
    "m0.2-f30-tinynl": (0.2, 30.0, 1e-3, 0.05, 0.1, 0.01, 0.05, 5000.0),
    "m0.8-f8-softening": (0.8, 8.0, 4e-3, 0.06, -0.05, 0.01, 0.3, 5000.0),
    "m0.1-f40-off10": (0.1, 40.0, 1e-3, 0.10, 0.2, 0.005, 0.2, 5000.0),
    "m0.4-f25-off15-nl2": (0.4, 25.0, 2e-3, 0.15, 0.3, 0.005, 2.0, 5000.0),
    "m0.6-f10-negk2-nl3": (0.6, 10.0, 3e-3, -0.10, 0.2, 0.01, 3.0, 5000.0),
    "m1-f5-20k": (1.0, 5.0, 5e-3, 0.05, 0.05, 0.02, 0.5, 20000.0),
    "m0.5-f8-20k-weaknl": (0.5, 8.0, 3e-3, 0.05, 0.1, 0.01, 0.2, 20000.0),
    # the same as tinynl without the asymmetry (true k2 = 0; its error is printed relative to k1 A)
    "m1-f5-sym": (1.0, 5.0, 5e-3, 0.0, 0.05, 0.02, 0.5, 5000.0),
    "m0.2-f30-tinynl-sym": (0.2, 30.0, 1e-3, 0.0, 0.1, 0.01, 0.05, 5000.0),
}


def system(m: float, f: float, amp: float, off: float, hard: float, zeta: float, nl: float) -> EquationOfMotion:
    """The model of one case (see the module notes)."""
    w = 2 * np.pi * f
    k, c = m * w * w, 2 * zeta * m * w
    return EquationOfMotion(mass=m, damping={"v": c, "x^2*v": nl * c / amp**2},
                            stiffness={"x": k, "x^2": 2 * off * k / amp, "x^3": hard * k / amp**2})


def peak_force(eom: EquationOfMotion, amp: float, rate: float) -> float:
    """Peak hammer force [N] whose first swing is ~``amp`` (two noise-free trial hits)."""
    peak = 1.0
    for _ in range(3):
        r = impact_test(eom, peak, rate_hz=rate, snr_db=None, pretrigger_s=0.1, record_s=0.5)
        peak *= amp / float(np.max(np.abs(r.truth_x)))
    return peak


def run(name: str, seeds: range, snr: float | None, verbose: bool, iepe_hz: float | None = None) -> None:
    """Print one line per seed and route (``verbose``) and a summary per term and route."""
    m, f, amp, off, hard, zeta, nl, rate = CASES[name]
    eom = system(m, f, amp, off, hard, zeta, nl)
    peak = peak_force(eom, amp, rate)
    # the scale of each coefficient (its true value, or k1 / A for a true k2 = 0)
    scale = {t: abs(c) if c else eom.stiffness["x"] / amp for g in ("damping", "stiffness")
             for t, c in getattr(eom, g).items()}
    rows: dict[tuple[str, str], list[tuple[float, float]]] = {}
    for seed in seeds:
        sensors = None
        if iepe_hz:  # an IEPE accelerometer's AC coupling the pipeline is not told about
            sensors = (default_sensors(snr)[0], accelerometer(snr_db=snr, iepe_highpass_hz=iepe_hz))
        r = impact_test(eom, peak, rate_hz=rate, snr_db=snr, seed=seed, pretrigger_s=0.2, sensors=sensors)
        for refine in (False, True):
            pipe = Pipeline(damping=DAMPING, stiffness=STIFFNESS, refine=refine)
            cond = pipe.condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
            res = pipe.fit(cond, m)
            cells = []
            for g in ("damping", "stiffness"):
                for term, c in getattr(eom, g).items():
                    got = getattr(res.model.eom, g).get(term, np.nan)
                    h = res.ci95[g].get(term, np.nan)
                    err, z = (got - c) / scale[term], (got - c) / (h / 1.96)
                    rows.setdefault(("EDDI" if not refine else "refine", term), []).append((err, z))
                    cells.append(f"{term} {100 * err:+6.2f}%±{100 * h / scale[term]:5.2f} z{z:+5.1f}")
            kind = "refined" if res.choices.refinement == "kept" else f"EDDI({res.choices.refinement})"
            kind += f" q{res.choices.decimation}"
            if verbose:
                print(f"{name:<19} seed {seed} {kind:<14} " + " | ".join(cells)
                      + (f"  WARN {len(res.choices.warnings)}" if res.choices.warnings else ""), flush=True)
    for (route, term), rz in rows.items():
        e, z = np.array(rz).T
        print(f"{name:<19} {route:<6} {term:<6} mean err {100 * e.mean():+7.2f}% (se {100 * e.std(ddof=1) / np.sqrt(e.size) if e.size > 1 else np.nan:5.2f}) "
              f"rms err {100 * np.sqrt(np.mean(e**2)):6.2f}%  covered {int(np.sum(np.abs(z) <= 1.96))}/{z.size}  "
              f"rms z {np.sqrt(np.mean(z**2)):4.2f}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=3, help="seeds per case (default 3)")
    ap.add_argument("--snr", type=float, default=50.0, help="SNR [dB] of both channels; 0: noise-free (default 50)")
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES), metavar="NAME",
                    help=f"cases (default: all of {', '.join(CASES)})")
    ap.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    ap.add_argument("--iepe-hz", type=float, default=None,
                    help="AC coupling of the accelerometer [Hz] (first-order high-pass; default none)")
    ap.add_argument("--quiet", action="store_true", help="only the summary per case, route and term")
    args = ap.parse_args()
    print(f"asymmetric-stiffness SDOF, {args.snr:g} dB (load {os.getloadavg()[0]:.1f})")
    t0 = time.perf_counter()
    for name in args.cases:
        run(name, range(args.first_seed, args.first_seed + args.seeds), None if args.snr <= 0 else args.snr,
            not args.quiet, args.iepe_hz)
    print(f"({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
