"""Coverage of the pipeline's 95 % intervals (``ci95``) through the rig's measurement chain.

``benchmarks/bench_ci_coverage.py`` measures coverage on white-noise records (4 kHz, 2 s,
40 dB). A lab's record is not that. Here every record comes from the simulated rig
(:func:`simulated_rig.bench.impact_test`: half-sine hammer from rest, the true equation of
motion integrated over the whole record, force sensor + accelerometer, noise, ADC
quantisation at 16 or 24 bits, optional IEPE AC coupling) and, per system, the rest of a
realistic chain:

* ``osr``, ``sinc``: the DAQ oversamples by ``osr`` (the record is simulated at ``osr x
  rate``) and decimates through a sinc^``sinc`` filter (``sinc`` cascaded means of ``osr``
  samples, as a sigma-delta ADC's decimator; ``sinc = 1``: the mean of each ``osr`` samples,
  white noise stays white; ``sinc = 3``: the noise of neighbouring samples is correlated);
* ``drift``: a DC-coupled accelerometer whose bias drifts linearly over the record by
  ``drift`` noise standard deviations (the pre-trigger mean is removed by conditioning, a
  slope is not);
* ``iepe``: AC coupling corner [Hz]; the conditioning is told its time constant, as
  ``station`` passes ``ac_coupling_s`` from a capture's metadata; likewise the decimation
  filter's order (``adc_sinc_order``) unless ``--untold``.

Systems (``SYSTEMS``): masses 5 g - 1 t, 2-80 Hz, 2-40 kHz, 30-60 dB, 5-45 s records,
hardening, softening and asymmetric (``x^2``) stiffness, ``x^2*v`` and ``v^3`` damping.
Nonlinear coefficients are set by their share at the first peak (``x^n``: ``k_n x_p^(n-1) /
k1``; ``x^2*v``: ``c x_p^2 / b1``; ``v^3``: ``c v_p^2 / b1``, with ``v_p = J / m`` and
``x_p = v_p / omega`` from the hammer's impulse ``J``). Six systems (``tune``) were used
while changing the engine; the four ``held-out`` ones were run once, at the end.

Each record is conditioned (``Pipeline.condition``) and identified by the pipeline with the
system's own terms (``Pipeline(damping=..., stiffness=...)``, as ``station identify --damping
... --stiffness ...``). For every true coefficient ``z = (c - c_true) / (ci95 / 1.96)``; the
interval covers when ``|z| <= 1.96``. Printed per system and overall: coverage with its 95 %
Wilson interval (the z of one record are correlated: somewhat optimistic), RMS z (1 for
honest standard errors), mean z (bias in standard errors), mean half width / ``|c|``, and
the records whose result carried an interval warning.

Run: ``python benchmarks/bench_ci_coverage_chain.py [--set tune|held-out|all] [--seeds 12]
[--systems ...]`` (~1-4 s per record).
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
from eddi.model import EquationOfMotion  # noqa: E402
from simulated_rig.bench import impact_test  # noqa: E402
from simulated_rig.hammer import HammerSpec  # noqa: E402
from simulated_rig.sensors import accelerometer, force_sensor  # noqa: E402

from bench_ci_coverage import wilson  # noqa: E402  (this folder: the script's own)

#: name: mass [kg], f [Hz], zeta (linear), record [s], rate [Hz], snr [dB], bits, tip,
#: v_p [m/s] (target peak velocity: sets the blow), nonlinear shares (see the docstring),
#: chain: osr, drift [noise sd over the record], iepe [Hz].
SYSTEMS: dict[str, dict] = {
    # --- tune
    "gram_hardening": dict(set="tune", mass=0.02, f=40.0, zeta=0.006, record=5.0, rate=10000.0, snr=45.0,
                           bits=24, tip="plastic", vp=0.3, stiff={"x^3": 0.6}, damp={}, osr=1, drift=0.0,
                           iepe=0.5),
    "tonne_asym": dict(set="tune", mass=1000.0, f=3.0, zeta=0.01, record=40.0, rate=2000.0, snr=35.0, bits=16,
                       tip="rubber", vp=0.02, stiff={"x^2": 0.3}, damp={}, osr=4, sinc=3, drift=0.0, iepe=None),
    "coarse_sinc3": dict(set="tune", mass=0.1, f=60.0, zeta=0.005, record=8.0, rate=2000.0, snr=40.0, bits=24,
                         tip="steel", vp=0.2, stiff={"x^3": 0.4}, damp={}, osr=8, sinc=3, drift=0.0, iepe=None),
    "cubic_damping": dict(set="tune", mass=0.5, f=15.0, zeta=0.008, record=15.0, rate=5000.0, snr=40.0, bits=24,
                          tip="plastic", vp=0.2, stiff={"x^3": 0.3}, damp={"v^3": 1.0}, osr=1, drift=3.0,
                          iepe=None),
    "x2v_damping": dict(set="tune", mass=2.0, f=8.0, zeta=0.01, record=15.0, rate=20000.0, snr=50.0, bits=24,
                        tip="plastic", vp=0.1, stiff={"x^3": 0.4}, damp={"x^2*v": 1.5}, osr=4,
                        drift=0.0, iepe=None),
    "softening": dict(set="tune", mass=0.2, f=25.0, zeta=0.007, record=10.0, rate=8000.0, snr=30.0, bits=24,
                      tip="plastic", vp=0.15, stiff={"x^3": -0.12}, damp={}, osr=1, drift=2.0, iepe=None),
    # --- held-out (run once, at the end)
    "heavy_asym_cubic": dict(set="held-out", mass=50.0, f=6.0, zeta=0.005, record=25.0, rate=40000.0, snr=60.0,
                             bits=24, tip="rubber", vp=0.05, stiff={"x^2": 0.25, "x^3": 0.3}, damp={}, osr=1,
                             drift=0.0, iepe=0.3),
    "five_gram": dict(set="held-out", mass=0.005, f=80.0, zeta=0.004, record=5.0, rate=4000.0, snr=45.0, bits=24,
                      tip="steel", vp=0.4, stiff={"x^3": 0.5}, damp={"v^3": 0.8}, osr=4, sinc=3, drift=0.0,
                      iepe=None),
    "slow_asym_x2v": dict(set="held-out", mass=200.0, f=2.0, zeta=0.012, record=45.0, rate=2000.0, snr=33.0,
                          bits=16, tip="rubber", vp=0.03, stiff={"x^2": 0.5}, damp={"x^2*v": 1.0}, osr=1,
                          drift=4.0, iepe=None),
    "linear_16bit": dict(set="held-out", mass=1.0, f=12.0, zeta=0.006, record=25.0, rate=4000.0, snr=55.0,
                         bits=16, tip="plastic", vp=0.1, stiff={}, damp={}, osr=4, drift=0.0, iepe=0.5),
}


def blow(spec: dict) -> tuple[float, HammerSpec]:
    """Peak force [N] giving the target peak velocity ``v_p = J / m``, and the hammer."""
    hammer = HammerSpec(tip=spec["tip"])
    impulse = spec["mass"] * spec["vp"]
    return impulse * math.pi / (2.0 * hammer.width_s), hammer


def true_model(spec: dict) -> EquationOfMotion:
    """The system's equation of motion from its frequency, damping ratio and shares."""
    m, w = spec["mass"], 2.0 * math.pi * spec["f"]
    k1, b1 = m * w * w, 2.0 * spec["zeta"] * m * w
    vp = spec["vp"]
    xp = vp / w
    stiffness = {"x": k1}
    for term, share in spec["stiff"].items():
        if term == "x":
            continue
        n = int(term.split("^")[1])
        stiffness[term] = share * k1 / xp ** (n - 1)
    damping = {"v": b1}
    for term, share in spec["damp"].items():
        damping[term] = share * b1 / (xp**2 if term == "x^2*v" else vp**2)
    return EquationOfMotion.create(mass=m, damping=damping, stiffness=stiffness)


