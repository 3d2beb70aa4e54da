"""Lightly damped two- and three-mass chains near internal resonance: EDDI alone and polished.

Own systems of session 9 (issue 14), built from target natural frequencies: a chain
ground - m1 - m2 (- m3) whose springs are solved so that the linear modes sit at ``f1`` and
``ratio * f1`` (ratios near 1:2 and 1:3), dashpots proportional to the springs (modal damping
ratio ``zeta`` at ``f1``), and a weak cubic spring whose force at the largest blow is ``share``
of the linear spring it sits beside. Records are 3 s or shorter, so a lightly damped record's
envelope never falls below 10x its noise: the free window reaches the record's end, where the
zero-phase drift filter's backward pass starts (session 8's open problem).

Per case: three blows train, a fourth (70 % of the largest, another noise seed) is held out;
accelerometers only, 45 dB, no mass given. Printed: the candidate kept and every candidate's
training nrmse, held-out nrmse per channel (EDDI alone, polished, the true model on the same
conditioned record; floor 0.05), natural frequencies and the cubic coefficients against the
truth (floor 3 %), CPU seconds.

Sets: ``tune`` (used while changing the code) and ``heldout`` (written at the same time, run
only at the end of the session).

    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_light.py --set tune [--cases NAME,..] [--no-polish]
    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_light.py --set modal-tune --coordinates modal

Modal sets (session 10): the model in modal coordinates is also scored by its shapes and modal
masses against the truth's, the coupling monomials it keeps (none on a null), and the cubic spring
equivalent to its cubic forces (the coupling coefficient of a modal model: its monomials are
another basis of the same force).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_mdof import _measurement, coupling_errors  # noqa: E402
from eddi.mdof.identify import identify_mdof  # noqa: E402
from eddi.mdof.signals import EDGE_PERIODS  # noqa: E402
from eddi.mdof.terms import parse_multi_term  # noqa: E402
from eddi.mdof.validate import validate_mdof  # noqa: E402
from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test  # noqa: E402
from station.mdof_data import condition_multichannel  # noqa: E402


def pair(name: str, m1: float, m2: float, f1: float, ratio: float, zeta: float, share: float, where: str = "12",
         drive: int = 1, rate: float = 2048.0, record_s: float = 3.0, impacts=(50.0, 120.0, 250.0)) -> MdofSystem:
    """Chain ground-m1-m2 with modes at ``f1`` and ``ratio f1``; cubic spring ``where`` ("12" between
    the masses, "01" to ground) of ``share`` of that element's linear force at the largest blow."""
    w1, w2 = 2 * np.pi * f1, 2 * np.pi * f1 * ratio

    def freqs(k1: float, k2: float) -> np.ndarray:
        k = np.array([[k1 + k2, -k2], [-k2, k2]])
        mi = np.diag(1 / np.sqrt([m1, m2]))
        return np.sqrt(np.linalg.eigvalsh(mi @ k @ mi))

    # product of the squared frequencies = k1 k2 / (m1 m2); sum = (k1 + k2) / m1 + k2 / m2
    prod = w1**2 * w2**2 * m1 * m2

    def sum_err(k2: float) -> float:
        k1 = prod / k2
        return (k1 + k2) / m1 + k2 / m2 - (w1**2 + w2**2)

    grid = np.geomspace(prod / (w2**2 * m1) * 1e-4, prod / (w1**2 * m1) * 1e4, 4000)
    vals = np.array([sum_err(g) for g in grid])
    roots = [brentq(sum_err, grid[i], grid[i + 1]) for i in range(len(grid) - 1) if vals[i] * vals[i + 1] < 0]
    k2 = min(roots, key=lambda r: abs(np.log(r / (prod / r))))  # the springs closest to each other
    k1 = prod / k2
    assert np.allclose(freqs(k1, k2), [w1, w2], rtol=1e-6)
    beta = 2 * zeta / w1  # stiffness-proportional dashpots: zeta at f1 (more on mode 2)
    base = [Element(between=(0, 1), k=k1, c=beta * k1), Element(between=(1, 2), k=k2, c=beta * k2)]
    lin = MdofSystem(name=name, masses_kg=(m1, m2), elements=tuple(base), driving_point=drive, rate_hz=rate,
                     record_s=record_s, impacts_n=tuple(impacts))
    x = mdof_impact_test(lin, max(impacts), snr_db=None).truth_x
    idx = 1 if where == "12" else 0
    z = x[0] - x[1] if where == "12" else x[0]
    k3 = float(f"{share * abs(base[idx].k) / float(np.max(np.abs(z))) ** 2:.3g}")
    els = list(base)
    els[idx] = els[idx].model_copy(update={"k3": k3 if share > 0 else 0.0})
    return lin.model_copy(update={"elements": tuple(els),
                                  "description": f"{m1}/{m2} kg, {f1:g} Hz x {ratio:g}, zeta {zeta:g}, "
                                                 f"cubic {where} {100 * share:g} % (k3 {k3:.3g}), {rate:g} Hz"})


