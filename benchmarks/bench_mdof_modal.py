"""The MDOF linear modal step (ERA, :mod:`eddi.mdof.modal`) on chains other than the rig's, 30-60 dB.

Cases of its own: chains of 2-4 masses with other mass and stiffness ratios, damping levels
and sample rates, a cubic spring scaled so that it adds ``ratio`` (30 %) of the linear force
at the largest blow. ``--set tune`` are the cases used while developing the stabilisation
diagram; ``--set heldout`` were run once after it (report them separately). Printed per case
and SNR: true linear frequencies, ERA's, the MAC of each found shape with the nearest true one,
and the modal evidence (``basis`` / ``unresolved`` / ``missing_mode``: a chain has no missing
mode, so ``missing_mode`` there is a wrong name). The last line counts cases whose modes all
came out within 1 % (floor: every case) and wrong names (floor: 0).

    PYTHONPATH=. python benchmarks/bench_mdof_modal.py [--set tune|heldout] [--snr 30,45,60]
"""

from __future__ import annotations

import argparse

import numpy as np

from eddi.errors import IdentificationError
from eddi.mdof.identify import linear_modes, modal_evidence
from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test
from station.mdof_data import condition_multichannel
from station.readers import Measurement


def chain(masses, ks, cs, k3_at=None, ratio=0.3, rate=2048.0) -> MdofSystem:
    """Ground-m1-...-mn; the cubic spring of element ``k3_at`` gives ``ratio`` of its linear force at 300 N."""
    els = [Element(between=(i, i + 1), k=k, c=c) for i, (k, c) in enumerate(zip(ks, cs))]
    lin = MdofSystem(name="chain", masses_kg=tuple(masses), elements=tuple(els), rate_hz=rate)
    if k3_at is None:
        return lin
    x = mdof_impact_test(lin, max(lin.impacts_n), snr_db=None).truth_x
    a, b = els[k3_at].between
    d = (x[a - 1] if a > 0 else 0.0) - (x[b - 1] if b > 0 else 0.0)
    k3 = float(f"{ratio * els[k3_at].k / np.max(np.abs(d)) ** 2:.3g}")
    els[k3_at] = els[k3_at].model_copy(update={"k3": k3})
    return lin.model_copy(update={"elements": tuple(els)})


CASES = {
    "tune": {
        "2 masses 0.5/2 kg": lambda: chain([0.5, 2.0], [3e4, 2e4], [3, 2], 1),
        "3 masses heavy-light": lambda: chain([2, 1, 0.3], [6e4, 2e4, 1e4], [6, 2, 1], 2),
        "2 masses stiffness ratio 10": lambda: chain([1, 1], [1e5, 1e4], [4, 1], 1),
        "4 equal masses": lambda: chain([1, 1, 1, 1], [4e4] * 4, [3] * 4, 3),
    },
    "heldout": {
        "3 masses 4096 Hz light damping": lambda: chain([0.8, 0.5, 0.3], [5e4, 3e4, 2e4], [1, 0.5, 0.3], 1,
                                                       rate=4096.0),
        "2 masses heavy damping grounded cubic": lambda: chain([1.5, 0.4], [4e4, 1.5e4], [15, 4], 0, ratio=0.2),
        "4 masses 1024 Hz stiff-soft": lambda: chain([1.2, 0.9, 0.6, 0.3], [8e4, 1e4, 3e4, 5e3], [4, 1, 2, 0.5], 2,
                                                    rate=1024.0),
        "2 masses linear": lambda: chain([0.7, 0.35], [2.5e4, 1.8e4], [3, 1]),
    },
}


def run(name: str, system: MdofSystem, snr: float) -> tuple[bool, bool]:
    recs = []
    for k, peak in enumerate(system.impacts_n):
        r = mdof_impact_test(system, peak, seed=10 + k, snr_db=snr)
        recs.append(condition_multichannel(Measurement(t=r.t, channels=r.columns(), rate_hz=r.rate_hz,
                                                       pretrigger_samples=r.pretrigger_samples, mass=None,
                                                       source="rig", metadata={})))
    truth = system.model().natural_frequencies_hz()
    m_, _c, k_ = system.model().linear_matrices()
    w, v = np.linalg.eig(np.linalg.solve(m_, k_))
    v = v[:, np.argsort(w.real)].real
    try:
        modes = linear_modes(recs)
    except IdentificationError as exc:
        print(f"  {name:<40} {snr:>4.0f} dB  true {np.round(truth, 2)}  REFUSED: {exc}")
        return False, False
    f = modes.frequencies_hz
    macs = [max((v[:, j] @ modes.shapes[:, i]) ** 2 / (v[:, j] @ v[:, j]) / (modes.shapes[:, i] @ modes.shapes[:, i])
                for j in range(v.shape[1])) for i in range(f.size)]
    ok = f.size == truth.size and bool(np.all(np.abs(f - truth) <= 0.01 * truth))
    evidence = modal_evidence(modes, truth.size)
    print(f"  {name:<40} {snr:>4.0f} dB  true {np.round(truth, 2)}  ERA {np.round(f, 2)}  "
          f"MAC {np.round(macs, 4)}  {evidence}{'' if ok else '  (NOT within 1 %)'}")
    return ok, evidence == "missing_mode"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--set", choices=sorted(CASES), default="tune")
    ap.add_argument("--snr", default="30,45,60", help="comma-separated SNRs [dB]")
    args = ap.parse_args()
    n = good = wrong = 0
    for name, make in CASES[args.set].items():
        system = make()
        for snr in (float(s) for s in args.snr.split(",")):
            ok, bad = run(name, system, snr)
            n, good, wrong = n + 1, good + ok, wrong + bad
    print(f"{args.set}: {good}/{n} cases with every mode within 1 % (floor {n}/{n}); "
          f"wrong missing_mode names {wrong} (floor 0)")


if __name__ == "__main__":
    main()
