"""Coverage of ``station identify``'s 95 % intervals over masses 1 g - 1 t, through the CLI.

``benchmarks/bench_ci_coverage.py`` and ``bench_ci_coverage_chain.py`` call the library. Here
every record goes the station's way: the simulated rig (:func:`simulated_rig.bench.impact_test`:
half-sine hammer from rest, the true equation of motion integrated over the whole record,
force sensor + accelerometer, white noise at the system's SNR, 24-bit ADC) is written to a CSV
(``t,force,acc`` at ``%.10g``, as a lab exports it) and identified by ``station identify CSV
--mass M --damping ... --stiffness ... --json`` (:func:`station.cli.main` in this process: the
same parser, reader, conditioning, pipeline and JSON as the command, without the start-up).

Systems (``SYSTEMS``): masses 1 g - 1 t, stiffness scaled so the linear frequency is 2-60 Hz,
weak and strong nonlinear damping (``v^3``, ``x^2*v``, ``v|v|``), hardening, softening and
asymmetric stiffness, 30-60 dB, 2-40 kHz. Nonlinear coefficients are set by their share at
the first peak as in ``bench_ci_coverage_chain.py`` (``v*abs(v)`` (v|v|): ``c v_p / b1``). The ``tune``
systems were used while changing the engine; the ``held-out`` ones were run only to report.

For every true coefficient ``z = (c - c_true) / (ci95 / 1.96)``; the interval covers when
``|z| <= 1.96``. Printed per system (and per term with ``--per-term``): coverage with its 95 %
Wilson interval, RMS z, mean z (bias in standard errors), mean half width / ``|c|``, how often
the refinement was kept, and how many records carried a warning about the intervals.

The ``coarse-*`` systems are point-sampled at 20-40 samples per cycle (no decimation filter);
``--rate-factor 6`` runs the same systems and seeds 6x denser, the peer their coverage is
compared with (session 10: the same within the binomial intervals, ``docs/eddi-method.md``).

Run: ``python benchmarks/bench_ci_coverage_cli.py [--set tune|held-out|coarse-tune|coarse-held-out|all]
[--seeds 20] [--systems ...] [--per-term] [--rate-factor F] [--analog-filter ORDER:FRACTION]`` (~0.1-5 s per record).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import resource
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from eddi.model import EquationOfMotion  # noqa: E402
from simulated_rig.bench import impact_test  # noqa: E402
from simulated_rig.hammer import HammerSpec  # noqa: E402
from simulated_rig.sensors import accelerometer, force_sensor  # noqa: E402

from bench_ci_coverage import wilson  # noqa: E402  (this folder: the script's own)
from station.cli import main as station_main  # noqa: E402


def _s(set_: str, mass: float, f: float, zeta: float, record: float, rate: float, snr: float, vp: float,
       stiff: dict, damp: dict, tip: str = "plastic", **chain: object) -> dict:
    return dict(set=set_, mass=mass, f=f, zeta=zeta, record=record, rate=rate, snr=snr, vp=vp, stiff=stiff,
                damp=damp, tip=tip, **chain)


#: name: set, mass [kg], f [Hz], zeta, record [s], rate [Hz], snr [dB], v_p [m/s], shares, tip
SYSTEMS: dict[str, dict] = {
    # --- tune
    "tonne_v3": _s("tune", 500.0, 5.0, 0.01, 20.0, 5000.0, 45.0, 0.05, {"x^3": 0.3}, {"v^3": 1.0}, "rubber"),
    "tonne_v3_weak": _s("tune", 800.0, 3.0, 0.008, 30.0, 2000.0, 50.0, 0.03, {"x^3": 0.2}, {"v^3": 0.2},
                        "rubber"),
    "heavy_asym_x2v": _s("tune", 300.0, 8.0, 0.01, 15.0, 10000.0, 40.0, 0.05, {"x^2": 0.3}, {"x^2*v": 1.0},
                         "rubber"),
    "gram_v3": _s("tune", 0.002, 60.0, 0.005, 4.0, 40000.0, 45.0, 0.3, {"x^3": 0.4}, {"v^3": 0.5}, "steel"),
    "kilo_vabs": _s("tune", 1.0, 20.0, 0.006, 8.0, 10000.0, 40.0, 0.15, {"x^3": -0.1}, {"v*abs(v)": 0.8}),
    "mid_x2v_30db": _s("tune", 5.0, 12.0, 0.01, 10.0, 4000.0, 30.0, 0.1, {"x^3": 0.3}, {"x^2*v": 2.0}),
    "tonne_slow_60db": _s("tune", 930.0, 1.4, 0.005, 40.0, 10000.0, 60.0, 0.02, {"x^3": -0.02}, {"v^3": 0.4},
                          "rubber"),
    "quarter_t_20k": _s("tune", 250.0, 6.0, 0.004, 20.0, 20000.0, 55.0, 0.04, {"x^3": 0.05}, {"v^3": 0.15},
                        "rubber"),
    # --- held-out (run to report, not tuned on)
    "tonne_v3_60db": _s("held-out", 1000.0, 2.0, 0.012, 40.0, 2000.0, 60.0, 0.03, {"x^3": 0.25}, {"v^3": 0.6},
                        "rubber"),
    "heavy_x2_x2v": _s("held-out", 600.0, 4.0, 0.01, 25.0, 4000.0, 40.0, 0.04, {"x^2": 0.25, "x^3": 0.2},
                       {"x^2*v": 0.5}, "rubber"),
    "milligram_vabs": _s("held-out", 0.001, 45.0, 0.004, 5.0, 20000.0, 50.0, 0.2, {"x^3": 0.3}, {"v*abs(v)": 0.3},
                         "steel"),
    "ten_kg_v3_35db": _s("held-out", 10.0, 30.0, 0.006, 6.0, 20000.0, 35.0, 0.08, {"x^3": 0.5}, {"v^3": 2.0}),
    "heavy_vabs_slow": _s("held-out", 400.0, 2.5, 0.004, 30.0, 10000.0, 55.0, 0.03, {"x^3": -0.05},
                          {"v*abs(v)": 0.5}, "rubber"),
    "light_x2v_40k": _s("held-out", 0.01, 50.0, 0.003, 4.0, 40000.0, 60.0, 0.3, {"x^3": 0.1}, {"x^2*v": 0.3},
                        "steel"),
    # --- coarse sampling (session 10, s10cov): point samples at 20-40 samples per cycle of the response
    # (rate / linear frequency; hardening raises the peak's), no decimation filter
    "coarse_gram_v3": _s("coarse-tune", 0.01, 200.0, 0.004, 4.0, 6000.0, 45.0, 0.2, {"x^3": 0.3}, {"v^3": 0.5},
                         "steel"),
    "coarse_kilo_x2v": _s("coarse-tune", 2.0, 40.0, 0.008, 8.0, 1000.0, 40.0, 0.1, {"x^2": 0.2}, {"x^2*v": 1.0}),
    "coarse_heavy_45s": _s("coarse-tune", 500.0, 5.0, 0.003, 45.0, 150.0, 50.0, 0.04, {"x^3": 0.2}, {"v^3": 0.5},
                           "rubber"),
    "coarse_mid_vabs": _s("coarse-tune", 20.0, 25.0, 0.006, 8.0, 900.0, 35.0, 0.1, {"x^3": -0.1},
                          {"v*abs(v)": 0.6}),
    "coarse_kilo_55db": _s("coarse-tune", 1.0, 80.0, 0.005, 5.0, 2000.0, 55.0, 0.15, {"x^3": 0.3}, {"v^3": 0.3}),
    # --- coarse held-out (run once at the start and once at the end, not looked at in between)
    "coarse_ho_light": _s("coarse-held-out", 0.05, 120.0, 0.005, 5.0, 3600.0, 50.0, 0.2, {"x^2": 0.15, "x^3": 0.2},
                          {"v^3": 0.4}, "steel"),
    "coarse_ho_heavy": _s("coarse-held-out", 200.0, 10.0, 0.006, 20.0, 250.0, 45.0, 0.05, {"x^3": 0.4},
                          {"x^2*v": 0.5}, "rubber"),
    "coarse_ho_30db": _s("coarse-held-out", 5.0, 60.0, 0.01, 6.0, 2400.0, 30.0, 0.15, {"x^3": 0.5}, {"v^3": 1.0}),
    "coarse_ho_55db": _s("coarse-held-out", 100.0, 15.0, 0.004, 15.0, 330.0, 55.0, 0.05, {"x^3": -0.05},
                         {"v*abs(v)": 0.3}, "rubber"),
}


def true_model(spec: dict) -> EquationOfMotion:
    """The system's equation of motion from its frequency, damping ratio and shares."""
    m, w = spec["mass"], 2.0 * math.pi * spec["f"]
    k1, b1 = m * w * w, 2.0 * spec["zeta"] * m * w
    vp = spec["vp"]
    xp = vp / w
    stiffness = {"x": k1}
    for term, share in spec["stiff"].items():
        stiffness[term] = share * k1 / xp ** (int(term.split("^")[1]) - 1)
    damping = {"v": b1}
    for term, share in spec["damp"].items():
        damping[term] = share * b1 / {"x^2*v": xp**2, "v^3": vp**2, "v*abs(v)": vp}[term]
    return EquationOfMotion.create(mass=m, damping=damping, stiffness=stiffness)


