"""One-DOF impact sets whose small-amplitude decay loses energy faster than a model of the default
libraries can (session 19, helper s19small), and their nulls at the same draws.

Each seed draws mass 0.1-20 kg (log-uniform), natural frequency 5-40 Hz, viscous damping ratio
0.3-2 %, a cubic spring (frequency shift up to +-4 % at the strongest blow), sample rate 2-20 kHz
(at least 50 samples per cycle), SNR 30-60 dB and 3 captures (blows at 1/1.5, 1/1.22, 1 of the
top one, acceleration and force). The family adds one mechanism that loses energy mostly at small
amplitude, its strength ``r`` (drawn 0.1-0.35) the extra loss per cycle over the viscous one at
``A_low`` (the amplitude two thirds of the way down the strongest blow's record, at least a tenth
of its peak):

* ``null``: nothing (the model class holds the truth);
* ``coulomb``: dry friction ``F_c tanh(v / v_s)``, ``v_s`` 1e-3 of the peak speed (``4 F_c A``
  per cycle against ``pi c w A^2``);
* ``smooth``: twice that force with ``v_s`` the speed at ``A_low`` (viscous below it, dry above: a
  lubricated contact, a Stribeck-like law the catalogue's sharp friction only approximates);
  ``smooth2`` twice that force again;
* ``mode2``: a second, lightly damped mode (0.5 %) at 1.3-2.5 f1, coupled by a spring r/4 of k1
  (beating: not a loss, an exchange the one-DOF model reads as one);
* ``quant``: a 16-bit converter over a range 2^(4 + 4 r / 0.35) times the peak (8-11 effective
  bits, no dither: the chain's, not the structure's).

    python benchmarks/bench_diagnose_smallamp.py --family coulomb --seeds 0-9 --jobs 2 --out F.jsonl
    python benchmarks/bench_diagnose_smallamp.py --summary F.jsonl

Seeds 0-49 are the tuning set of session 19 (s19small); 100-149 were kept out of it.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_diagnose_calibration as B  # noqa: E402

RATES = (2000.0, 5000.0, 10000.0, 20000.0)
FAMILIES = ("null", "coulomb", "smooth", "smooth2", "mode2", "quant")
FACTORS = (2.5,)


def draw(seed: int) -> dict:
    """The system and chain of one seed (the same for every family)."""
    rng = np.random.default_rng(190_000 + seed)
    mass = float(np.exp(rng.uniform(np.log(0.1), np.log(20.0))))
    f1 = float(np.exp(rng.uniform(np.log(5.0), np.log(40.0))))
    zeta = float(np.exp(rng.uniform(np.log(0.003), np.log(0.02))))
    rate = float(rng.choice([r for r in RATES if r >= 50 * f1] or [RATES[-1]]))
    snr = float(rng.uniform(30.0, 60.0))
    shift = float(rng.uniform(-0.04, 0.04))
    strength = float(rng.uniform(0.1, 0.35))
    return {"mass_kg": mass, "f1_hz": f1, "zeta": zeta, "rate_hz": rate, "snr_db": snr, "shift": shift,
            "strength": strength}


def small_set(seed: int, family: str) -> tuple[list, dict]:
    """The records of one set and what was drawn (module notes)."""
    from eddi.conditioning import condition
    from eddi.diagnosis import Record
    from eddi.model import Effect, EquationOfMotion
    from simulated_rig.bench import impact_test
    from simulated_rig.sensors import accelerometer, force_sensor

    d = draw(seed)
    mass, f1, zeta, rate, snr = d["mass_kg"], d["f1_hz"], d["zeta"], d["rate_hz"], d["snr_db"]
    w = 2 * math.pi * f1
    k1, c = mass * w ** 2, 2 * zeta * math.sqrt(mass * w ** 2 * mass)
    top = 30.0 * mass / 0.1
    lin = EquationOfMotion.create(mass=mass, damping={"v": c}, stiffness={"x": k1})
    probe = impact_test(lin, top, rate_hz=rate, pretrigger_s=0.01, record_s=min(0.5, 5 / f1), snr_db=None, seed=0)
    amp = float(np.max(np.abs(probe.truth_x)))
    cycles = min(60.0, 4.0 / (2 * math.pi * zeta))
    record_s = min(max(cycles, 8.0) / f1, 30_000 / rate)
    decay = 2 * math.pi * zeta * f1 * record_s
    a_low = amp * max(math.exp(-2 * decay / 3), 0.1)
    eom = EquationOfMotion.create(mass=mass, damping={"v": c},
                                  stiffness={"x": k1, "x^3": 8 * d["shift"] * k1 / (3 * amp ** 2)})
    r = d["strength"]
    sensors, extra = None, {}
    if family in ("coulomb", "smooth", "smooth2"):
        # smooth: tanh(1) of the force at A_low's speed, so twice the force for a like loss there;
        # smooth2 twice that again (r 0.2-0.7)
        force = r * math.pi * c * w * a_low / 4 * {"coulomb": 1.0, "smooth": 2.0, "smooth2": 4.0}[family]
        vs = 1e-3 * amp * w if family == "coulomb" else a_low * w
        eom = eom.with_effect(Effect(name="coulomb_friction", params={"force_n": force, "velocity_scale": vs}))
        extra = {"friction_n": force, "velocity_scale": vs}
    elif family == "mode2":
        # a second, lightly damped mode (0.5 %) at 1.3-2.5 f1 through a spring r/4 of k1: its beating
        # with the main mode moves the energy back and forth, most visibly where the main mode is small
        ratio = 1.3 + 1.2 * (r - 0.1) / 0.25
        m2, kc = 0.1 * mass, 0.25 * r * k1
        k_own = max(m2 * (ratio * w) ** 2 - kc, 0.1 * m2 * (ratio * w) ** 2)
        eom = eom.with_effect(Effect(name="second_mode", params={
            "mass_kg": m2, "stiffness_n_per_m": k_own, "damping_n_s_per_m": 2 * 0.005 * math.sqrt((k_own + kc) * m2),
            "coupling_n_per_m": kc}))
        extra = {"mode2_ratio": ratio, "coupling_n_per_m": kc}
    elif family == "quant":
        # a coarse converter: 16 bits over a range 2^(4 + 4 r / 0.35) times the peak (an 8-11 bit step
        # at the peak), no dither: at small amplitude the step is a larger share of the signal
        head = 2.0 ** (4 + 4 * r / 0.35)
        sensors = (force_sensor(), accelerometer(snr_db=snr, adc_bits=16, range_headroom=head))
        extra = {"range_headroom": head}
    recs = []
    for i, lev in enumerate((1 / 1.5, 1 / 1.22, 1.0)):
        kw = {"sensors": sensors} if sensors is not None else {"snr_db": snr}
        rr = impact_test(eom, top * lev, rate_hz=rate, pretrigger_s=0.1, record_s=record_s,
                         seed=1000 * seed + 10 * i + 5, **kw)
        cnd = condition(rr.t, acc=rr.acc_m_s2, force=rr.force_n, pretrigger_samples=rr.pretrigger_samples)
        recs.append(Record.from_conditioned(cnd, label=f"impact {i + 1}", pretrigger_samples=rr.pretrigger_samples))
    return recs, {**d, "family": family, "record_s": record_s, "a_low_m": a_low, "peak_m": amp, **extra}


def case(args: tuple[int, str]) -> dict:
    seed, family = args
    np.seterr(all="ignore")
    try:
        recs, info = small_set(seed, family)
        row, cpu = B._diagnose(recs, info["mass_kg"], FACTORS)
    except Exception as exc:  # refused sets are reported, not hidden
        return {"seed": seed, "family": family, "error": f"{type(exc).__name__}: {exc}"}
    keep = {k: row.get(k) for k in ("baseline_nrmse", "data_floor", "floor", "pipeline_nrmse", "causes",
                                     "named_causes", "partial", "symptoms", "candidates", "floor_parts")}
    keep["judged_ratio"] = row["baseline_nrmse"] / row["data_floor"]
    return {"seed": seed, **info, **keep, "cpu_s": cpu}


def _energy(r: dict) -> dict:
    """The row's energy-mismatch values as floats (JSON keeps infinities as text)."""
    e = next((v for k, v, _n in r.get("symptoms", []) if k == "energy_mismatch"), {})
    return {k: float(v) for k, v in e.items()}


