"""The pipeline against its regression peers on the same conditioned signals.

For each system, SNR (force and accelerometer, 24-bit) and seed, an impact record is
simulated (``tests/eddi/impact_cases.py``), conditioned once by the pipeline
(``eddi.fit_record.Pipeline.condition``), and every method gets the same conditioned signals
over the same free-response window and the same candidate terms (the system's own):

* ``pipeline``: ``Pipeline(...).fit`` as every ``station`` command runs it (EDDI, output-error
  refinement kept when it lowers the validation error, BIC term selection);
* ``EDDI``: the same pipeline with ``refine=False`` (the paper's method as implemented);
* ``STLSQ``: pysindy's ``SINDy`` with ``STLSQ`` (paper threshold 0.05, column-normalised), given
  the measured acceleration (its strongest use, ``eddi.sindy``);
* ``STLSQ-0``: the same with threshold 0 (plain least squares on the true terms);
* ``weak``: weak-form SINDy (pysindy ``WeakPDELibrary`` around the same ``CustomLibrary``,
  ``K`` test functions, threshold 0: the weak form needs no derivative of the state), with the
  better of two test-function supports per record (pysindy's default and one period), chosen
  with the truth: an oracle choice, generous to the peer.

Error of a method on one record: mean over the true coefficients of ``|c / c_true - 1|`` (a
dropped true term counts 1). Printed: for each SNR, the median and the worst error of each
method over systems x seeds, and the ratios pipeline / peer and EDDI / peer (goal: pipeline
<= 1 for median and worst against every peer; EDDI <= 1.5).

Systems: the four of ``impact_cases.SYSTEMS`` plus two not used to tune anything
(``coarse_50hz``: 41 samples a period at 2048 Hz; ``soft_heavy``: 4 Hz, 5 kg at 1 kHz).

Held-out systems (``--held-out``, :data:`HELD`): five more, of other masses, frequencies, rates
and kinds, kept out of the development of phase two's slow-error columns.

Second held-out set (``--held-out-2``, :data:`HELD2`): six more, built in session 6 before
its changes and run only to report on them.

Run: ``python benchmarks/bench_vs_sindy.py [--snr 45 30] [--seeds 1 2] [--systems ...] [--held-out | --held-out-2] [--K 200]``
(about 20-40 s per record on a loaded 2-core machine).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from eddi.fit_record import Pipeline, highest_frequency  # noqa: E402
from eddi.model import EquationOfMotion  # noqa: E402
from eddi.sindy import sindy_identify  # noqa: E402
from eddi.terms import parse_terms  # noqa: E402
from tests.eddi.impact_cases import SYSTEMS, impact_record  # noqa: E402

METHODS = ("pipeline", "EDDI", "STLSQ", "STLSQ-0", "weak")
PEERS = ("STLSQ", "STLSQ-0", "weak")

#: Systems kept out of every tuning loop: (spec, rate [Hz], duration [s], pre-trigger [s], pulse [s]).
EXTRA = {
    "coarse_50hz": (dict(mass=1.0, damping={"v": 6.28}, stiffness={"x": 98696.0, "x^3": 2.8e8}, peak_n=1000.0),
                    2048.0, 3.0, 0.5, 3e-3),
    "soft_heavy": (dict(mass=5.0, damping={"v": 4.0}, stiffness={"x": 3200.0, "x^3": 2.0e6}, peak_n=900.0),
                   1000.0, 12.0, 1.0, 4e-3),
}

#: Held-out systems (session 5): never looked at while the phase-two changes of
#: ``eddi/slow_errors.py`` were developed (on the six above); other masses, frequencies,
#: rates and kinds. Hammer peaks aim at the stated peak displacement.
HELD = {
    # 25 Hz, quadratic + cubic stiffness (30 % / 50 % of k1 x at 1 mm), 8 kHz
    "quad_light": (dict(mass=0.2, damping={"v": 1.88}, stiffness={"x": 4935.0, "x^2": 1.48e6, "x^3": 2.47e9},
                        peak_n=25.0), 8000.0, 2.5, 0.3, 2e-3),
    # 8 Hz softening (-15 % at 5 mm), 2 kHz
    "soft_mid": (dict(mass=1.5, damping={"v": 3.0}, stiffness={"x": 3790.0, "x^3": -2.27e7}, peak_n=147.0),
                 2000.0, 6.0, 0.5, 4e-3),
    # 80 Hz hardening (+100 % at 0.2 mm), 100 samples a period
    "fast_hard": (dict(mass=0.05, damping={"v": 1.0}, stiffness={"x": 12633.0, "x^3": 3.16e11}, peak_n=7.9),
                  8000.0, 1.2, 0.2, 1e-3),
    # 3 Hz, 4 kg, quadratic + cubic, 1 kHz
    "asym_slow": (dict(mass=4.0, damping={"v": 4.52}, stiffness={"x": 1421.0, "x^2": 3.55e4, "x^3": 7.1e6},
                       peak_n=237.0), 1000.0, 12.0, 1.0, 5e-3),
    # 15 Hz hardening with x^2 v damping, 5 kHz
    "nld_mid": (dict(mass=0.5, damping={"v": 0.94, "x^2*v": 4.7e5}, stiffness={"x": 4441.0, "x^3": 6.66e8},
                     peak_n=74.0), 5000.0, 5.0, 0.5, 2e-3),
}

#: Second held-out set (session 6): built before the session's changes to phase one/two and
#: to the refinement judge, and run only to report, never while tuning; other masses (0.02 -
#: 10 kg), frequencies (2 - 150 Hz), rates (27 - 250 samples a period) and mechanisms
#: (softening, cubic damping, quintic stiffness, very light damping). Peaks aim at the
#: stated nonlinearity at the first peak.
HELD2 = {
    # 2 Hz, 10 kg, k2 X / k1 = 0.25 and k3 X^2 / k1 = 0.4 at 20 mm, 500 Hz
    "heavy_quad": (dict(mass=10.0, damping={"v": 2.513}, stiffness={"x": 1579.14, "x^2": 1.974e4, "x^3": 1.579e6},
                        peak_n=493.5), 500.0, 20.0, 1.0, 8e-3),
    # 150 Hz hardening (+80 % at 0.2 mm), 27 samples a period at 4 kHz
    "coarse_hard": (dict(mass=0.02, damping={"v": 0.377}, stiffness={"x": 17765.3, "x^3": 3.553e11}, peak_n=11.84),
                    4000.0, 1.0, 0.1, 5e-4),
    # 10 Hz softening (-12 % at 4 mm), 0.1 kg, 2 kHz
    "soft_light": (dict(mass=0.1, damping={"v": 0.1257}, stiffness={"x": 394.78, "x^3": -2.961e6}, peak_n=13.16),
                   2000.0, 5.0, 0.5, 3e-3),
    # 6 Hz hardening with cubic damping (b3 v^2 ~ 0.6 b1 at the first peak), 1 kHz
    "cubic_damp": (dict(mass=1.0, damping={"v": 0.6032, "v^3": 4.24}, stiffness={"x": 1421.22, "x^3": 8.527e6},
                        peak_n=148.0), 1000.0, 8.0, 0.5, 4e-3),
    # 20 Hz, cubic and quintic stiffness (30 % / 30 % of k1 x at 2 mm), 5 kHz
    "quintic": (dict(mass=0.3, damping={"v": 0.754}, stiffness={"x": 4737.41, "x^3": 3.553e8, "x^5": 8.883e13},
                     peak_n=59.22), 5000.0, 3.0, 0.3, 2e-3),
    # 30 Hz, 0.3 % damping (long ring-down), 6 kHz
    "long_light": (dict(mass=0.8, damping={"v": 0.9048}, stiffness={"x": 28424.5, "x^3": 1.421e10}, peak_n=157.9),
                   6000.0, 8.0, 0.5, 1.5e-3),
}


def coef_error(eom: EquationOfMotion, truth: dict) -> float:
    """Mean over the true coefficients of ``|identified / exact - 1|`` (missing term: 1)."""
    errs = []
    for group in ("damping", "stiffness"):
        for term, c in truth[group].items():
            got = getattr(eom, group).get(term)
            errs.append(1.0 if got is None else abs(got / c - 1))
    return float(np.mean(errs))


def weak_sindy(t: np.ndarray, x: np.ndarray, v: np.ndarray, mass: float, terms: list[str], k_test: int,
               periods: float | None, freq_hz: float, threshold: float = 0.0) -> EquationOfMotion:
    """Weak-form SINDy (pysindy ``WeakPDELibrary``) on the state ``(x, v)``: ``m v' = -sum c f``.

    Test-function support ``H_xt``: ``periods`` periods of ``freq_hz``, or pysindy's default
    (1/20 of the record) for None. Measured: the default works on long records of many
    cycles (0.2 % on paper_do) and fails on short ones (170-200 %); one period is better
    there, two periods fail everywhere (the oscillation integrates out).
    """
    import pysindy as ps

    parsed = parse_terms(terms)
    fl = ps.CustomLibrary(library_functions=[(lambda tm: (lambda p, q: tm(p, q)))(tm) for tm in parsed],
                          function_names=[(lambda nm: (lambda p, q: nm))(tm.text) for tm in parsed])
    extra = {} if periods is None else {"H_xt": [min(periods / freq_hz, 0.25 * float(t[-1] - t[0]))]}
    lib = ps.WeakPDELibrary(function_library=fl, spatiotemporal_grid=t, K=k_test, p=4, **extra)
    model = ps.SINDy(optimizer=ps.STLSQ(threshold=threshold, alpha=0.0, normalize_columns=True), feature_library=lib)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.fit(np.column_stack([x, v]), t=t, feature_names=["x", "v"])
    c = -mass * np.asarray(model.coefficients())[1]
    damping = {tm.text: float(ci) for tm, ci in zip(parsed, c) if tm.depends_on_v}
    stiffness = {tm.text: float(ci) for tm, ci in zip(parsed, c) if not tm.depends_on_v}
    return EquationOfMotion.create(mass=mass, damping=damping, stiffness=stiffness)


def record(name: str, snr: float, seed: int):
    """The simulated record and its true spec."""
    table = {**EXTRA, **HELD, **HELD2}
    if name in table:
        spec, rate, dur, pre, pulse = table[name]
        return impact_record(spec, rate_hz=rate, duration_s=dur, pretrigger_s=pre, pulse_s=pulse, snr_db=snr,
                             seed=seed), spec
    return impact_record(name, snr_db=snr, seed=seed), SYSTEMS[name]


def run_case(name: str, snr: float, seed: int, k_test: int,
             weak_periods: float, weak: bool = True) -> tuple[dict[str, float], dict[str, float]]:
    """Errors and run times [s] of every method on one record."""
    r, spec = record(name, snr, seed)
    d, k, m = tuple(spec["damping"]), tuple(spec["stiffness"]), spec["mass"]
    pipe = Pipeline(damping=d, stiffness=k)
    cond = pipe.condition(r.t, acc=r.acc, force=r.force)
    w0, w1 = cond.window
    tw, xw, vw, aw = cond.t[w0:w1], cond.x[w0:w1], cond.v[w0:w1], cond.a[w0:w1]
    err: dict[str, float] = {}
    sec: dict[str, float] = {}

    def timed(label: str, fn) -> None:
        t0 = time.perf_counter()
        eom = fn()
        sec[label] = time.perf_counter() - t0
        err[label] = coef_error(eom, spec)

    timed("pipeline", lambda: pipe.fit(cond, m).model.eom)
    timed("EDDI", lambda: Pipeline(damping=d, stiffness=k, refine=False).fit(cond, m).model.eom)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        timed("STLSQ", lambda: sindy_identify(tw, xw, vw, aw, m, damping=d, stiffness=k, threshold=0.05))
        timed("STLSQ-0", lambda: sindy_identify(tw, xw, vw, aw, m, damping=d, stiffness=k, threshold=0.0))
    if not weak:
        err["weak"], sec["weak"] = float("nan"), 0.0
        return err, sec
    f_hz = highest_frequency(cond)
    # the better of two supports, chosen with the truth (an oracle: generous to the peer)
    t0 = time.perf_counter()
    err["weak"] = min(coef_error(weak_sindy(tw, xw, vw, m, list(d) + list(k), k_test, h, f_hz), spec)
                      for h in (None, weak_periods))
    sec["weak"] = time.perf_counter() - t0
    return err, sec


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--snr", type=float, nargs="+", default=[45.0, 30.0], help="SNRs [dB] (default: 45 30)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2], help="noise seeds (default: 1 2)")
    ap.add_argument("--systems", nargs="+", default=sorted(SYSTEMS) + sorted(EXTRA),
                    help="systems (default: all of impact_cases.SYSTEMS and the two unseen ones)")
    ap.add_argument("--held-out", action="store_true",
                    help=f"run the held-out systems instead ({', '.join(HELD)}; not used to develop anything)")
    ap.add_argument("--held-out-2", action="store_true",
                    help=f"run the second held-out set instead ({', '.join(HELD2)}; session 6, report only)")
    ap.add_argument("--K", type=int, default=300, help="weak SINDy: number of test functions (default: 300)")
    ap.add_argument("--weak-periods", type=float, default=1.0,
                    help="weak SINDy: the second test-function support tried, in periods of the response "
                         "(default: 1; the first is pysindy's default; the better of the two is kept)")
    ap.add_argument("--skip-weak", action="store_true",
                    help="leave weak SINDy out (most of the run time); its column prints nan")
    args = ap.parse_args(argv)
    if args.held_out:
        args.systems = list(HELD)
    if args.held_out_2:
        args.systems = list(HELD2)
    verdicts = []
    for snr in args.snr:
        rows: dict[str, list[float]] = {mth: [] for mth in METHODS}
        secs: dict[str, list[float]] = {mth: [] for mth in METHODS}
        print(f"\n== {snr:g} dB: coefficient error, mean |c / c_true - 1| over the true terms ==")
        print(f"{'system':<13}{'seed':>5}" + "".join(f"{mth:>11}" for mth in METHODS))
        for name in args.systems:
            for seed in args.seeds:
                err, sec = run_case(name, snr, seed, args.K, args.weak_periods, not args.skip_weak)
                for mth in METHODS:
                    rows[mth].append(err[mth])
                    secs[mth].append(sec[mth])
                print(f"{name:<13}{seed:>5}" + "".join(f"{err[mth]:>11.2e}" for mth in METHODS), flush=True)
        med = {mth: float(np.median(v)) for mth, v in rows.items()}
        worst = {mth: float(np.max(v)) for mth, v in rows.items()}
        print(f"{'median':<18}" + "".join(f"{med[mth]:>11.2e}" for mth in METHODS))
        print(f"{'worst':<18}" + "".join(f"{worst[mth]:>11.2e}" for mth in METHODS))
        print(f"{'mean time [s]':<18}" + "".join(f"{np.mean(secs[mth]):>11.2f}" for mth in METHODS))
        for peer in (p for p in PEERS if not (args.skip_weak and p == "weak")):
            rp = (med["pipeline"] / med[peer], worst["pipeline"] / worst[peer])
            re = (med["EDDI"] / med[peer], worst["EDDI"] / worst[peer])
            ok_p = rp[0] <= 1 and rp[1] <= 1
            ok_e = re[0] <= 1.5 and re[1] <= 1.5
            verdicts.append(ok_p and ok_e)
            print(f"  vs {peer:<8} pipeline/peer median {rp[0]:.3g} worst {rp[1]:.3g} ({'met' if ok_p else 'NOT met'}); "
                  f"EDDI/peer median {re[0]:.3g} worst {re[1]:.3g} ({'within 1.5x' if ok_e else 'NOT within 1.5x'})")
    print("\nall goals met" if all(verdicts) else "\nsome goals NOT met (see above)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