def write_csv(spec: dict, seed: int, path: Path) -> None:
    """One rig record of the system as ``t,force,acc`` (``%.10g``); optional spec keys: ``bits`` (ADC,
    default 24), ``iepe`` (accelerometer AC-coupling corner [Hz], not told to the station), ``pre``
    (pre-trigger [s], default 0.3)."""
    eom = true_model(spec)
    hammer = HammerSpec(tip=spec["tip"])
    peak = spec["mass"] * spec["vp"] * math.pi / (2.0 * hammer.width_s)
    bits = spec.get("bits", 24)
    sensors = (force_sensor(adc_bits=bits),
               accelerometer(snr_db=spec["snr"], adc_bits=bits, iepe_highpass_hz=spec.get("iepe")))
    r = impact_test(eom, peak, rate_hz=spec["rate"], pretrigger_s=spec.get("pre", 0.3), record_s=spec["record"], sensors=sensors,
                    hammer=hammer, seed=seed)
    acc = r.acc_m_s2
    if spec.get("aaf"):  # an analog anti-alias filter before the ADC: Butterworth (order, cutoff / rate), bilinear
        from scipy import signal

        order, frac = spec["aaf"]
        b, a = signal.butter(order, 2.0 * math.pi * frac * spec["rate"], analog=True)
        acc = signal.lfilter(*signal.bilinear(b, a, spec["rate"]), acc)
    np.savetxt(path, np.column_stack((r.t, r.force_n, acc)), delimiter=",", header="t,force,acc",
               comments="", fmt="%.10g")