def decimate(y: np.ndarray, osr: int, order: int) -> np.ndarray:
    """A sinc^order decimator: ``order`` cascaded means of ``osr`` samples (causal, from rest),
    every ``osr``-th output kept (``order = 1``: the mean of each ``osr`` samples)."""
    if osr == 1:
        return np.asarray(y, dtype=float)
    out = np.asarray(y, dtype=float)
    for _ in range(order):
        out = np.convolve(out, np.full(osr, 1.0 / osr))[: y.size]
    return out[osr - 1:: osr]


def chain_record(spec: dict, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float | None]:
    """``t, force, acc`` as the DAQ delivers them, and the AC-coupling time constant [s] (or None)."""
    eom = true_model(spec)
    peak, hammer = blow(spec)
    osr = int(spec["osr"])
    rate_hi = spec["rate"] * osr
    sensors = (force_sensor(adc_bits=spec["bits"]),
               accelerometer(snr_db=spec["snr"] + 10 * math.log10(osr), adc_bits=spec["bits"],
                             iepe_highpass_hz=spec["iepe"]))
    r = impact_test(eom, peak, rate_hz=rate_hi, pretrigger_s=0.5, record_s=spec["record"], sensors=sensors,
                    hammer=hammer, seed=seed)
    n = r.n_samples // osr
    t = r.t[: n * osr: osr]
    force = decimate(r.force_n, osr, spec.get("sinc", 1))[:n]
    acc = decimate(r.acc_m_s2, osr, spec.get("sinc", 1))[:n]
    if spec["drift"]:
        sigma = r.noise_rms["acc"] / math.sqrt(osr)
        acc = acc + spec["drift"] * sigma * (t - t[0]) / (t[-1] - t[0])
    tau = None if spec["iepe"] is None else 1.0 / (2.0 * math.pi * spec["iepe"])
    return t, force, acc, tau




