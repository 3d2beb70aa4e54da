"""Calibration of the diagnosis verdicts: rates on nulls and on strength ladders, tuning vs held out.

Every case is a set of rig captures (simulated rig -> acceleration-only chain with noise ->
conditioning) diagnosed with the default libraries and catalogue. The verdict is computed for
several ``none`` factors at once: the diagnosis runs with ``none_factor`` 1 (so every
candidate is fitted) and :func:`eddi.diagnosis.name.decide` is applied afterwards with each
factor of ``--factors`` (exactly what ``diagnose(..., none_factor=F)`` returns: above the
factor the candidates it fits are the same, within it the verdict is ``none``).

Two sets, drawn from disjoint seeds and different systems, so a threshold chosen on the
first is checked on the second:

* **tuning**: nulls (seeds 1000-1059, :func:`null_case`: masses 0.05-0.5 kg, 8-30 Hz, soft
  or hard springs, 2-40 kHz, 30-60 dB, 3 captures or 6 from two acquire runs with
  different rig seeds) and ladders on the 12.3 Hz, 0.1 kg test system at 5 kHz, 40 dB
  (second mode at 2.7 f1), seeds 0-2 per rung;
* **held-out**: nulls (seeds 2000-2119) and ladders on a 0.3 kg, 7.1 Hz softening system
  at 20 kHz, 35 dB (second mode at 2.2 f1, AC coupling on a 7 Hz system), seeds 10-12.

Each case prints one JSON line (``--out FILE`` appends); ``--summary FILE`` prints, per set
and factor, the nulls' verdicts (any verdict but ``none`` on a null is a false alarm) and,
per mechanism and rung, the rates found / unexplained / none / wrong.

    python benchmarks/bench_diagnose_calibration.py --set tuning --out cal.jsonl --jobs 2
    python benchmarks/bench_diagnose_calibration.py --set heldout --out cal.jsonl --jobs 2
    python benchmarks/bench_diagnose_calibration.py --summary cal.jsonl --factor 3

It takes minutes (about 2-5 s per case on a quiet 2-core machine, 300 cases); the figures are
quoted in docs/diagnosis.md ("Calibration of the verdicts").
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

FACTORS = (2.0, 2.5, 3.0, 3.5, 4.0, 5.0)
#: Cuts that name a mechanism even within the ``none`` factor (None: never).
STRONG = (None, 0.6, 0.75, 0.9)
MECHANISMS = ("coulomb_friction", "quadratic_damping", "clearance", "asymmetric_stiffness", "second_mode",
              "sensor_highpass", "hysteresis", "amplitude_damping")
#: Measurement-chain faults that are detected, not named (session 7): each rung is "found" when
#: the verdict is ``unexplained`` with the symptom of that kind (eddi.diagnosis.earn), any name
#: is wrong, and ``none`` is a miss; a double hit, reported without overturning the verdict since
#: session 10, is "found" when its symptom is reported with ``none`` or ``unexplained``
#: (calibration_summary.py). Magnitudes: ``mass_error`` the stated mass's error (stated
#: = true (1 + mag)); ``clipping`` how much of the strongest blow's acceleration peak the range
#: cuts off (range = (1 - mag) peak); ``double_hit`` the second blow's peak ratio (4 ms later);
#: ``base_motion`` the structure's mass over the base's (base suspended at 0.2 f1, 5 %).
CHAIN_FAULTS = {"mass_error": "impulse_mass", "clipping": "clipping", "double_hit": "double_hit",
                "base_motion": "base_motion"}
#: Factors of the noise floor within which a named mechanism's extended model must land
#: (``NAMED_FACTOR``); every case is judged at each (at the default none factor and strong cut).
NAMED_FACTORS = (2.0, 3.0, 5.0, 10.0, 20.0, math.inf)
#: Rungs per mechanism: force at the typical amplitude as a fraction of k1 A
#: (simulated_rig.systems.hide_effect), or the AC-coupling corner [Hz] for sensor_highpass.
RUNGS = {"coulomb_friction": (0.003, 0.01, 0.03), "quadratic_damping": (0.02, 0.06, 0.2),
         "clearance": (0.02, 0.06, 0.2), "asymmetric_stiffness": (0.02, 0.06, 0.2),
         "second_mode": (0.02, 0.06, 0.2), "sensor_highpass": (0.3, 0.8, 2.0),
         "hysteresis": (0.01, 0.03, 0.1), "amplitude_damping": (0.02, 0.06, 0.2),
         "mass_error": (0.05, 0.1, 0.2), "clipping": (0.1, 0.3, 0.5), "double_hit": (0.05, 0.15, 0.3),
         "base_motion": (0.033, 0.1, 0.33)}
SETS = {
    "tuning": {"null_seeds": range(1000, 1060), "chain_seeds": range(3000, 3030), "ladder_seeds": (0, 1, 2), "mass": 0.1, "k1": 600.0,
               "k3": 2e7, "zeta": 0.004, "rate": 5000.0, "snr": 40.0, "record_s": 4.0, "mode_ratio": 2.7},
    "heldout": {"null_seeds": range(2000, 2120), "chain_seeds": [*range(5000, 5030), *range(4000, 4060)], "ladder_seeds": (10, 11, 12), "mass": 0.3, "k1": 600.0,
                "k3": -3e5, "zeta": 0.006, "rate": 20000.0, "snr": 35.0, "record_s": 4.0, "mode_ratio": 2.2},
}


def _system(cfg: dict):
    from eddi.model import EquationOfMotion

    c = 2 * cfg["zeta"] * math.sqrt(cfg["k1"] * cfg["mass"])
    return EquationOfMotion.create(mass=cfg["mass"], damping={"v": c}, stiffness={"x": cfg["k1"], "x^3": cfg["k3"]})


def _typical(eom, force: float, rate: float) -> tuple[float, float]:
    from simulated_rig.bench import impact_test

    r = impact_test(eom, force, rate_hz=rate, pretrigger_s=0.05, record_s=0.5, snr_db=None, seed=0)
    return float(np.max(np.abs(r.truth_x))), float(np.max(np.abs(r.truth_v)))


def _second_mode(eom, magnitude: float, seed: int, ratio: float):
    """A second mode at ``ratio`` times the first linear frequency (coupling ``magnitude k1``,
    modal mass 0.1 m, 2 % damping, strength jittered by 0.8-1.2 from ``seed``)."""
    from eddi.model import Effect

    k1, m = eom.linear_stiffness(), eom.mass
    mag = magnitude * float(np.random.default_rng(seed).uniform(0.8, 1.2))
    m2, kc = 0.1 * m, mag * k1
    k_total = m2 * (ratio * math.sqrt(k1 / m)) ** 2
    k_own = max(k_total - kc, 0.1 * k_total)
    return eom.with_effect(Effect(name="second_mode", params={
        "mass_kg": m2, "stiffness_n_per_m": k_own, "damping_n_s_per_m": 2 * 0.02 * math.sqrt((k_own + kc) * m2),
        "coupling_n_per_m": kc}))


def _records(truth, forces, cfg: dict, seed: int, sensors=None, **rig):
    from eddi.conditioning import condition
    from eddi.diagnosis import Record
    from simulated_rig.bench import impact_test

    recs = []
    for i, f in enumerate(forces):
        kw = {"sensors": sensors} if sensors is not None else {"snr_db": cfg["snr"]}
        r = impact_test(truth, f, rate_hz=cfg["rate"], pretrigger_s=0.2, record_s=cfg["record_s"],
                        seed=1000 * seed + 10 * i + 7, **kw, **rig)
        c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
        recs.append(Record.from_conditioned(c, label=f"impact {i + 1}", pretrigger_samples=r.pretrigger_samples))
    return recs


def _noise_only(d):
    """``d`` with the floor of the noise and conditioning alone (before session 9's chain share):
    every candidate is fitted either way (none factor 0), so the verdicts of the session-8 floor
    follow from the same diagnosis."""
    fl = d.noise_floor
    if not fl.noise_fold_nrmse:
        return d
    from eddi.diagnosis.measure import data_floor

    nf = dataclasses.replace(fl, fold_nrmse=fl.noise_fold_nrmse, nrmse=float(np.mean(fl.noise_fold_nrmse)),
                             chain_nrmse=(), data_fold_nrmse=data_floor(fl.noise_fold_nrmse, fl.part_conditioning_nrmse,
                                                                        fl.prediction_nrmse, ()))
    return dataclasses.replace(d, noise_floor=nf)


def _symptoms_for(dec, d, measured: list) -> list:
    """The symptoms the loop hears for ``dec``: ``d`` was diagnosed at none factor 0, where
    ``sensor_highpass`` may win and its impulse-mass check is then made on the reconditioned
    records (``eddi.diagnosis.loop._impulse_through_coupling``); a verdict at a larger factor
    that does not name it hears the check as measured (``measured``: those findings)."""
    if dec.winner is not None and dec.winner.name == "sensor_highpass":
        return list(d.symptoms)
    return [s for s in d.symptoms if s.kind != "impulse_mass"] + list(measured)


def _verdicts(d, factors, measured: list | None = None) -> tuple[dict[str, str], dict[str, str]]:
    """The cause ``diagnose`` gives at each ``none`` factor (see the module notes), and the one
    :func:`eddi.diagnosis.name.decide` gave before :func:`eddi.diagnosis.earn.earn` heard the
    chain and the symptoms (``--summary --rejudge`` applies the current rule to it)."""
    from eddi.diagnosis.earn import earn
    from eddi.diagnosis.loop import records_share
    from eddi.diagnosis.name import decide
    from eddi.diagnosis.settings import NAMED_FACTOR, PIPELINE_NONE_LIMIT

    out, raw = {}, {}
    pipe = d.pipeline
    floor = d.noise_floor.data_nrmse  # as the loop: the floor of the data (session 12)
    if pipe is not None and pipe.held_out:  # as the loop: the records' own share over the records it did not fit (session 15)
        floors = [fl for p, fl in zip(d.parts, records_share(d.noise_floor) or d.noise_floor.data_fold_nrmse
                                              or d.noise_floor.fold_nrmse)
                  if p.record in pipe.held_out]
        floor = float(np.mean(floors)) if floors else floor
    for f in factors:
        for strong in STRONG:
            # the loop's pipeline check: `none` needs the pipeline's model within the factor too
            lim = max(f, PIPELINE_NONE_LIMIT)  # as the loop (session 18)
            departs = "pipeline" if (pipe is not None and pipe.held_out and not pipe.nrmse <= lim * floor) else ""
            dec = decide(d.candidates, d.judging.fold_nrmse, d.noise_floor, d.margin, f, NAMED_FACTOR,
                         strong_margin=strong, eddi_fold=d.reference_fold or None, departs=departs)
            raw[f"{f:g}|{strong}"] = dec.cause
            sy = d.symptoms if measured is None else _symptoms_for(dec, d, measured)
            dec = earn(dec, d.judging.nrmse / d.noise_floor.data_nrmse, sy)
            out[f"{f:g}|{strong}"] = dec.cause
    return out, raw


def _named_verdicts(d, measured: list | None = None) -> dict[str, str]:
    """The cause at each factor of :data:`NAMED_FACTORS` (default none factor and strong cut)."""
    from eddi.diagnosis.earn import earn
    from eddi.diagnosis.loop import records_share
    from eddi.diagnosis.name import decide
    from eddi.diagnosis.settings import NONE_LIMIT as NONE_FACTOR, PIPELINE_NONE_LIMIT, STRONG_MARGIN  # the loop's

    pipe = d.pipeline
    floor = d.noise_floor.data_nrmse  # as the loop: the floor of the data (session 12)
    if pipe is not None and pipe.held_out:
        floors = [fl for p, fl in zip(d.parts, records_share(d.noise_floor) or d.noise_floor.data_fold_nrmse
                                              or d.noise_floor.fold_nrmse)
                  if p.record in pipe.held_out]
        floor = float(np.mean(floors)) if floors else floor
    lim = max(NONE_FACTOR, PIPELINE_NONE_LIMIT)
    departs = "pipeline" if (pipe is not None and pipe.held_out and not pipe.nrmse <= lim * floor) else ""
    out = {}
    for nf in NAMED_FACTORS:
        dec = decide(d.candidates, d.judging.fold_nrmse, d.noise_floor, d.margin, NONE_FACTOR, nf,
                     strong_margin=STRONG_MARGIN, eddi_fold=d.reference_fold or None, departs=departs)
        sy = d.symptoms if measured is None else _symptoms_for(dec, d, measured)
        out[f"{nf:g}"] = earn(dec, d.judging.nrmse / d.noise_floor.data_nrmse, sy).cause
    return out


#: Give the loop the pipeline's baseline, as ``station diagnose`` does (``--no-pipeline``: the
#: library call without it, as before session 4); ``chain``: the measurement chain's tolerance
#: in the noise floor (session 9; ``--no-chain``: the floor of noise and conditioning only, as before).
PIPELINE = {"on": True, "chain": True}


def _diagnose(recs, mass: float, factors, stiffness: str | None = None) -> tuple[dict, float]:
    from eddi.diagnosis import diagnose
    from eddi.terms import DEFAULT_STIFFNESS

    from eddi.diagnosis.chain import impulse_mass_ratio, inspect
    from eddi.diagnosis.symptoms import notable

    t0 = time.process_time()
    pipe = None
    if PIPELINE["on"]:
        from eddi.diagnosis.pipeline_base import pipeline_baseline

        pipe = pipeline_baseline(recs, mass, stiffness=stiffness or DEFAULT_STIFFNESS)
    from eddi.diagnosis.tolerance import ChainTolerance

    d = diagnose(recs, mass, none_factor=0.0,  # every candidate fitted; the verdicts come after
                 stiffness=stiffness or DEFAULT_STIFFNESS, pipeline=pipe,
                 chain=ChainTolerance() if PIPELINE["chain"] else None)
    before = _noise_only(d)
    k = getattr(d.baseline.model, "linear_stiffness", lambda: 0.0)()  # the loop's fallback f1
    f1 = math.sqrt(max(k, 0.0) / mass) / (2 * math.pi)
    measured = [s for s in inspect(recs, mass, f1) if s.kind == "impulse_mass"]
    return {"ratio": d.judging.nrmse / d.noise_floor.nrmse, "baseline_nrmse": d.judging.nrmse,
            "ratio_nochain": d.judging.nrmse / before.noise_floor.nrmse,
            "causes_nochain": _verdicts(before, factors, measured)[0],
            "named_causes_nochain": _named_verdicts(before, measured),
            "pipeline_nrmse": d.pipeline.nrmse if d.pipeline is not None else None,
            "floor": d.noise_floor.nrmse, "partial": d.partial, "data_floor": d.noise_floor.data_nrmse,
            "floor_parts": {"judged": list(d.judging.fold_nrmse), "fold": list(d.noise_floor.fold_nrmse),
                            "cond": list(d.noise_floor.part_conditioning_nrmse),
                            "pred": list(d.noise_floor.prediction_nrmse), "chain": list(d.noise_floor.chain_nrmse)},
            "chain_nrmse": list(d.noise_floor.chain_nrmse),
            "gain_per_part": list(d.noise_floor.chain.get("gain_per_part", [])),
            **dict(zip(("causes", "decided"), _verdicts(d, factors, measured))), "named_causes": _named_verdicts(d, measured),
            # every symptom (kind, numbers, notable), and the raw impulse/momentum mass ratio (median,
            # spread, captures): a rule on them can be re-judged on these rows (summary)
            "symptoms": [[s.kind, {k: (v if math.isfinite(v) else str(v)) for k, v in s.values.items()}, notable(s)]
                         for s in d.symptoms],
            "impulse_mass": impulse_mass_ratio(recs, mass),
            "candidates": [[c.name, round(c.nrmse, 5), round(c.gain, 4), c.wins_every_part, c.consistent,
                            {k: round(v["z"], 2) for k, v in c.within_cycle.items() if v.get("same_fitter")}]
                           for c in d.candidates if not c.skipped and c.model is not None]}, \
        time.process_time() - t0


def null_case(args: tuple) -> dict:
    set_name, seed, factors = args
    from bench_diagnose import null_recipe

    recs, info = null_recipe(seed)
    row, cpu = _diagnose(recs, info["mass_kg"], factors)
    return {"kind": "null", "set": set_name, "seed": seed, **info, **row, "cpu_s": cpu}


def chain_null_recipe(seed: int, stiff: bool = False) -> tuple[list, dict]:
    """Records of one chain-difference null (session 9): nothing hidden, captures from 2-3
    acquisition sessions whose chains differ (:mod:`simulated_rig.sessions`: accelerometer
    gain 0.1-1 %, force gain a third of that, clock 10-100 ppm, DC offsets, trigger jitter,
    pretrigger 0.05-0.3 s; half of the sessions read without the pretrigger length, as a
    CSV is). Mass 0.01-100 kg, 10-80 Hz, damping ratio 0.001-0.01, a soft, hard or
    asymmetric spring, weakly (tangent stiffness 2-10 % off at the largest blow's linear peak)
    or strongly (50-200 %: 30-100 % at the peak the nonlinear system reaches; soft 3-15 %)
    nonlinear, 20-120 cycles (at most 64k samples), 2-40 kHz,
    30-60 dB, 3 captures per session at amplitudes spread 1.2-2x. ``stiff``: the regime of the
    blind false alarm only (hard or asymmetric, strong, damping ratio 0.001-0.003, 60-120
    cycles, 45-60 dB, accelerometer gains 0.2-1 %)."""
    from eddi.conditioning import condition
    from eddi.diagnosis import Record
    from eddi.model import EquationOfMotion
    from simulated_rig.bench import impact_test
    from simulated_rig.sessions import draw_chains, session_test

    rng = np.random.default_rng(30_000 + seed)
    mass = float(np.exp(rng.uniform(np.log(0.01), np.log(100.0))))
    f1 = float(rng.uniform(10.0, 80.0))
    zeta = float(np.exp(rng.uniform(np.log(0.001), np.log(0.01))))
    spring = str(rng.choice(["hard", "asymmetric"] if stiff else ["soft", "hard", "asymmetric"]))
    strong = stiff or bool(rng.random() < 0.5)
    if stiff:
        zeta = float(np.exp(rng.uniform(np.log(0.001), np.log(0.003))))
    rise = (float(rng.uniform(0.03, 0.15)) if spring == "soft" else
            float(rng.uniform(0.5, 2.0)) if strong else float(rng.uniform(0.02, 0.1)))
    rate = float(rng.choice([2000.0, 5000.0, 10000.0, 16000.0, 20000.0, 40000.0]))
    snr = float(rng.uniform(45.0, 60.0) if stiff else rng.uniform(30.0, 60.0))
    record_s = min(float(rng.uniform(60.0, 120.0) if stiff else rng.uniform(20.0, 120.0)) / f1, 64_000 / rate)
    sessions = 2 if rng.random() < 0.6 else 3
    spread = float(rng.uniform(1.2, 2.0))
    k1 = mass * (2 * math.pi * f1) ** 2
    c = 2 * zeta * math.sqrt(k1 * mass)
    top = 30.0 * mass / 0.1
    lin = EquationOfMotion.create(mass=mass, damping={"v": c}, stiffness={"x": k1})
    amp = float(np.max(np.abs(impact_test(lin, top, rate_hz=rate, pretrigger_s=0.01, record_s=min(0.5, 5 / f1),
                                          snr_db=None, seed=0).truth_x)))
    if spring == "soft":
        k = {"x": k1, "x^3": -rise * k1 / (3 * amp ** 2)}
    elif spring == "hard":
        k = {"x": k1, "x^3": rise * k1 / (3 * amp ** 2)}
    else:  # half of the rise from x^2 at the positive peak (the negative side still stiffens)
        k = {"x": k1, "x^2": 0.5 * rise * k1 / (2 * amp), "x^3": rise * k1 / (3 * amp ** 2)}
    eom = EquationOfMotion.create(mass=mass, damping={"v": c}, stiffness=k)
    peak_acc = top / mass
    chains = draw_chains(rng, sessions, gain=(0.002, 0.01) if stiff else (0.001, 0.01),
                         acc_offset=0.01 * peak_acc, force_offset=0.005 * top)
    levels = list(np.geomspace(1.0 / spread, 1.0, 3 * sessions))
    rng.shuffle(levels)
    recs = []
    for i, lev in enumerate(levels):
        ch = chains[i // 3]
        r = session_test(eom, top * float(lev), ch, rate_hz=rate, record_s=record_s, snr_db=snr,
                         seed=1000 * seed + 10 * i + 5)
        known = (i // 3) % 2 == 0  # the second session read as a CSV (pretrigger unknown)
        cnd = condition(r.t, acc=r.acc_m_s2, force=r.force_n,
                        pretrigger_samples=r.pretrigger_samples if known else None)
        recs.append(Record.from_conditioned(cnd, label=f"session {i // 3 + 1} impact {i % 3 + 1}",
                                            pretrigger_samples=r.pretrigger_samples if known else None))
    return recs, {"mass_kg": mass, "f1_hz": f1, "spring": spring, "strong": strong, "rise": rise, "stiff": stiff,
                  "zeta": zeta, "rate_hz": rate, "snr_db": snr, "record_s": record_s, "sessions": sessions,
                  "spread": spread, "captures": len(recs),
                  "chains": [[ch.acc_gain, ch.force_gain, ch.clock_ppm] for ch in chains]}


def chain_null_case(args: tuple) -> dict:
    set_name, seed, factors = args
    stiff = seed in STIFF_SEEDS
    try:
        recs, info = chain_null_recipe(seed, stiff)
        row, cpu = _diagnose(recs, info["mass_kg"], factors)
    except Exception as exc:  # a case the chain refuses is reported, not hidden
        return {"kind": "null", "family": "chain-stiff" if stiff else "chain", "set": set_name, "seed": seed,
                "error": f"{type(exc).__name__}: {exc}"}
    return {"kind": "null", "family": "chain-stiff" if stiff else "chain", "set": set_name, "seed": seed, **info,
            **row, "cpu_s": cpu}


#: Seeds of the chain-difference nulls drawn in the blind false alarm's regime (held out; the
#: set runs 5000-5029, 5030-5099 are kept for ``--seeds`` hold-outs).
STIFF_SEEDS = range(5000, 5100)


def ladder_case(args: tuple) -> dict:
    set_name, name, magnitude, seed, factors = args
    from simulated_rig.bench import default_sensors
    from simulated_rig.systems import hide_effect

    cfg = SETS[set_name]
    eom = _system(cfg)
    forces = tuple(cfg["mass"] / 0.1 * f for f in (20.0, 25.0, 30.0))
    truth, sensors, rig, stated = eom, None, {}, eom.mass
    if name in CHAIN_FAULTS:
        sensors, rig, stated = _chain_fault(name, magnitude, eom, forces, cfg)
    elif name == "sensor_highpass":
        s = default_sensors(cfg["snr"], 24, None)
        sensors = (s[0], dataclasses.replace(s[1], iepe_highpass_hz=magnitude))
    elif name == "second_mode":
        truth = _second_mode(eom, magnitude, seed, cfg["mode_ratio"])
    elif name == "amplitude_damping":  # a damping term, not an effect: c_x |x| v, jittered as hide_effect
        amp, vel = _typical(eom, forces[1], cfg["rate"])
        c = magnitude * float(np.random.default_rng(seed).uniform(0.8, 1.2)) * eom.linear_stiffness() / vel
        truth = eom.model_copy(update={"damping": {**eom.damping, "abs(x)*v": c}})
    else:
        amp, vel = _typical(eom, forces[1], cfg["rate"])
        truth = hide_effect(eom, name, magnitude, seed, amplitude_m=amp, velocity_m_s=vel)
    try:
        recs = _records(truth, forces, cfg, seed, sensors, **rig)
        # x^2 in the default library is an asymmetric stiffness already: judge it with x, x^3
        row, cpu = _diagnose(recs, stated, factors, "x,x^3" if name == "asymmetric_stiffness" else None)
    except Exception as exc:  # a case the chain refuses is reported, not hidden
        return {"kind": "ladder", "set": set_name, "mechanism": name, "magnitude": magnitude, "seed": seed,
                "error": f"{type(exc).__name__}: {exc}"}
    return {"kind": "ladder", "set": set_name, "mechanism": name, "magnitude": magnitude, "seed": seed,
            "f1_hz": math.sqrt(eom.linear_stiffness() / eom.mass) / (2 * math.pi), **row, "cpu_s": cpu}


def _chain_fault(name: str, magnitude: float, eom, forces, cfg: dict) -> tuple:
    """(sensors, impact_test keywords, stated mass) of a measurement-chain rung (CHAIN_FAULTS)."""
    from simulated_rig.bench import default_sensors, impact_test
    from simulated_rig.hammer import HammerSpec

    sensors = default_sensors(cfg["snr"], 24, None)
    f1 = math.sqrt(eom.linear_stiffness() / eom.mass) / (2 * math.pi)
    if name == "mass_error":
        return sensors, {}, eom.mass * (1.0 + magnitude)
    if name == "clipping":
        peak = float(np.max(np.abs(impact_test(eom, forces[-1], rate_hz=cfg["rate"], pretrigger_s=0.05,
                                               record_s=0.3, snr_db=None, seed=0).acc_m_s2)))
        return (sensors[0], dataclasses.replace(sensors[1], range_si=(1.0 - magnitude) * peak)), {}, eom.mass
    if name == "double_hit":
        return sensors, {"double_hit": True, "hammer": HammerSpec(double_hit_ratio=magnitude)}, eom.mass
    return sensors, {"base_motion": {"mass_kg": eom.mass / magnitude, "frequency_hz": 0.2 * f1,
                                     "damping_ratio": 0.05}}, eom.mass


def parse_seeds(spec: str) -> list[int]:
    """Seeds from ``"2000-2029"`` (inclusive) or ``"10,11,4058"`` or a mix (``"10,20-22"``)."""
    out = []
    for part in spec.split(","):
        a, _, b = part.strip().partition("-")
        out += list(range(int(a), int(b) + 1)) if b else [int(a)]
    return out


def run(set_name: str, out: str | None, jobs: int, factors, nulls: bool, ladders: bool, names,
        max_nulls: int | None = None, ladder_seeds: int | None = None, chain_nulls: bool = False,
        seeds: list[int] | None = None) -> None:
    """Run the selected families; ``seeds`` replaces the seeds of every selected family (a run
    in pieces, or seeds outside the set's lists kept apart as a final held-out check)."""
    cfg = SETS[set_name]
    tasks = []
    if nulls:
        tasks += [(null_case, (set_name, s, factors)) for s in (seeds or list(cfg["null_seeds"])[:max_nulls])]
    if chain_nulls:
        tasks += [(chain_null_case, (set_name, s, factors)) for s in (seeds or list(cfg["chain_seeds"])[:max_nulls])]
    if ladders:
        tasks += [(ladder_case, (set_name, n, m, s, factors)) for n in names for m in RUNGS[n]
                  for s in (seeds or cfg["ladder_seeds"][:ladder_seeds])]
    with ProcessPoolExecutor(max_workers=max(1, jobs)) as pool:
        futures = [pool.submit(fn, a) for fn, a in tasks]
        for fut in futures:
            row = fut.result()
            line = json.dumps(row)
            print(line, flush=True)
            if out:
                with open(out, "a") as fh:
                    fh.write(line + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--set", choices=tuple(SETS), help="run this set's cases")
    ap.add_argument("--only", choices=("nulls", "ladders", "chainnulls"),
                    help="run only the nulls, the ladders, or the chain-difference nulls (session 9; "
                         "default: nulls and ladders and chain-difference nulls)")
    ap.add_argument("--no-chain", action="store_true",
                    help="the noise floor without the measurement chain's tolerance (as before session 9)")
    ap.add_argument("--mechanisms", default=",".join(MECHANISMS + tuple(CHAIN_FAULTS)),
                    help="ladders of these (default: all, chain faults included)")
    ap.add_argument("--factors", default=",".join(f"{f:g}" for f in FACTORS),
                    help="none factors to evaluate (default: %(default)s)")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (default: %(default)s)")
    ap.add_argument("--out", metavar="FILE", help="append JSON lines here")
    ap.add_argument("--no-pipeline", action="store_true",
                    help="diagnose without the pipeline's baseline (the library call as before session 4)")
    ap.add_argument("--max-nulls", type=int, default=None, metavar="N",
                    help="a reduced run: only the first N nulls of the set (default: all)")
    ap.add_argument("--ladder-seeds", type=int, default=None, metavar="N",
                    help="a reduced run: only the first N seeds of each rung (default: all)")
    ap.add_argument("--seeds", metavar="SPEC", default=None,
                    help="run these seeds of every selected family instead of the set's (e.g. 2000-2029 or "
                         "10,11; seeds outside the set's lists are drawn the same way)")
    ap.add_argument("--summary", metavar="FILE", help="print the rates of earlier runs")
    ap.add_argument("--nochain", action="store_true",
                    help="with --summary: the verdicts with the floor of noise and conditioning alone (the "
                         "session-8 floor; computed from the same diagnoses, stored as causes_nochain)")
    ap.add_argument("--rejudge", action="store_true",
                    help="with --summary: apply the current eddi.diagnosis.earn rule to the stored verdicts")
    ap.add_argument("--factor", type=float, default=None,
                    help="none factor of the ladder table (default: eddi.diagnosis.NONE_LIMIT)")
    ap.add_argument("--strong", default="default",
                    help="strong cut of the ladder table, or None (default: eddi.diagnosis.STRONG_MARGIN)")
    args = ap.parse_args()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    np.seterr(all="ignore")
    if args.summary:
        from eddi.diagnosis import NONE_LIMIT as NONE_FACTOR
        from eddi.diagnosis.settings import STRONG_MARGIN

        strong = STRONG_MARGIN if args.strong == "default" else (None if args.strong == "None" else float(args.strong))
        from calibration_summary import summary

        summary(args.summary, args.factor if args.factor is not None else NONE_FACTOR, strong, args.rejudge,
                args.nochain)
        return
    if not args.set:
        ap.error("give --set tuning|heldout, or --summary FILE")
    factors = tuple(float(f) for f in args.factors.split(","))
    try:
        seeds = parse_seeds(args.seeds) if args.seeds else None
    except ValueError:
        ap.error(f"--seeds: not a list of seeds or ranges: {args.seeds!r}")
    PIPELINE["on"] = not args.no_pipeline
    PIPELINE["chain"] = not args.no_chain
    run(args.set, args.out, args.jobs, factors, args.only in (None, "nulls"), args.only in (None, "ladders"),
        args.mechanisms.split(","), args.max_nulls, args.ladder_seeds, args.only in (None, "chainnulls"),
        seeds)


if __name__ == "__main__":
    main()
