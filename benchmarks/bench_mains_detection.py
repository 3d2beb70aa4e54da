"""False alarms and detections of the mains-tone detector (eddi.diagnosis.mains) on rig captures.

Random one-DOF systems (10-200 Hz, half of them at line-like frequencies 49.7-150 Hz, zeta
0.2-5 %, 0.1-3 kg, 2/4/10 kHz, 30-60 dB, 50 ms pre-trigger, 1 s): ``null`` counts captures with
any tone found; ``tone`` adds 0.02-0.2 m/s^2 at 50 or 60 Hz (+-0.5 %) and counts the tones found
at the right frequency by their size over the pre-trigger's standard error.

    python benchmarks/bench_mains_detection.py SEED COUNT null|tone
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository's tests/ (the cases)

from eddi.diagnosis.chain import record_tones  # noqa: E402
from simulated_rig.bench import impact_test  # noqa: E402
from simulated_rig.sensors import accelerometer, force_sensor  # noqa: E402
from tests.eddi.diagnose_cases import to_record  # noqa: E402
from tests.eddi.test_diagnose_mains import _system  # noqa: E402


def _capture(rng: np.random.Generator, i: int, tone: bool):
    """One random capture: (record, mains spec or {}, the rig's result, a text of the system)."""
    f = float(rng.choice([rng.uniform(10, 200), rng.choice([49.7, 50, 50.3, 59.8, 60, 100, 120, 150])]))
    z, m = float(rng.uniform(0.002, 0.05)), float(rng.uniform(0.1, 3))
    rate, snr = float(rng.choice([2048, 4096, 10240])), float(rng.uniform(30, 60))
    mains = dict(mains_si=float(rng.uniform(0.02, 0.2)),
                 mains_hz=float(rng.choice([50, 60]) * rng.uniform(0.995, 1.005))) if tone else {}
    r = impact_test(_system(m, f, z), float(rng.uniform(10, 100)) * m, rate_hz=rate, pretrigger_s=0.05,
                    record_s=1.0, sensors=(force_sensor(), accelerometer(snr_db=snr, **mains)), seed=1000 + i)
    return to_record(r.t, r.acc_m_s2, r.force_n, r.pretrigger_samples, "x"), mains, r, \
        f"{f:.4g} Hz, zeta {z:.3g}, {rate:g} Hz, {snr:.0f} dB"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("seed", type=int, help="the draws' seed")
    ap.add_argument("count", type=int, help="captures to draw")
    ap.add_argument("kind", choices=("null", "tone"), help="null: no tone; tone: a mains tone added")
    args = ap.parse_args()
    rng, tone = np.random.default_rng(args.seed), args.kind == "tone"
    fa, rows = 0, []
    for i in range(args.count):
        try:
            rec, mains, r, text = _capture(rng, i, tone)
        except Exception as exc:  # a draw the conditioning refuses: counted out, said
            print("skip", exc)
            continue
        tones = record_tones(rec)
        if not tone:
            if tones:
                fa += 1
                print("FALSE", text, [(x.frequency_hz, x.amplitude, x.pre_sigmas, x.tail_sigmas) for x in tones])
            continue
        # detectable: the tone stands 4 standard errors in the pre-trigger at least
        se = r.sensors[1].noise_rms_si * math.sqrt(2 / r.pretrigger_samples)
        ok = [x for x in tones if abs(x.frequency_hz - mains["mains_hz"]) < 0.01 * mains["mains_hz"]]
        rows.append((mains["mains_si"] / se, bool(ok), len(tones) - len(ok)))
        if not ok and rows[-1][0] >= 8:
            print(f"missed: {mains['mains_si']:.3g} m/s^2 at {mains['mains_hz']:.4g} Hz ({rows[-1][0]:.0f} se) "
                  f"on {text}")
    if not tone:
        print("false alarms", fa, "of", args.count)
        return 0
    a = np.array(rows)
    for lo, hi in [(0, 4), (4, 8), (8, 16), (16, 1e9)]:
        s = (a[:, 0] >= lo) & (a[:, 0] < hi)
        print(f"tone/se {lo}-{hi}: {int(a[s, 1].sum())}/{int(s.sum())} found, wrong extra {int(a[s, 2].sum())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