def signature(r: dict) -> bool:
    """Whether :func:`eddi.diagnosis.smallamp.amplitude_signature` holds on a row's stored symptom."""
    from eddi.diagnosis.results import Symptom
    from eddi.diagnosis.smallamp import amplitude_signature

    e = {k: float(v) for k, v in _energy(r).items()}
    for key in ("low", "shape"):  # rows of the first runs hold no sum: the bound the least z gives
        if f"{key}_z_sum" not in e and f"{key}_z_min" in e:
            lo, hi = e[f"{key}_z_min"], e[f"{key}_z_max"]
            e[f"{key}_z_sum"] = e["parts"] * (hi if hi < 0 else lo if lo > 0 else 0.0)
    return bool(e) and amplitude_signature([Symptom("energy_mismatch", "", e)]) is not None


def summary(path: str) -> None:
    """One line per row (any bench's rows holding ``symptoms``), then the ratio distributions and how
    often the signature holds above the floor, per family."""
    rows = [json.loads(line) for line in open(path)]
    fams: dict[str, list] = {}
    for r in rows:
        if "error" in r:
            continue
        fam = r.get("family") or r.get("kind", "?")
        full = r["baseline_nrmse"] / r["floor"]
        fams.setdefault(fam, []).append((r["baseline_nrmse"] / r["data_floor"], full, signature(r),
                                         (r.get("named_causes") or {}).get("10", r["causes"].get("2.5|0.6", "?"))))
    for fam, v in fams.items():
        ratio = np.array([x[0] for x in v])
        above = [x for x in v if x[1] > 1.0]
        print(f"# {fam}: n {len(v)}; judged / floor of the data median {np.median(ratio):.2f}, max {ratio.max():.2f}; "
              f"above the floor {len(above)}, signature there {sum(x[2] for x in above)}, anywhere "
              f"{sum(x[2] for x in v)}; verdicts " + ", ".join(f"{c} {sum(x[3] == c for x in v)}"
                                                             for c in sorted({x[3] for x in v})))
    for r in rows:
        if "strength" not in r:
            continue
        if "error" in r:
            print(f"{r['family']:9s} {r['seed']:4d} ERROR {r['error'][:80]}")
            continue
        e = _energy(r)
        print(f"{r['family']:9s} {r['seed']:4d} m {r['mass_kg']:6.3g} f1 {r['f1_hz']:5.3g} z {r['zeta']:.4f} "
              f"fs {r['rate_hz']:6.0f} snr {r['snr_db']:4.1f} r {r['strength']:.2f} ratio {r['judged_ratio']:5.2f} "
              f"low {e.get('low_amplitude_pct', float('nan')):+6.1f}+-{e.get('low_amplitude_se_pct', float('nan')):.1f} "
              f"high {e.get('high_amplitude_pct', float('nan')):+6.1f} z[{e.get('low_z_min', float('nan')):+.1f},"
              f"{e.get('low_z_max', float('nan')):+.1f}] dz[{e.get('shape_z_min', float('nan')):+.1f},"
              f"{e.get('shape_z_max', float('nan')):+.1f}] {r['named_causes'].get('10', '?')} "
              f"(partial {r.get('partial')}) sig {int(signature(r))}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="0-9")
    ap.add_argument("--family", default="null", help="one of " + ", ".join(FAMILIES) + " or a comma list")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out")
    ap.add_argument("--summary", metavar="FILE")
    a = ap.parse_args()
    if a.summary:
        summary(a.summary)
        return
    lo, _, hi = a.seeds.partition("-")
    seeds = [int(s) for s in a.seeds.split(",")] if not hi else list(range(int(lo), int(hi) + 1))
    work = [(s, f) for s in seeds for f in a.family.split(",")]
    with ProcessPoolExecutor(a.jobs) as ex:
        for row in ex.map(case, work):
            line = json.dumps(row)
            if a.out:
                with open(a.out, "a") as fh:
                    fh.write(line + "\n")
            print(line[:300], flush=True)


if __name__ == "__main__":
    main()