#: Tune set (used while changing the code).
TUNE = {
    "t-1to2-light": lambda: pair("t-1to2-light", 1.0, 0.25, 18.0, 2.03, 0.003, 0.05),
    "t-1to3-light": lambda: pair("t-1to3-light", 0.6, 0.15, 22.0, 3.04, 0.005, 0.08, where="01"),
    "t-1to2-far": lambda: pair("t-1to2-far", 2.0, 0.4, 12.0, 1.97, 0.004, 0.04, drive=2),
    "t-end-0.2pct": lambda: pair("t-end-0.2pct", 0.8, 0.3, 25.0, 2.4, 0.002, 0.10, record_s=2.0),
}
#: Held out (written with the tune set, run once at the end of the session).
HELDOUT = {
    "h-1to2-heavy": lambda: pair("h-1to2-heavy", 20.0, 6.0, 9.0, 2.02, 0.006, 0.06, rate=1024.0,
                                 impacts=(300.0, 800.0, 1600.0)),
    "h-1to3-tiny": lambda: pair("h-1to3-tiny", 0.08, 0.05, 40.0, 2.97, 0.008, 0.05, rate=4096.0, drive=2,
                                impacts=(5.0, 12.0, 25.0)),
    "h-1to2-mid-ground": lambda: pair("h-1to2-mid-ground", 3.0, 1.0, 15.0, 1.99, 0.002, 0.06, where="01",
                                      record_s=2.5, impacts=(80.0, 200.0, 400.0)),
    "h-end-1pct": lambda: pair("h-end-1pct", 0.9, 0.3, 30.0, 2.5, 0.01, 0.15, drive=2, record_s=1.5),
}


#: Session 10 (helper s10m12), identified in modal coordinates (``--coordinates modal``, the form a
#: beam or plate must use): near 1:2, 1:3 and 1:2.3, 30 dB, and an uncoupled pair (a null: no
#: coupling term may be kept). Tune set, used while changing the code (with the SNR of each case).
MODAL_TUNE = {
    "t-1to2-light": (TUNE["t-1to2-light"], 45.0),
    "t-1to3-light": (TUNE["t-1to3-light"], 45.0),
    "m-1to2.3": (lambda: pair("m-1to2.3", 1.5, 0.4, 20.0, 2.3, 0.005, 0.06), 45.0),
    "m-1to2-30db": (lambda: pair("m-1to2-30db", 2.0, 0.7, 14.0, 1.98, 0.004, 0.08, drive=2), 30.0),
    "m-null-1to2": (lambda: pair("m-null-1to2", 1.0, 0.3, 16.0, 2.01, 0.004, 0.0), 45.0),
}
#: Held out (written before any code change of session 10, run once at its end).
MODAL_HELDOUT = {
    "h-1to2-20db": (lambda: pair("h-1to2-20db", 5.0, 1.2, 11.0, 2.02, 0.006, 0.10), 20.0),
    "h-1to3-heavy": (lambda: pair("h-1to3-heavy", 8.0, 3.0, 9.0, 2.96, 0.003, 0.06, rate=1024.0,
                                  impacts=(150.0, 400.0, 800.0)), 45.0),
    "h-1to2-tiny": (lambda: pair("h-1to2-tiny", 0.1, 0.04, 35.0, 1.99, 0.004, 0.05, rate=4096.0,
                                 impacts=(5.0, 12.0, 25.0), drive=2), 45.0),
    "h-null-1to3": (lambda: pair("h-null-1to3", 0.7, 0.25, 25.0, 3.02, 0.003, 0.0), 45.0),
    "h-1to2.6-ground": (lambda: pair("h-1to2.6-ground", 1.2, 0.5, 17.0, 2.6, 0.008, 0.07, where="01"), 45.0),
}


