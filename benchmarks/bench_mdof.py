"""Multi-DOF identification on the simulated rig's MDOF systems (acc only, 45 dB, no mass given).

For each system: three impacts (the system's levels) train, a fourth (70 % of the largest,
another noise seed) is held out. Identification (:func:`eddi.mdof.identify.identify_mdof`,
coordinates chosen from the data), then output-error refinement
(:func:`eddi.mdof.refine.refine_mdof`). Prints the held-out nrmse of every channel against
the floor 0.05, the same figure for the TRUE model on the same conditioned record (what the
measurement allows), the natural frequencies against the truth (floor 3 %) and, in physical
coordinates, the identified masses and coefficients against the truth.

    PYTHONPATH=. python benchmarks/bench_mdof.py [--systems two-mass-cubic,internal-1-3,nes] [--no-refine]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from eddi.mdof.identify import identify_mdof
from eddi.mdof.refine import refine_mdof
from eddi.mdof.validate import validate_mdof
from simulated_rig.mdof_systems import load_mdof_system, mdof_impact_test
from station.mdof_data import condition_multichannel
from station.readers import Measurement


def _measurement(rec) -> Measurement:
    return Measurement(t=rec.t, channels=rec.columns(), rate_hz=rec.rate_hz, pretrigger_samples=rec.pretrigger_samples,
                       mass=None, source=f"rig {rec.peak_force_n:g} N", metadata={})


def run(name: str, refine: bool) -> None:
    system = load_mdof_system(name)
    truth = system.model()
    peaks = list(system.impacts_n) + [0.7 * max(system.impacts_n)]
    recs = [condition_multichannel(_measurement(mdof_impact_test(system, p, seed=100 + k)))
            for k, p in enumerate(peaks)]
    t0 = time.perf_counter()
    ident = identify_mdof(recs[:3], truth.channels, truth.driving_point)
    model = ident.model
    if refine:
        model, _b, _a = refine_mdof(model, recs[:3])
    dt = time.perf_counter() - t0
    held = validate_mdof(model, recs[3])
    floor = validate_mdof(truth, recs[3])
    f_id, f_true = model.natural_frequencies_hz(), truth.natural_frequencies_hz()
    print(f"{name}: {ident.coordinates} coordinates, {dt:.1f} s, tail modes "
          f"{', '.join(f'{f:.4g}' for f in ident.modes.frequencies_hz)} Hz")
    for c in truth.channels:
        e = held.channel_nrmse[c]
        print(f"  held-out nrmse {c}: {e:.4f}  (true model {floor.channel_nrmse[c]:.4f}; floor 0.05 -> "
              f"{'met' if e <= 0.05 else 'NOT met'})")
    for k, ft in enumerate(f_true):
        if ft > 0 and k < len(f_id):
            err = abs(f_id[k] - ft) / ft
            print(f"  f{k + 1}: {f_id[k]:.4f} Hz vs true {ft:.4f} Hz ({100 * err:.3f} %; floor 3 % -> "
                  f"{'met' if err <= 0.03 else 'NOT met'})")
    if ident.coordinates == "physical":
        print(f"  masses {[round(m, 4) for m in model.mass]} kg vs true {list(truth.mass)}")
        for i in range(truth.n_coords):
            for t, c in truth.stiffness[i].items():
                got = model.stiffness[i].get(t, 0.0)
                print(f"  eq {i + 1} {t:>10}: {got:.5g} vs {c:.5g} ({100 * abs(got - c) / abs(c):.2f} %)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--systems", default="two-mass-cubic,internal-1-3,nes")
    ap.add_argument("--no-refine", action="store_true", help="EDDI only, no output-error refinement")
    args = ap.parse_args()
    for name in args.systems.split(","):
        run(name.strip(), not args.no_refine)


if __name__ == "__main__":
    main()
