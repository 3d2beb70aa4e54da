"""How often `station identify`'s hammer-impulse check warns on clean records, and whether it names
a response in g read as m/s^2, an inverted accelerometer and a 5 % mass error.

Draws single-DOF impact records (0.01-1000 kg, 2-300 Hz, 0.3-5 % damping, hardening or softening
cubic springs, 1-40 kHz, 30-60 dB, blows of 0.3-3 ms), conditions each as the pipeline does and
runs :func:`station.impulse_check.check_signal` with the true mass, then with the record's
response divided by g, negated, and with the mass 5 % low. Prints per family the ratios' range
and how many checks named each fault (a warning on a clean record is a false alarm).

    python benchmarks/bench_impulse_check.py --records 60 --seed 0
    python benchmarks/bench_impulse_check.py --records 60 --seed 3 --coarse
"""

from __future__ import annotations

import argparse
import math
import sys
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from eddi.conditioning import condition  # noqa: E402
from station.impulse_check import G, check_signal  # noqa: E402
from tests.eddi.impact_cases import impact_record  # noqa: E402


def draw(rng: np.random.Generator, coarse: bool = False) -> dict:
    """One system and its test set-up (``coarse``: 12-60 samples a cycle, blows of 2-8 samples)."""
    m = float(10 ** rng.uniform(-2, 3))
    f = float(10 ** rng.uniform(math.log10(2), math.log10(300)))
    k = m * (2 * math.pi * f) ** 2
    zeta = float(10 ** rng.uniform(math.log10(0.003), math.log10(0.05)))
    rate = float(rng.choice([1000.0, 2000.0, 5000.0, 10000.0, 20000.0, 40000.0]))
    rate = max(rate, 20 * f)
    pulse = float(10 ** rng.uniform(math.log10(3e-4), math.log10(3e-3)))
    if coarse:
        rate = float(f * rng.uniform(12, 60))
        pulse = float(rng.uniform(2, 8)) / rate
    pulse = min(pulse, 0.25 / f)
    x_peak = float(10 ** rng.uniform(-4, -2.3))
    peak_n = k * x_peak * math.pi / (2 * math.pi * f * pulse * 2)  # about x_peak after the blow
    k3 = float(rng.choice([1.0, -0.4])) * 0.3 * k / x_peak ** 2
    cycles = float(rng.uniform(15, 60))
    duration = min(max(cycles / f, 0.5), 40.0, 300000 / rate)
    return dict(system=dict(mass=m, damping={"v": 2 * zeta * m * 2 * math.pi * f},
                            stiffness={"x": k, "x^3": k3}, peak_n=peak_n),
                rate_hz=rate, duration_s=duration + 0.2, pretrigger_s=0.2, pulse_s=pulse,
                snr_db=float(rng.uniform(30, 60)), f=f)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--records", type=int, default=60, help="systems drawn (default 60)")
    ap.add_argument("--seed", type=int, default=0, help="draw seed (default 0)")
    ap.add_argument("--coarse", action="store_true",
                    help="coarse records: 12-60 samples a cycle, blows of 2-8 samples (session 12)")
    ap.add_argument("--lag", action="store_true",
                    help="also a 4th-order Butterworth low-pass on the acceleration only, cut-off 1.5-5 / blow "
                         "(session 13): how often the response's lag is named and the ratios then; the lag is "
                         "also counted on every family")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    lag_rng = np.random.default_rng(args.seed + 7919)  # the systems drawn stay those without --lag
    fams = ("clean", "g_as_si", "sign", "mass_5pct_low") + (("lowpass_acc",) if args.lag else ())
    found: dict[str, Counter] = {k: Counter() for k in fams}
    ratios: dict[str, list[float]] = {k: [] for k in found}
    for i in range(args.records):
        d = draw(rng, args.coarse)
        r = impact_record(d["system"], rate_hz=d["rate_hz"], duration_s=d["duration_s"],
                          pretrigger_s=d["pretrigger_s"], pulse_s=d["pulse_s"], snr_db=d["snr_db"],
                          seed=args.seed * 1000 + i)
        pre = int(d["pretrigger_s"] * d["rate_hz"])
        mass = d["system"]["mass"]
        cases = [("clean", r.acc, mass), ("g_as_si", r.acc / G, mass), ("sign", -r.acc, mass),
                 ("mass_5pct_low", r.acc, 0.95 * mass)]
        if args.lag:
            from scipy.signal import butter, lfilter

            fc = min(lag_rng.uniform(1.5, 5.0) / d["pulse_s"], 0.45 * d["rate_hz"])
            cases.append(("lowpass_acc", lfilter(*butter(4, fc / (d["rate_hz"] / 2)), r.acc), mass))
        for fam, acc, m in cases:
            try:
                sig = condition(r.t, acc=acc, force=r.force, pretrigger_samples=pre)
            except Exception as exc:  # noqa: BLE001 - a record the conditioner refuses is counted
                found[fam]["refused: " + type(exc).__name__] += 1
                continue
            chk = check_signal(sig, m)
            if chk is None:
                found[fam]["no check"] += 1
                continue
            ratios[fam].append(chk.ratio)
            found[fam][chk.fault or "silent"] += 1
            if args.lag and chk.lag is not None:
                found[fam]["lag named"] += 1
    print(f"hammer-impulse check, {args.records} drawn {'coarse ' if args.coarse else ''}systems (seed {args.seed})")
    for fam in found:
        q = np.array(ratios[fam])
        rng_txt = f"ratio {q.min():.4g} .. {q.max():.4g}, median {np.median(q):.4g}" if q.size else "no ratio"
        print(f"  {fam:14s} {dict(found[fam])}  {rng_txt}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
