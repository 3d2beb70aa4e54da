"""Detection limits and false alarms of ``eddi.diagnose``, and its run time.

For each mechanism, its magnitude is swept against the accelerometer SNR; each point hides
the mechanism in the reference system, records three impacts through the acceleration-only
chain (simulated rig -> conditioning) and runs the diagnosis. The smallest magnitude found
(right cause) at each SNR is printed, then the false-alarm rate on null cases (nothing
hidden) over many seeds, then the time to diagnose three 6 s captures at 10 kHz.

    python benchmarks/bench_diagnose.py [--quick]

The numbers are quoted in docs/diagnosis.md.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from eddi.conditioning import condition
from eddi.diagnose import Record, diagnose
from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test

#: Reference system: 12.3 Hz, zeta 0.4 %, mildly hardening (about 8 % at 1.6 mm).
SYSTEM = EquationOfMotion.create(mass=0.1, damping={"v": 0.06}, stiffness={"x": 600.0, "x^3": 2e7})
FORCES_N = (12.0, 20.0, 30.0)
DAMPING = "v,x^2*v,v^3"
STIFFNESS = "x,x^2,x^3,x^4,x^5"

#: Magnitude ladders (a scale factor s multiplies a reference magnitude).
LADDER = (0.05, 0.1, 0.2, 0.4, 0.8, 1.6)


def hidden(name: str, s: float) -> dict:
    """The hidden effect ``name`` at scale ``s`` (1 = clearly visible on the reference system)."""
    if name == "coulomb_friction":
        return {"name": name, "params": {"force_n": 0.005 * s}}
    if name == "quadratic_damping":
        return {"name": name, "params": {"coefficient": 0.5 * s}}
    if name == "clearance":
        return {"name": name, "params": {"gap_m": 0.5e-3, "stiffness_n_per_m": 200.0 * s}}
    if name == "asymmetric_stiffness":
        return {"name": name, "params": {"k2": 4e4 * s}}
    if name == "second_mode":
        # 30 Hz second mode, coupling scaled
        kc = 300.0 * s
        return {"name": name, "params": {"mass_kg": 0.05, "stiffness_n_per_m": 1777.0 - kc,
                                         "damping_n_s_per_m": 0.1, "coupling_n_per_m": kc}}
    raise ValueError(name)


def records(effects: list[dict], seed: int, snr_db: float, rate_hz: float = 5000.0,
            record_s: float = 4.0) -> list[Record]:
    out = []
    for i, f in enumerate(FORCES_N):
        r = impact_test(SYSTEM, f * (1 + 0.1 * ((seed + i) % 3)), rate_hz=rate_hz, pretrigger_s=0.2,
                        record_s=record_s, snr_db=snr_db, effects=effects, seed=1000 * seed + i)
        c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
        out.append(Record.from_conditioned(c, label=f"impact {i + 1}"))
    return out


def run(name: str | None, s: float, seed: int, snr_db: float) -> tuple[str, float]:
    effects = [hidden(name, s)] if name else []
    stiff = "x,x^3" if name == "asymmetric_stiffness" else STIFFNESS
    d = diagnose(records(effects, seed, snr_db), SYSTEM.mass, damping=DAMPING, stiffness=stiff)
    return d.cause, d.gain


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer SNRs and seeds")
    args = ap.parse_args()
    snrs = (45.0, 30.0) if args.quick else (60.0, 45.0, 30.0, 20.0)
    seeds = range(2) if args.quick else range(3)
    names = ("coulomb_friction", "quadratic_damping", "clearance", "asymmetric_stiffness", "second_mode")
    print("smallest magnitude (scale of the reference) found on every seed, per SNR [dB]")
    print(f"{'mechanism':<22}" + "".join(f"{snr:>8.0f}" for snr in snrs))
    for name in names:
        row = []
        for snr in snrs:
            found = "-"
            for s in LADDER:
                if all(run(name, s, seed, snr)[0] == name for seed in seeds):
                    found = f"{s:g}"
                    break
            row.append(found)
        print(f"{name:<22}" + "".join(f"{v:>8}" for v in row), flush=True)
    n_null = 6 if args.quick else 20
    for snr in snrs:
        alarms = [run(None, 1.0, seed, snr) for seed in range(n_null)]
        bad = [c for c, _ in alarms if c != "none"]
        print(f"false alarms at {snr:.0f} dB: {len(bad)}/{n_null} {bad}  "
              f"(largest gain of a null: {max(g for _, g in alarms):.3f})", flush=True)
    recs = records([hidden("clearance", 1.0)], 0, 45.0, rate_hz=10000.0, record_s=6.0)
    t0 = time.perf_counter()
    diagnose(recs, SYSTEM.mass, damping=DAMPING, stiffness=STIFFNESS)
    print(f"three 6 s captures at 10 kHz diagnosed in {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