def identify_cli(spec: dict, path: Path, extra: tuple[str, ...] = ()) -> dict:
    """``station identify PATH --mass ... --damping ... --stiffness ... --json``, parsed."""
    eom = true_model(spec)
    argv = ["identify", str(path), "--mass", repr(spec["mass"]), "--damping", ",".join(eom.damping),
            "--stiffness", ",".join(eom.stiffness), "--json", *extra]
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = station_main(argv)
    if code not in (0, 1):
        raise RuntimeError(f"station identify exit {code}: {err.getvalue().strip()}")
    return json.loads(out.getvalue())


def _coef(js: dict, group: str, term: str) -> tuple[float | None, float]:
    got = js.get(group, {}).get(term)
    half = js.get("ci95", {}).get(group, {}).get(term, math.nan)
    return got, half


def run_case(spec: dict, seeds: range, tmp: Path, extra: tuple[str, ...] = ()) -> tuple[dict, int, int]:
    """``({term: [(z, half/|c|, rel err), ...]}, records refined, records with an interval warning)``."""
    eom = true_model(spec)
    truth = {"damping": dict(eom.damping), "stiffness": dict(eom.stiffness)}
    out: dict[str, list[tuple[float, float, float]]] = {}
    kept = warned = 0
    for seed in seeds:
        path = tmp / f"rec{seed}.csv"
        write_csv(spec, seed, path)
        js = identify_cli(spec, path, extra)
        kept += js["pipeline"]["refinement"] == "kept"
        warned += any("interval" in w or "poorly determined" in w for w in js["warnings"])
        for group, terms in truth.items():
            for term, c in terms.items():
                got, half = _coef(js, group, term)
                z = math.inf if got is None or not half > 0 else (got - c) / (half / 1.959964)
                out.setdefault(term, []).append((z, half / abs(c), math.nan if got is None else got / c - 1))
    return out, kept, warned




