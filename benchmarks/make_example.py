"""Write ``station/examples/duffing-impact.csv``: a force + acceleration impact record.

The system is a Duffing-like oscillator after the paper's rig (Sec. 3.3.1: m = 0.815 kg,
k1 = 390 N/m, k3 = 1.3e7 N/m^3) with more damping (b1 = 1.0 Ns/m) so that it rings down
within the 5 s record. Simulated with :func:`simulated_rig.bench.impact_test`: a 200 N
hammer blow, 1 s pre-trigger, 5 kHz, force and accelerometer at 45 dB SNR, 24-bit ADC.

Run: python benchmarks/make_example.py [--write | --out PATH]. Without an option it only
prints the true coefficients and the record's size; --write rewrites the packaged example.
"""

from __future__ import annotations

import argparse
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "station" / "examples" / "duffing-impact.csv"
TRUTH = dict(mass=0.815, damping={"v": 1.0}, stiffness={"x": 390.0, "x^3": 1.3e7},
             notes="example: paper Sec. 3.3.1 Duffing rig stiffness, b1 = 1.0 Ns/m")


def main(out: Path | None) -> None:
    import numpy as np

    from eddi.model import EquationOfMotion
    from simulated_rig.bench import impact_test

    truth = EquationOfMotion.create(**TRUTH)
    rec = impact_test(truth, 200.0, rate_hz=5000.0, pretrigger_s=1.0, record_s=5.0,
                      snr_db=45.0, force_snr_db=45.0, seed=7)
    print(f"truth: mass {truth.mass} kg, damping {truth.damping}, stiffness {truth.stiffness}")
    if out is None:
        print(f"{rec.n_samples} samples; nothing written (--write rewrites {OUT}, --out PATH writes elsewhere)")
        return
    data = np.column_stack((rec.t, rec.force_n, rec.acc_m_s2))
    out.parent.mkdir(parents=True, exist_ok=True)
    np.savetxt(out, data, delimiter=",", header="t,force,acc", comments="", fmt="%.9g")
    print(f"wrote {out} ({out.stat().st_size / 1e6:.2f} MB, {rec.n_samples} samples)")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    where = ap.add_mutually_exclusive_group()
    where.add_argument("--write", action="store_true", help=f"rewrite the packaged example ({OUT.name})")
    where.add_argument("--out", type=Path, metavar="PATH", help="write the record to PATH instead")
    args = ap.parse_args()
    main(OUT if args.write else args.out)
