"""Write ``station/examples/duffing-impact.csv``: a force + acceleration impact record.

The system is a Duffing-like oscillator after the paper's rig (Sec. 3.3.1: m = 0.815 kg,
k1 = 390 N/m, k3 = 1.3e7 N/m^3) with more damping (b1 = 1.0 Ns/m) so that it rings down
within the 5 s record. Simulated with :func:`simulated_rig.bench.impact_test`: a 200 N
hammer blow, 1 s pre-trigger, 5 kHz, force and accelerometer at 45 dB SNR, 24-bit ADC.

Run: ``python benchmarks/make_example.py`` (prints the true coefficients); ``--out FILE`` to
write elsewhere instead of replacing the packaged example.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test

OUT = Path(__file__).resolve().parents[1] / "station" / "examples" / "duffing-impact.csv"
TRUTH = EquationOfMotion.create(
    mass=0.815, damping={"v": 1.0}, stiffness={"x": 390.0, "x^3": 1.3e7},
    notes="example: paper Sec. 3.3.1 Duffing rig stiffness, b1 = 1.0 Ns/m",
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=OUT, help="CSV to write (default: the packaged example, %(default)s)")
    out = ap.parse_args().out
    rec = impact_test(TRUTH, 200.0, rate_hz=5000.0, pretrigger_s=1.0, record_s=5.0,
                      snr_db=45.0, force_snr_db=45.0, seed=7)
    data = np.column_stack((rec.t, rec.force_n, rec.acc_m_s2))
    out.parent.mkdir(parents=True, exist_ok=True)
    np.savetxt(out, data, delimiter=",", header="t,force,acc", comments="", fmt="%.9g")
    print(f"wrote {out} ({out.stat().st_size / 1e6:.2f} MB, {rec.n_samples} samples)")
    print(f"truth: mass {TRUTH.mass} kg, damping {TRUTH.damping}, stiffness {TRUTH.stiffness}")


if __name__ == "__main__":
    main()