def summary(rows: list[tuple[float, float, float]]) -> str:
    z = np.array([r[0] for r in rows])
    k, n = int(np.sum(np.abs(z) <= 1.959964)), z.size
    lo, hi = wilson(k, n)
    fin = z[np.isfinite(z)]
    rms = math.sqrt(float(np.mean(fin**2))) if fin.size else math.nan
    mean = float(np.mean(fin)) if fin.size else math.nan
    err = np.array([r[2] for r in rows])
    return (f"{k / n:5.3f} [{lo:.2f}, {hi:.2f}] n={n:<4d} rms z {rms:5.2f} mean z {mean:+5.2f} "
            f"half {float(np.nanmean([r[1] for r in rows])):7.1e} rms err {math.sqrt(float(np.nanmean(err**2))):7.1e}")


def _cpu() -> float:
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--set", choices=("tune", "held-out", "coarse-tune", "coarse-held-out", "all"), default="tune",
                    help="which systems (default: tune; held-out and coarse-held-out are for reporting; "
                         "coarse-*: 20-40 point samples per cycle)")
    ap.add_argument("--systems", nargs="+", choices=list(SYSTEMS), metavar="NAME",
                    help=f"systems (overrides --set; of {', '.join(SYSTEMS)})")
    ap.add_argument("--seeds", type=int, default=20, help="seeds per system (default 20)")
    ap.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    ap.add_argument("--per-term", action="store_true", help="one line per coefficient too")
    ap.add_argument("--no-refine", action="store_true", help="station identify --no-refine")
    ap.add_argument("--analog-filter", metavar="ORDER:FRACTION",
                    help="an analog Butterworth anti-alias filter on the acceleration before sampling, cut-off "
                         "FRACTION of the rate (e.g. 1:0.39; not told to the station)")
    ap.add_argument("--rate-factor", type=float, default=1.0,
                    help="multiply every system's sample rate (e.g. 6: the coarse family at 120-240 samples "
                         "per cycle, the peer the coarse coverage is compared with; default 1)")
    args = ap.parse_args()
    names = args.systems or [k for k, s in SYSTEMS.items() if args.set in ("all", s["set"])]
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    extra = ("--no-refine",) if args.no_refine else ()
    print(f"station identify ci95 coverage, nominal 0.95: {len(seeds)} seeds x {len(names)} systems "
          f"(rate x {args.rate_factor:g}; load average {os.getloadavg()[0]:.1f})")
    print(f"{'system':<16} {'term':<7} coverage [Wilson 95 %]  n      rms z   mean z  half/|c|  rms err  kept warned")
    total: list[tuple[float, float, float]] = []
    c0 = _cpu()
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            spec = dict(SYSTEMS[name], rate=SYSTEMS[name]["rate"] * args.rate_factor)
            if args.analog_filter:
                order, frac = args.analog_filter.split(":")
                spec["aaf"] = (int(order), float(frac))
            res, kept, warned = run_case(spec, seeds, Path(tmp), extra)
            rows = [r for v in res.values() for r in v]
            total += rows
            if args.per_term:
                for term, v in res.items():
                    print(f"{name:<16} {term:<7} {summary(v)}", flush=True)
            print(f"{name:<16} {'all':<7} {summary(rows)}  {kept}/{len(seeds)} {warned}/{len(seeds)}", flush=True)
    print("-" * 110)
    print(f"{'all':<16} {'all':<7} {summary(total)}")
    print(f"({_cpu() - c0:.0f} s CPU, this process and its children)")


if __name__ == "__main__":
    main()
