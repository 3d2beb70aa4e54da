"""Detection limits and false alarms of ``eddi.diagnose``, and its run time.

Every case hides one mechanism (``simulated_rig.systems.hide_effect``: its force at the
typical amplitude as a fraction ``magnitude`` of the linear spring force there) in a system,
records three impacts through the acceleration-only chain (simulated rig -> conditioning,
with noise at the given accelerometer SNR) and runs the diagnosis. Null cases hide nothing.

Each run prints one JSON line (``--out FILE`` appends them to a file), with, besides the
verdict at the margin used, the largest gain of a candidate that passed every other test
(``passing_gain``): the margin a null case would have needed to stay silent, or the margin
under which a hidden case is still found. ``--summary FILE`` reads such lines and prints,
for a margin, the false-alarm rate and the smallest magnitude found per mechanism and SNR.

    python benchmarks/bench_diagnose.py --nulls --seeds 10 --out runs.jsonl
    python benchmarks/bench_diagnose.py --limits --seeds 2 --out runs.jsonl
    python benchmarks/bench_diagnose.py --summary runs.jsonl [--margin 0.25]
    python benchmarks/bench_diagnose.py --speed
    python benchmarks/bench_diagnose.py --free-decays --seeds 2 --out free.jsonl
    python benchmarks/bench_diagnose.py --free-decays --ratios 0 --seeds 6 --noise 0.02 --out free.jsonl

Add ``--fit equation-error`` to measure the equation-error fit instead of EDDI's.
The numbers are quoted in docs/diagnosis.md.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections import defaultdict

import numpy as np

from eddi.conditioning import condition
from eddi.diagnosis import DEFAULT_MARGIN, Record, diagnose
from eddi.errors import EddiError
from eddi.model import EquationOfMotion
from eddi.simulate import simulate
from simulated_rig.bench import impact_test
from simulated_rig.systems import hide_effect

DAMPING = "v,x^2*v,v^3"
STIFFNESS = "x,x^2,x^3,x^4,x^5"
MECHANISMS = ("coulomb_friction", "quadratic_damping", "clearance", "asymmetric_stiffness", "second_mode")


def systems() -> dict[str, tuple[EquationOfMotion, tuple[float, ...], float, float]]:
    """name -> (system, peak forces [N], sample rate [Hz], record length [s])."""
    return {
        # the tests' system: 12.3 Hz, zeta 0.4 %, about 8 % frequency shift at 1.6 mm
        "mild": (EquationOfMotion.create(mass=0.1, damping={"v": 0.06},
                                         stiffness={"x": 600.0, "x^3": 2e7}), (20.0, 25.0, 30.0), 5000.0, 4.0),
        # nearly linear: 0.8 % shift at the typical amplitude
        "linear": (EquationOfMotion.create(mass=0.1, damping={"v": 0.06},
                                           stiffness={"x": 600.0, "x^3": 2e6}), (20.0, 25.0, 30.0), 5000.0, 4.0),
        # strongly hardening with nonlinear damping: about 40 % frequency shift
        "hard": (EquationOfMotion.create(mass=0.1, damping={"v": 0.05, "x^2*v": 2000.0},
                                         stiffness={"x": 600.0, "x^3": 1.5e8}), (20.0, 25.0, 30.0), 5000.0, 4.0),
    }


def typical_amplitude(eom: EquationOfMotion, force: float, rate: float) -> tuple[float, float]:
    r = impact_test(eom, force, rate_hz=rate, pretrigger_s=0.05, record_s=0.5, snr_db=None, seed=0)
    return float(np.max(np.abs(r.truth_x))), float(np.max(np.abs(r.truth_v)))


def run(system: str, name: str | None, magnitude: float, seed: int, snr_db: float, fit: str,
        margin: float) -> dict:
    eom, forces, rate, record_s = systems()[system]
    truth = eom
    if name:
        amp, vel = typical_amplitude(eom, forces[1], rate)
        truth = hide_effect(eom, name, magnitude, seed, amplitude_m=amp, velocity_m_s=vel)
    recs = []
    for i, f in enumerate(forces):
        r = impact_test(truth, f, rate_hz=rate, pretrigger_s=0.2, record_s=record_s, snr_db=snr_db,
                        seed=1000 * seed + 10 * i + 7)
        c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
        recs.append(Record.from_conditioned(c, label=f"impact {i + 1}"))
    stiff = "x,x^3" if name == "asymmetric_stiffness" else STIFFNESS
    t0 = time.perf_counter()
    d = diagnose(recs, eom.mass, damping=DAMPING, stiffness=stiff, fit=fit, margin=margin)
    passing = [c for c in d.candidates if not c.skipped and c.model is not None
               and c.wins_every_part and c.consistent]
    true_c = next((c for c in d.candidates if c.name == name), None)
    return {
        "system": system, "mechanism": name or "none", "magnitude": magnitude, "seed": seed,
        "snr_db": snr_db, "fit": fit, "margin": margin, "cause": d.cause,
        "baseline_nrmse": d.baseline.nrmse, "extended_nrmse": d.extended.nrmse,
        "passing_gain": max((c.gain for c in passing), default=float("-inf")),
        "passing_best": max(passing, key=lambda c: c.gain).name if passing else "none",
        "true_gain": true_c.gain if true_c else None,
        "true_passes": bool(true_c and true_c.wins_every_part and true_c.consistent),
        "top": d.candidates[0].name, "seconds": time.perf_counter() - t0,
    }


def null_case(seed: int) -> dict:
    """One null of the calibration set (:func:`null_recipe`), diagnosed."""
    recs, info = null_recipe(seed)
    t0 = time.perf_counter()
    d = diagnose(recs, info["mass_kg"], damping=DAMPING, stiffness=STIFFNESS)
    return {"kind": "null", "seed": seed, **info, "cause": d.cause,
            "baseline_nrmse": d.baseline.nrmse, "floor": d.noise_floor.nrmse,
            "ratio": d.baseline.nrmse / d.noise_floor.nrmse, "partial": d.partial,
            "candidates": _cands(d), "seconds": time.perf_counter() - t0}


def null_recipe(seed: int) -> tuple[list, dict]:
    """The records of one null of the calibration set, drawn from ``seed`` (nothing hidden),
    and what was drawn.

    Mass 0.05-0.5 kg, natural frequency 8-30 Hz, a soft (negative ``x^3``, up to -4 % frequency
    shift) or hard (up to +15 %) spring, sample rate 2-40 kHz (record shortened at high
    rates), accelerometer SNR 30-60 dB, 3 captures or 6 (two "acquire runs": seeds differ per
    run, forces 20-30 N scaled to the mass).
    """
    rng = np.random.default_rng(10_000 + seed)
    mass = float(np.exp(rng.uniform(np.log(0.05), np.log(0.5))))
    f1 = float(rng.uniform(8.0, 30.0))
    k1 = mass * (2 * math.pi * f1) ** 2
    zeta = float(rng.uniform(0.002, 0.01))
    soft = bool(rng.random() < 0.35)
    rate = float(rng.choice([2000.0, 5000.0, 10000.0, 20000.0, 40000.0]))
    snr = float(rng.uniform(30.0, 60.0))
    runs = 2 if rng.random() < 0.35 else 1
    record_s = min(3.0, 40_000 / rate)
    # peak displacement under the middle blow ~ F * pulse / (m w); set k3 for the wanted shift
    force_scale = mass / 0.1
    forces = tuple(force_scale * f for f in (20.0, 25.0, 30.0))
    a_typ = forces[1] * 1e-3 / (mass * 2 * math.pi * f1) * 1.2
    shift = -float(rng.uniform(0.0, 0.04)) if soft else float(rng.uniform(0.0, 0.15))
    k3 = shift * 2 * k1 * 4 / (3 * a_typ ** 2)
    eom = EquationOfMotion.create(mass=mass, damping={"v": 2 * zeta * math.sqrt(k1 * mass)},
                                  stiffness={"x": k1, "x^3": k3})
    recs = []
    for run_i in range(runs):
        for i, f in enumerate(forces):
            r = impact_test(eom, f, rate_hz=rate, pretrigger_s=0.2, record_s=record_s, snr_db=snr,
                            seed=100_000 * run_i + 1000 * seed + 10 * i + 3)
            c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
            recs.append(Record.from_conditioned(c, label=f"run {run_i + 1} impact {i + 1}",
                                                pretrigger_samples=r.pretrigger_samples))
    return recs, {"mass_kg": mass, "f1_hz": f1, "spring": "soft" if soft else "hard", "shift": shift,
                  "rate_hz": rate, "snr_db": snr, "captures": len(recs)}


def _cands(d) -> list:
    """Every tried candidate: name, held-out nrmse, gain, wins every part, consistent."""
    return [[c.name, c.nrmse, c.gain, c.wins_every_part, c.consistent]
            for c in d.candidates if not c.skipped and c.model is not None]


def ladder_case(name: str, magnitude: float, seed: int, snr_db: float) -> dict:
    """One rung of a strength ladder on the ``mild`` system: a physical mechanism sized by
    ``hide_effect`` (``magnitude``: force fraction at the typical amplitude), or
    ``sensor_highpass`` (``magnitude``: the corner [Hz] of the accelerometer's IEPE high-pass)."""
    import dataclasses

    from simulated_rig.bench import default_sensors

    eom, forces, rate, record_s = systems()["mild"]
    truth, sensors = eom, default_sensors(snr_db, 24, None)
    if name == "sensor_highpass":
        sensors = (sensors[0], dataclasses.replace(sensors[1], iepe_highpass_hz=magnitude))
    else:
        amp, vel = typical_amplitude(eom, forces[1], rate)
        truth = hide_effect(eom, name, magnitude, seed, amplitude_m=amp, velocity_m_s=vel)
    recs = []
    for i, f in enumerate(forces):
        r = impact_test(truth, f, rate_hz=rate, pretrigger_s=0.2, record_s=record_s, sensors=sensors,
                        seed=1000 * seed + 10 * i + 7)
        c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
        recs.append(Record.from_conditioned(c, label=f"impact {i + 1}", pretrigger_samples=r.pretrigger_samples))
    stiff = "x,x^3" if name == "asymmetric_stiffness" else STIFFNESS
    t0 = time.perf_counter()
    d = diagnose(recs, eom.mass, damping=DAMPING, stiffness=stiff)
    return {"kind": "ladder", "mechanism": name, "magnitude": magnitude, "seed": seed, "snr_db": snr_db,
            "cause": d.cause, "partial": d.partial, "baseline_nrmse": d.baseline.nrmse,
            "extended_nrmse": d.extended.nrmse, "floor": d.noise_floor.nrmse,
            "candidates": _cands(d), "seconds": time.perf_counter() - t0}


def calibration_summary(path: str) -> None:
    """False alarms on the nulls; found / unexplained / none / wrong per mechanism and rung."""
    rows = [json.loads(s) for s in open(path) if s.strip()]
    nulls = [r for r in rows if r.get("kind") == "null"]
    if nulls:
        alarms = [r for r in nulls if r["cause"] != "none"]
        multi = sum(r["captures"] >= 6 for r in nulls)
        ratios = sorted(r["ratio"] for r in nulls)
        print(f"nulls: {len(nulls)} ({multi} with 6 captures from two runs); verdict other than none: "
              f"{len(alarms)} (named {sum(r['cause'] != 'unexplained' for r in alarms)}, unexplained "
              f"{sum(r['cause'] == 'unexplained' for r in alarms)}); baseline/floor ratio median "
              f"{ratios[len(ratios) // 2]:.2f}, max {ratios[-1]:.2f}")
        for r in alarms:
            print(f"  alarm: seed {r['seed']} cause {r['cause']} ratio {r['ratio']:.2f} "
                  f"({r['spring']}, {r['rate_hz']:.0f} Hz, {r['snr_db']:.0f} dB, {r['captures']} captures)")
    groups = defaultdict(list)
    for r in rows:
        if r.get("kind") == "ladder" and "error" not in r:
            groups[(r["mechanism"], r["snr_db"], r["magnitude"])].append(r)
    for (name, snr, mag), g in sorted(groups.items()):
        n = len(g)
        found = sum(r["cause"] == name for r in g)
        unexpl = sum(r["cause"] == "unexplained" for r in g)
        none = sum(r["cause"] == "none" for r in g)
        print(f"{name:<22} {snr:>4.0f} dB  strength {mag:<6g} found {found}/{n}  unexplained {unexpl}/{n}  "
              f"none {none}/{n}  wrong {n - found - unexpl - none}/{n}")


def emit(row: dict, out: str | None) -> None:
    line = json.dumps(row)
    print(line, flush=True)
    if out:
        with open(out, "a") as fh:
            fh.write(line + "\n")


def summary(path: str, margin: float) -> None:
    rows = [json.loads(s) for s in open(path) if s.strip()]
    by_fit = defaultdict(list)
    for r in rows:
        by_fit[r["fit"]].append(r)
    for fit, rs in by_fit.items():
        print(f"== fit = {fit}, margin = {margin}")
        nulls = [r for r in rs if r["mechanism"] == "none"]
        groups = defaultdict(list)
        for r in nulls:
            groups[(r["system"], r["snr_db"])].append(r)
        for key in sorted(groups):
            g = groups[key]
            alarms = [r["passing_best"] for r in g if r["passing_gain"] > margin]
            worst = max(r["passing_gain"] for r in g)
            print(f"null {key[0]:<7} {key[1]:>4.0f} dB: {len(alarms)}/{len(g)} false alarms {alarms} "
                  f"(largest passing gain {worst:+.3f})")
        if nulls:
            worst = max(r["passing_gain"] for r in nulls)
            print(f"all nulls: {sum(r['passing_gain'] > margin for r in nulls)}/{len(nulls)} false alarms; "
                  f"smallest margin with none: {max(worst, 0):.3f}")
        hid = [r for r in rs if r["mechanism"] != "none"]
        cells = defaultdict(lambda: defaultdict(list))
        for r in hid:
            found = (r["true_passes"] and r["true_gain"] is not None and r["true_gain"] > margin
                     and r["top"] == r["mechanism"])
            cells[(r["system"], r["mechanism"], r["snr_db"])][r["magnitude"]].append(found)
        if cells:
            print("smallest magnitude found on every seed (fraction of k1 A at the typical amplitude)")
        for key in sorted(cells):
            mags = cells[key]
            ok = [m for m in sorted(mags) if all(mags[m]) and all(all(mags[n]) for n in mags if n >= m)]
            print(f"{key[0]:<7} {key[1]:<22} {key[2]:>4.0f} dB: {ok[0] if ok else '-'}   "
                  + " ".join(f"{m:g}:{sum(v)}/{len(v)}" for m, v in sorted(mags.items())))


def _mode(f_hz: float, zeta: float, damping: dict | None = None, stiffness: dict | None = None
          ) -> EquationOfMotion:
    w = 2 * math.pi * f_hz
    return EquationOfMotion.create(mass=1.0, damping={"v": 2 * zeta * w, **(damping or {})},
                                   stiffness={"x": w * w, **(stiffness or {})})


#: Main modes of the velocity-only free decays (per unit mass, 40 Hz; amplitudes up to about
#: 0.2 mm): linear; hardening (`x^3`, about 7 % frequency rise at 0.2 mm); a joint (`abs(x)*x`
#: softening about 0.5 % and `abs(v)*v` about doubling the loss at 0.05 m/s, as on the double beam).
FREE_MODES = {
    "linear": _mode(40.0, 0.003),
    "hardening": _mode(40.0, 0.003, stiffness={"x^3": 3e11}),
    "joint": _mode(40.0, 0.003, damping={"abs(v)*v": 20.0}, stiffness={"abs(x)*x": -3e6}),
}


def free_decay_run(kind: str, ratio: float, seed: int, noise: float, margin: float) -> dict:
    """Velocity-only free decays (no force channel), three records starting in motion.

    ``ratio`` is the second mode's initial velocity over the first's (80.6 Hz, zeta 0.6 %,
    close to 1:2); 0 is a null case. Noise: ``noise`` times the peak velocity (white).
    """
    rng = np.random.default_rng(seed)
    t = np.arange(6000) / 2000.0
    m2 = _mode(80.6, 0.006)
    recs = []
    for i, v1 in enumerate((0.03, 0.05, 0.02)):
        v1 = v1 * float(rng.uniform(0.8, 1.2))
        v = simulate(FREE_MODES[kind], t, x0=0.0, v0=v1).v
        if ratio > 0:
            v = v + simulate(m2, t, x0=0.0, v0=ratio * v1 * float(rng.uniform(0.7, 1.3))).v
        v = v + rng.normal(0.0, noise * float(np.max(np.abs(v))), t.size)
        recs.append(Record.from_conditioned(condition(t, vel=v), label=f"free decay {i + 1}"))
    t0 = time.perf_counter()
    d = diagnose(recs, 1.0, margin=margin)
    sm = next(c for c in d.candidates if c.name == "second_mode")
    passing = [c.gain for c in d.candidates if not c.skipped and c.wins_every_part and c.consistent]
    return {"kind": "free-decay", "system": kind, "ratio": ratio, "seed": seed, "noise": noise,
            "cause": d.cause, "second_mode_form": sm.form, "second_mode_gain": sm.gain,
            "passing_gain": max(passing) if passing else None, "notes": list(d.notes),
            "baseline_nrmse": d.baseline.nrmse, "seconds": time.perf_counter() - t0}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nulls", action="store_true", help="null cases (nothing hidden)")
    ap.add_argument("--limits", action="store_true", help="magnitude sweeps of every mechanism")
    ap.add_argument("--speed", action="store_true", help="three 6 s captures at 10 kHz")
    ap.add_argument("--summary", metavar="FILE", help="summarise JSON lines of earlier runs")
    ap.add_argument("--fit", default="eddi", choices=("eddi", "equation-error"))
    ap.add_argument("--margin", type=float, default=DEFAULT_MARGIN)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument("--systems", default="mild,linear,hard")
    ap.add_argument("--snrs", default="60,30")
    ap.add_argument("--mechanisms", default=",".join(MECHANISMS))
    ap.add_argument("--magnitudes", default="0.005,0.01,0.02,0.05,0.1")
    ap.add_argument("--free-decays", action="store_true",
                    help="velocity-only free decays: single-mode nulls and a second mode at 1:2 "
                         "(the observed form of second_mode), ratios from --ratios")
    ap.add_argument("--ratios", default="0,0.05,0.1,0.2,0.5,1,2")
    ap.add_argument("--noise", type=float, default=0.005,
                    help="free decays: white noise RMS as a fraction of the peak velocity")
    ap.add_argument("--calibrate-nulls", type=int, metavar="N", default=0,
                    help="N nulls of the calibration set (masses, soft/hard springs, 2-40 kHz, 30-60 dB, "
                         "3 or 6 captures): the verdict must be none")
    ap.add_argument("--ladder", metavar="NAMES", help="strength ladders of these mechanisms "
                    "(sensor_highpass: corners in Hz) at --magnitudes, --snrs, --seeds")
    ap.add_argument("--calibration-summary", metavar="FILE", help="summarise --calibrate-nulls/--ladder lines")
    ap.add_argument("--out", metavar="FILE")
    args = ap.parse_args()
    if args.calibration_summary:
        calibration_summary(args.calibration_summary)
        return
    for k in range(args.seed0, args.seed0 + args.calibrate_nulls):
        emit(null_case(k), args.out)
    if args.ladder:
        for name in args.ladder.split(","):
            for snr in [float(x) for x in args.snrs.split(",")]:
                for mag in [float(m) for m in args.magnitudes.split(",")]:
                    for seed in range(args.seed0, args.seed0 + args.seeds):
                        try:
                            emit(ladder_case(name, mag, seed, snr), args.out)
                        except (EddiError, ValueError) as exc:  # a case the chain refuses: say so
                            emit({"kind": "ladder", "mechanism": name, "magnitude": mag, "seed": seed,
                                  "snr_db": snr, "error": str(exc)}, args.out)
    if args.summary:
        summary(args.summary, args.margin)
        return
    snrs = [float(s) for s in args.snrs.split(",")]
    seeds = range(args.seed0, args.seed0 + args.seeds)
    if args.nulls:
        for system in args.systems.split(","):
            for snr in snrs:
                for seed in seeds:
                    emit(run(system, None, 0.0, seed, snr, args.fit, args.margin), args.out)
    if args.limits:
        for system in args.systems.split(","):
            for name in args.mechanisms.split(","):
                for snr in snrs:
                    for mag in [float(m) for m in args.magnitudes.split(",")]:
                        for seed in seeds:
                            emit(run(system, name, mag, seed, snr, args.fit, args.margin), args.out)
    if args.free_decays:
        for kind in FREE_MODES:
            for ratio in [float(r) for r in args.ratios.split(",")]:
                for seed in seeds:
                    emit(free_decay_run(kind, ratio, seed, args.noise, args.margin), args.out)
    if args.speed:
        eom = systems()["mild"][0]
        amp, vel = typical_amplitude(eom, 25.0, 10000.0)
        truth = hide_effect(eom, "clearance", 0.1, 0, amplitude_m=amp, velocity_m_s=vel)
        recs = []
        for i, f in enumerate((20.0, 25.0, 30.0)):
            r = impact_test(truth, f, rate_hz=10000.0, pretrigger_s=0.2, record_s=6.0, snr_db=45.0, seed=i)
            c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
            recs.append(Record.from_conditioned(c, label=f"impact {i + 1}"))
        t0 = time.perf_counter()
        d = diagnose(recs, eom.mass, damping=DAMPING, stiffness=STIFFNESS, fit=args.fit)
        cpu = time.process_time()
        print(f"three 6 s captures at 10 kHz diagnosed in {time.perf_counter() - t0:.1f} s "
              f"(cause {d.cause}, fit {args.fit}; process CPU so far {cpu:.1f} s)")


if __name__ == "__main__":
    main()
