"""EDDI vs SINDy on the acceleration-only chain (force + accelerometer at 60, 45, 30 dB).

For each system of ``tests/eddi/impact_cases.py``, each SNR (force and accelerometer,
24-bit) and each seed, the record is conditioned once (``eddi.conditioning.condition``) and
every method gets the same conditioned signals over the same free-response window and the
same candidate terms (the system's own terms); SINDy's STLSQ threshold is the paper's 0.05
(Sec. 3.3.1). Methods:

* ``EDDI``: ``eddi.identify`` (route auto), the paper's method as implemented;
* ``EDDI+ref``: the same, then ``refine=True`` (output-error fit of the free response to
  the measured acceleration, starting from the EDDI estimate; ``eddi/refine.py``);
* ``SINDy-paper``: pysindy fed the conditioned state ``(x, v)``, differentiating it itself
  (default ``FiniteDifference``), as the paper used SINDy;
* ``SINDy+a``: pysindy given the measured acceleration (the stronger baseline).

Error of a method: mean over the true coefficients of ``|identified / exact - 1|``. Printed:
errors, run times, and the ratios of EDDI's error to SINDy's (goal of the engine issue:
EDDI's error at most half of SINDy's on this chain).

Last, the displacement error of the conditioning (relative L2 over the free window, seed 1)
against the paper's integrate + 3rd-order zero-phase Butterworth high-pass at 2 Hz
(``docs/conditioning.md``).

First, unless ``--no-paper``, the paper's two simulated cases (Duffing, pendulum; clean and
with 60 dB white noise on ``x, v``) through ``benchmarks/bench_paper_cases.py``: the same
methods side by side with the paper's own figures.

Run: ``python benchmarks/bench_accel_chain.py [--seeds 1 2 3] [--no-paper]`` (about 15 s per
seed, 20 s for the paper cases).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from eddi.conditioning import condition, integrate_highpass  # noqa: E402
from eddi.identify import identify  # noqa: E402
from eddi.model import EquationOfMotion  # noqa: E402
from eddi.sindy import sindy_identify  # noqa: E402
from tests.eddi.impact_cases import SYSTEMS, impact_record  # noqa: E402

METHODS = ("EDDI", "EDDI+ref", "SINDy-paper", "SINDy+a")


def coef_error(eom: EquationOfMotion, truth: dict) -> float:
    """Mean over the true coefficients of ``|identified / exact - 1|``."""
    errs = []
    for group in ("damping", "stiffness"):
        for term, c in truth[group].items():
            errs.append(abs(getattr(eom, group)[term] / c - 1))
    return float(np.mean(errs))


def run_case(name: str, snr: float, seed: int) -> tuple[dict[str, float], dict[str, float]]:
    """Errors and run times [s] of every method on one record."""
    spec = SYSTEMS[name]
    r = impact_record(name, snr_db=snr, seed=seed)
    cond = condition(r.t, acc=r.acc, force=r.force)
    d, k, m = tuple(spec["damping"]), tuple(spec["stiffness"]), spec["mass"]
    w0, w1 = cond.window
    tw, xw, vw, aw = cond.t[w0:w1], cond.x[w0:w1], cond.v[w0:w1], cond.a[w0:w1]
    err: dict[str, float] = {}
    sec: dict[str, float] = {}
    t0 = time.perf_counter()
    model = identify(tw, xw, vw, m, damping=d, stiffness=k, a=aw)
    sec["EDDI"] = time.perf_counter() - t0
    err["EDDI"] = coef_error(model.eom, spec)
    t0 = time.perf_counter()
    refined = identify(tw, xw, vw, m, damping=d, stiffness=k, a=aw, refine=True)
    sec["EDDI+ref"] = time.perf_counter() - t0
    err["EDDI+ref"] = coef_error(refined.eom, spec)
    assert refined.unrefined is not None and coef_error(refined.unrefined, spec) == err["EDDI"]
    for label, acc in (("SINDy-paper", None), ("SINDy+a", aw)):
        t0 = time.perf_counter()
        s_eom = sindy_identify(tw, xw, vw, acc, m, damping=d, stiffness=k, threshold=0.05)
        sec[label] = time.perf_counter() - t0
        err[label] = coef_error(s_eom, spec)
    return err, sec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--no-paper", action="store_true", help="skip the paper's simulated cases")
    args = ap.parse_args()
    seeds = args.seeds
    if not args.no_paper:
        import bench_paper_cases as paper  # benchmarks/ is on sys.path when run as a script

        rng = np.random.default_rng(0)
        for case in (paper.duffing_case(), paper.pendulum_case()):
            paper.run_case(case, None, rng)
            paper.run_case(case, 60.0, rng)
        print()
    head = " ".join(f"{m:>11s}" for m in METHODS)
    print(f"{'system':12s} {'SNR':>3s} {'seed':>4s} | coefficient error: {head} | run time [s]: {head}")
    rows = []
    for snr in (60.0, 45.0, 30.0):
        for name in SYSTEMS:
            for seed in seeds:
                err, sec = run_case(name, snr, seed)
                rows.append((snr, err))
                print(f"{name:12s} {snr:3.0f} {seed:4d} | {'':19s}"
                      + " ".join(f"{100 * err[m]:10.3f}%" for m in METHODS)
                      + f" | {'':14s}" + " ".join(f"{sec[m]:11.2f}" for m in METHODS))
    print()
    print("ratio of errors (per record), median and worst; goal: EDDI / SINDy <= 0.5")
    for snr_sel in (60.0, 45.0, 30.0, None):
        sel = [e for s, e in rows if snr_sel is None or s == snr_sel]
        label = "all SNR" if snr_sel is None else f"{snr_sel:.0f} dB"
        parts = []
        for num in ("EDDI", "EDDI+ref"):
            for den in ("SINDy-paper", "SINDy+a"):
                q = np.array([e[num] / e[den] if e[den] > 0 else np.inf for e in sel])
                parts.append(f"{num}/{den} {np.median(q):.2f} (worst {np.max(q):.2f})")
        print(f"  {label:8s} " + "; ".join(parts))
    print()
    print("displacement error of the conditioning over the free window (seed 1): ours vs integrate + HP 2 Hz")
    for snr in (60.0, 45.0, 30.0):
        cells = []
        for name in SYSTEMS:
            r = impact_record(name, snr_db=snr, seed=1)
            cond = condition(r.t, acc=r.acc, force=r.force)
            w0, w1 = cond.window
            xh, _ = integrate_highpass(r.t, r.acc, 2.0)
            ref = np.linalg.norm(r.x[w0:w1])
            ours = np.linalg.norm(cond.x[w0:w1] - r.x[w0:w1]) / ref
            hp = np.linalg.norm(xh[w0:w1] - r.x[w0:w1]) / ref
            cells.append(f"{name} {100 * ours:.2f} % vs {100 * hp:.1f} %")
        print(f"  {snr:.0f} dB: " + "; ".join(cells))


if __name__ == "__main__":
    main()