def modal_lines(system: MdofSystem, model, records) -> list[str]:
    """A modal model against the truth: shapes and modal masses, the coupling monomials kept, and
    the cubic spring equivalent to its cubic forces (:func:`equivalent_k3`)."""
    m, _c, k = system.model().linear_matrices()
    w2, phi = np.linalg.eig(np.linalg.solve(m, k))
    phi = phi.real[:, np.argsort(w2.real)]
    d = system.driving_point - 1
    phi = phi / np.max(np.abs(phi), axis=0) * np.sign(phi[d])
    masses = np.diag(phi.T @ m @ phi)
    shape_err = np.max(np.abs(model.phi - phi), axis=0)
    out = [f"shapes off by {', '.join(f'{100 * e:.2f} %' for e in shape_err)} (largest entry 1); modal masses "
           f"{', '.join(f'{100 * (a / b - 1):+.2f} %' for a, b in zip(model.mass, masses))}"]
    cpl = [f"eq {i + 1} {t}" for i, st in enumerate(model.stiffness) for t in st
           if (e := parse_multi_term(t, model.n_coords).exponents[0]).sum() != e[i]]
    out.append(f"coupling monomials kept: {len(cpl)} ({', '.join(cpl) or 'none'})")
    for el in system.elements:
        if el.k3:
            k3, rest = equivalent_k3(model, records, el.between)
            out.append(f"equivalent cubic spring k3({el.between[0]}-{el.between[1]}) {k3:.4g} vs {el.k3:.4g} "
                       f"({100 * (k3 / el.k3 - 1):+.2f} %; the part of the cubic force it leaves {100 * rest:.1f} %)")
    return out


def equivalent_k3(model, records, between: tuple[int, int]) -> tuple[float, float]:
    """The cubic spring between nodes ``between`` (0 = ground) that best explains (least squares)
    the model's cubic forces mapped to physical coordinates (``f = Psi^-T g(Psi^-1 y)`` over the
    records' free windows), and the relative part of them it leaves."""
    inv = np.linalg.inv(model.phi)
    y = np.hstack([r.x[:, r.window[0]:r.window[1]] for r in records])[:, ::5]
    q = inv @ y
    g = np.zeros_like(q)
    for i in range(model.n_coords):
        for t, c in model.stiffness[i].items():
            term = parse_multi_term(t, model.n_coords)
            if term.degree == 3:
                g[i] += c * term(q, np.zeros_like(q))
    f = inv.T @ g
    a, b = between
    dz = (y[a - 1] if a else 0.0) - (y[b - 1] if b else 0.0)
    basis = np.zeros_like(f)
    for node, sign in ((a, 1.0), (b, -1.0)):
        if node:
            basis[node - 1] = sign * dz**3
    k3 = float(np.sum(basis * f) / np.sum(basis * basis))
    return k3, float(np.linalg.norm(f - k3 * basis) / max(float(np.linalg.norm(f)), 1e-300))