def run_case(spec: dict, seeds: range, refine: bool, tell: bool = True
             ) -> tuple[dict[str, list[tuple[float, float]]], int]:
    """``({term: [(z, half/|c|), ...]}, records with an interval warning)`` over seeds."""
    eom = true_model(spec)
    truth = {"damping": dict(eom.damping), "stiffness": dict(eom.stiffness)}
    pipe = Pipeline(damping=tuple(eom.damping), stiffness=tuple(eom.stiffness), refine=refine)
    out: dict[str, list[tuple[float, float]]] = {}
    warned = 0
    for seed in seeds:
        t, force, acc, tau = chain_record(spec, seed)
        told = dict(adc_sinc_order=spec.get("sinc", 1), adc_osr=spec["osr"]) if spec["osr"] > 1 and tell else {}
        res = pipe.fit(pipe.condition(t, acc=acc, force=force, ac_coupling_s=tau, **told), spec["mass"])
        warned += any("interval" in w for w in res.warnings)
        for group, terms in truth.items():
            for term, c in terms.items():
                got = getattr(res.model.eom, group).get(term)
                half = res.ci95.get(group, {}).get(term, math.nan)
                z = math.inf if got is None or not half > 0 else (got - c) / (half / 1.959964)
                out.setdefault(term, []).append((z, half / abs(c)))
    return out, warned


def summary(rows: list[tuple[float, float]]) -> str:
    z = np.array([r[0] for r in rows])
    za = np.abs(z)
    k, n = int(np.sum(za <= 1.959964)), z.size
    lo, hi = wilson(k, n)
    fin = z[np.isfinite(z)]
    rms = math.sqrt(float(np.mean(fin**2))) if fin.size else math.nan
    return (f"{k / n:5.3f} [{lo:.2f}, {hi:.2f}] n={n:<4d} rms z {rms:5.2f} mean z {float(np.mean(fin)):+5.2f} "
            f"half {float(np.nanmean([r[1] for r in rows])):7.1e}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--set", choices=("tune", "held-out", "all"), default="tune",
                    help="which systems (default: tune; held-out is for the final run)")
    ap.add_argument("--systems", nargs="+", choices=list(SYSTEMS), metavar="NAME",
                    help=f"systems (overrides --set; of {', '.join(SYSTEMS)})")
    ap.add_argument("--seeds", type=int, default=12, help="seeds per system (default 12)")
    ap.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    ap.add_argument("--no-refine", action="store_true", help="the pipeline with --no-refine")
    ap.add_argument("--untold", action="store_true",
                    help="do not tell the pipeline the DAQ's decimation filter (adc_sinc_order)")
    ap.add_argument("--per-term", action="store_true", help="one line per coefficient too")
    args = ap.parse_args()
    names = args.systems or [k for k, s in SYSTEMS.items() if args.set in ("all", s["set"])]
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    print(f"ci95 coverage through the rig's chain, nominal 0.95: {len(seeds)} seeds x {len(names)} systems, "
          f"{'--no-refine' if args.no_refine else 'default pipeline'} (load average {os.getloadavg()[0]:.1f})")
    print(f"{'system':<18} {'term':<7} coverage [Wilson 95 %]  n      rms z   mean z  mean half/|c|   warned")
    total: list[tuple[float, float]] = []
    c0 = time.process_time()
    for name in names:
        res, warned = run_case(SYSTEMS[name], seeds, not args.no_refine, not args.untold)
        rows = [r for v in res.values() for r in v]
        total += rows
        if args.per_term:
            for term, v in res.items():
                print(f"{name:<18} {term:<7} {summary(v)}", flush=True)
        print(f"{name:<18} {'all':<7} {summary(rows)}  {warned}/{len(seeds)}", flush=True)
    print("-" * 96)
    print(f"{'all':<18} {'all':<7} {summary(total)}")
    print(f"({time.process_time() - c0:.0f} s CPU)")


if __name__ == "__main__":
    main()
