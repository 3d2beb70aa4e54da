"""A low, large mode leaking into stiffer, more damped modal coordinates: per-mode EDDI frequencies.

Session 17 (helper s17leak, issue 14). A blind three-channel capture set (acc only, no mass,
modes 2.5 / 15.6 / 22.5 Hz) gave the uncoupled modal fits 2.52 / 8.89 / 10.80 Hz: the 2.5 Hz
mode, ~80x the displacement of the 22 Hz one at equal acceleration, leaks through small errors
of the tail's mode shapes into the other modal coordinates, and phase two's ``k q_i ~ -q_i'' - B``
pulls their stiffness toward mode 1's. Own cases of that kind: chains ground-m1-m2(-m3) with a
soft spring to ground under a heavy first mass (the low mode), stiffness-proportional dashpots
(upper modes 2-10 % damped, the low one < 1 %), a cubic spring (``share`` of its linear force at
the largest blow), acc only, 45 dB, no mass, 1-10 kHz.

Per case: three blows, conditioned as ``station diagnose`` does, the tail's linear modes (ERA),
the uncoupled modal fits (``fit_all(coupling=False)``, the diagnosis' baseline equations), per
mode ``sqrt(k_i) / 2 pi`` against the true linear modes; CPU seconds. ``--pin``: as
``identify_mdof`` does, refit with the tail's stiffness a mode whose own departs by > 3 %
(:func:`eddi.mdof.equations.era_stiffness`). Figures: docs/multi-dof.md (session 17).

    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_leak.py --set tune|heldout|heldout2 [--pin]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_mdof import _measurement  # noqa: E402
from eddi.mdof.coordinates import choose_coordinates, linear_modes  # noqa: E402
from eddi.mdof.equations import fit_all  # noqa: E402
from eddi.mdof.terms import monomial  # noqa: E402
from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test  # noqa: E402
from station.mdof_data import condition_multichannel  # noqa: E402


def chain(name, masses, ks, beta, k3, k3_at=(0, 1), rate=2048.0, record_s=4.0, impacts=(40.0, 80.0, 120.0),
          drive=2, pre=0.05):
    """ground-m1-..-mN chain, springs ``ks`` (first to ground; one more than masses: mN to ground),
    dashpots ``beta k``, cubic ``k3`` on the element ``k3_at``."""
    els = []
    n = len(masses)
    for j, k in enumerate(ks):
        between = (j, j + 1) if j < n else (0, n)
        els.append(Element(between=between, k=k, c=beta * k, k3=k3 if between == tuple(k3_at) else 0.0))
    return MdofSystem(name=name, description=name, masses_kg=tuple(masses), elements=tuple(els), driving_point=drive,
                      rate_hz=rate, record_s=record_s, impacts_n=tuple(impacts), pretrigger_s=pre)


TUNE = {
    # the blind record's kind: 2.5 / 15.6 / 22.5 Hz (m3 held to ground too), upper modes 5-7 %
    "t3c": lambda: chain("t3c", (5.0, 0.5, 0.3), (415.5, 4763.7, 2060.2, 2486.8), 1e-3, 1e5, rate=1024.0,
                         record_s=6.0),
    "t3d": lambda: chain("t3d", (12.0, 1.0, 0.8), (964.8, 9830.8, 4736.7, 6761.8), 1.4e-3, 3e5, rate=2048.0,
                         record_s=6.0, drive=2),
    # 3 masses: ~2.5 / 15 / 23 Hz, upper modes ~3-5 %
    "t3a": lambda: chain("t3a", (5.0, 0.5, 0.3), (1300.0, 4000.0, 3000.0), 7e-4, 4e5, rate=2048.0),
    "t3b": lambda: chain("t3b", (12.0, 1.0, 0.6), (3000.0, 9000.0, 7000.0), 1.2e-3, 1e6, rate=5000.0, drive=3),
    "t2a": lambda: chain("t2a", (4.0, 0.4), (1000.0, 3000.0), 9e-4, 3e5, rate=1024.0, record_s=5.0, drive=2),
}
HELDOUT = {
    "h3c": lambda: chain("h3c", (2.0, 0.3, 0.2), (112.1, 2968.5, 1394.4, 2289.7), 9e-4, 2e4, rate=2048.0,
                         record_s=6.0, drive=3),
    "h3d": lambda: chain("h3d", (8.0, 0.6, 0.5), (343.3, 5743.1, 2035.7, 2945.1), 1.6e-3, 2e5, rate=1000.0,
                         record_s=7.0),
    "h3a": lambda: chain("h3a", (8.0, 0.8, 0.4), (2000.0, 6000.0, 3500.0), 1e-3, 6e5, rate=4096.0),
    "h3b": lambda: chain("h3b", (3.0, 0.3, 0.2), (700.0, 2600.0, 2200.0), 6e-4, 1.5e5, rate=10000.0, drive=1),
    "h2a": lambda: chain("h2a", (20.0, 1.5), (5000.0, 16000.0), 1.5e-3, 2e6, rate=2048.0, drive=2),
}

#: Held out from the ERA check (written after the own-span runs, run once with and without ``--pin``).
HELDOUT2 = {
    "g3a": lambda: chain("g3a", (6.0, 0.5, 0.4), (114.3, 2536.8, 1585.2, 2381.9), 1.5e-3, 5e3, rate=5000.0,
                         record_s=8.0, drive=2),
    "g3b": lambda: chain("g3b", (3.0, 0.4, 0.25), (450.6, 6359.2, 2492.5, 3214.2), 8e-4, 1e5, rate=2048.0,
                         record_s=5.0, drive=1),
    "g3c": lambda: chain("g3c", (10.0, 0.8, 0.6), (615.2, 8696.0, 2510.3, 5150.8), 1.2e-3, 2e5, rate=1024.0,
                         record_s=6.0, drive=3),
    "g2b": lambda: chain("g2b", (10.0, 0.6), (2000.0, 8000.0), 1.2e-3, 8e5, rate=4096.0, drive=2),
}

PIN = False


def records(system, snr=45.0):
    return [condition_multichannel(_measurement(mdof_impact_test(system, p, seed=700 + k, snr_db=snr)))
            for k, p in enumerate(system.impacts_n)]


def run(name, system):
    truth = system.model()
    f_true = np.sort(truth.natural_frequencies_hz())
    recs = records(system)
    d = truth.channels.index(truth.driving_point)
    c0 = time.process_time()
    modes = linear_modes(recs, tail_fraction=0.2, driving_point=d)
    kind, tmat, _span = choose_coordinates(recs, modes, coordinates="modal")
    fits = fit_all(recs, tmat, False, 3e-3)
    if PIN and tmat.shape[1] == len(modes.frequencies_hz):
        from eddi.mdof.equations import era_stiffness

        pins = era_stiffness(fits, modes.frequencies_hz, modes.damping_ratios)
        if any(p is not None for p in pins):
            fits = fit_all(recs, tmat, False, 3e-3, k_lin=pins)
    cpu = time.process_time() - c0
    n = tmat.shape[1]
    f_id = [np.sqrt(max(f.stiffness.get(monomial({i: 1}, n), 0.0), 0.0)) / (2 * np.pi) for i, f in enumerate(fits)]
    zeta = [f.damping.get(monomial({i: 1}, n, rate=True), np.nan) / (2 * 2 * np.pi * max(fi, 1e-9))
            for i, (f, fi) in enumerate(zip(fits, f_id))]
    err = [100 * abs(a - b) / b for a, b in zip(f_id, f_true)]
    print(f"{name}: true {', '.join(f'{f:.3f}' for f in f_true)} Hz; ERA "
          f"{', '.join(f'{f:.3f}' for f in modes.frequencies_hz)}; EDDI {', '.join(f'{f:.3f}' for f in f_id)} Hz "
          f"(err {', '.join(f'{e:.1f}' for e in err)} %; zeta {', '.join(f'{z:.3f}' for z in zeta)}); "
          f"cubic {', '.join(f'{f.stiffness.get(monomial({i: 3}, n), 0.0):.3g}' for i, f in enumerate(fits))}; "
          f"{cpu:.1f} s CPU", flush=True)
    return max(err)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--set", default="tune", choices=("tune", "heldout", "heldout2"))
    ap.add_argument("--cases", default="")
    ap.add_argument("--pin", action="store_true")
    a = ap.parse_args()
    global PIN
    PIN = a.pin
    cases = {"tune": TUNE, "heldout": HELDOUT, "heldout2": HELDOUT2}[a.set]
    for name, make in cases.items():
        if a.cases and name not in a.cases.split(","):
            continue
        run(name, make())


if __name__ == "__main__":
    main()