def run_case(name: str, system: MdofSystem, polish: bool, snr_db: float = 45.0, coordinates: str = "auto") -> None:
    """Identify ``system`` from three blows, score on a fourth (module docstring)."""
    truth = system.model()
    peaks = list(system.impacts_n) + [0.7 * max(system.impacts_n)]
    recs = [condition_multichannel(_measurement(mdof_impact_test(system, p, seed=500 + k, snr_db=snr_db)))
            for k, p in enumerate(peaks)]
    c0 = time.process_time()
    ident = identify_mdof(recs[:3], truth.channels, truth.driving_point, coordinates=coordinates)
    c_ident = time.process_time() - c0
    models = {"EDDI": ident.model}
    if polish:
        from eddi.mdof.refine import refine_identified

        c1 = time.process_time()
        models["polished"] = refine_identified(ident, recs[:3])[0]
        c_pol = time.process_time() - c1
    edge = [r.t.size - int(EDGE_PERIODS * system.rate_hz / r.highpass_hz) for r in recs]
    end = [r.window[1] >= e - 2 for r, e in zip(recs, edge)]
    print(f"{name}: {system.description}; free windows that reach the drift filter's end transient "
          f"(stopped {EDGE_PERIODS:g} cut-off periods before the end): {sum(end)}/{len(end)}")
    print(f"  model: {ident.notes[-1]}")
    print(f"  EDDI {c_ident:.1f} s CPU" + (f", polish {c_pol:.1f} s CPU" if polish else "")
          + f"; load average {os.getloadavg()[0]:.1f}")
    true_v = validate_mdof(truth, recs[3])
    f_true = truth.natural_frequencies_hz()
    for label, m in models.items():
        v = validate_mdof(m, recs[3])
        chans = ", ".join(f"{c} {v.channel_nrmse[c]:.4f} (true {true_v.channel_nrmse[c]:.4f})" for c in truth.channels)
        worst = max(v.channel_nrmse.values())
        f_id = m.natural_frequencies_hz()
        ferr = [abs(a - b) / b for a, b in zip(f_id, f_true) if b > 0]
        print(f"  {label:>8} held out: {chans} -> {'met' if worst <= 0.05 else 'NOT met'}; frequencies "
              f"{', '.join(f'{100 * e:.3f} %' for e in ferr)}; masses {[round(x, 4) for x in m.mass]} "
              f"(true {list(truth.mass)})")
        for line in coupling_errors(truth, m, recs[:3]):
            print(f"  {label:>8}{line}")
        if m.coordinates == "modal":
            for line in modal_lines(system, m, recs[:3]):
                print(f"  {label:>8}    {line}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--set", choices=("tune", "heldout", "modal-tune", "modal-heldout"), default="tune",
                    help="modal-*: session 10's pairs (each at its own SNR; use with --coordinates modal)")
    ap.add_argument("--coordinates", choices=("auto", "modal"), default="auto")
    ap.add_argument("--cases", default="", help="comma-separated case names of the set (default all)")
    ap.add_argument("--no-polish", action="store_true", help="EDDI alone (no output-error polish)")
    ap.add_argument("--snr-db", type=float, default=45.0)
    args = ap.parse_args()
    sets = {"tune": TUNE, "heldout": HELDOUT, "modal-tune": MODAL_TUNE, "modal-heldout": MODAL_HELDOUT}
    cases = sets[args.set]
    names = [c.strip() for c in args.cases.split(",") if c.strip()] or list(cases)
    for name in names:
        if name not in cases:
            ap.error(f"unknown case {name!r}; known: {', '.join(cases)}")
    for name in names:
        make, snr = cases[name] if isinstance(cases[name], tuple) else (cases[name], args.snr_db)
        run_case(name, make(), not args.no_polish, snr, args.coordinates)


if __name__ == "__main__":
    main()
