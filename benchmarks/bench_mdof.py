"""Multi-DOF identification on the simulated rig's MDOF systems, EDDI beside pysindy.

For each system (``simulated_rig/mdof/*.toml``): three impacts at the system's levels train,
a fourth (70 % of the largest, another noise seed) is held out; accelerometers only, 45 dB
SNR on every channel, no mass given. Both methods get the same conditioned multi-channel
states (:func:`station.mdof_data.condition_multichannel`):

* **EDDI** (:func:`eddi.mdof.identify.identify_mdof`): candidates (modal / physical
  coordinates with the per-coordinate library, physical with drift-filtered equations, lumped
  springs and dashpots :mod:`eddi.mdof.lumped`), the one that reproduces the training records
  best kept (printed as ``model:``); masses from the driving-point force;
  ``--refine`` adds the output-error polish (:func:`eddi.mdof.refine.refine_mdof`).
* **pysindy**: STLSQ (``pysindy.STLSQ``, threshold ``--sindy-threshold``) regressing each
  physical channel's measured acceleration on the same library (linear rates, every monomial
  of the displacements up to degree 3) plus the force as an input column, over the same
  windows. It identifies per unit mass.

Printed per system: held-out nrmse of every channel (floor 0.05) for EDDI, pysindy and the
TRUE model on the same conditioned record (what the measurement allows); natural frequencies
against the truth (floor 3 %); the coupling coefficients (cubic monomials) against the truth
written in the identified coordinates (per unit mass; floor 3 % on the terms carrying at least
10 % of the largest cubic force).

    PYTHONPATH=. python benchmarks/bench_mdof.py [--systems two-mass-cubic,internal-1-3,nes] [--refine]
    PYTHONPATH=. python benchmarks/bench_mdof.py --coupling-sweep 4    # coupling bias vs printed ci95, EDDI and polished
    PYTHONPATH=. python benchmarks/bench_mdof.py --coupling-anatomy 6  # where a weak coupling's EDDI error comes from
"""

from __future__ import annotations

import argparse
import itertools
import os
import time

import numpy as np

from eddi.mdof.identify import ChannelRecord, identify_mdof
from eddi.mdof.model import MdofModel
from eddi.mdof.terms import monomial, parse_multi_term
from eddi.mdof.validate import validate_mdof
from simulated_rig.mdof_systems import load_mdof_system, mdof_impact_test
from station.mdof_data import condition_multichannel
from station.readers import Measurement


def _measurement(rec) -> Measurement:
    return Measurement(t=rec.t, channels=rec.columns(), rate_hz=rec.rate_hz, pretrigger_samples=rec.pretrigger_samples,
                       mass=None, source=f"rig {rec.peak_force_n:g} N", metadata={})


def _library(n: int) -> tuple[list[str], list[str]]:
    damping = [monomial({j: 1}, n, rate=True) for j in range(n)]
    stiff = []
    for deg in (1, 2, 3):
        for combo in itertools.combinations_with_replacement(range(n), deg):
            powers: dict[int, int] = {}
            for j in combo:
                powers[j] = powers.get(j, 0) + 1
            stiff.append(monomial(powers, n))
    return damping, stiff


def sindy_model(records: list[ChannelRecord], channels: tuple[str, ...], driving_point: str,
                threshold: float) -> MdofModel:
    """pysindy STLSQ on physical channels, force as an input column; per unit mass."""
    import pysindy as ps

    n = len(channels)
    damping, stiff = _library(n)
    terms = [parse_multi_term(t, n) for t in damping + stiff]
    rows, targets = [], []
    for r in records:
        s, e = r.impact[0], r.window[1]
        x, v, a = r.x[:, s:e], r.v[:, s:e], r.a[:, s:e]
        f = r.force[s:e] if r.force is not None else np.zeros(e - s)
        rows.append(np.column_stack([t(x, v) for t in terms] + [f]))
        targets.append(a.T)
    theta = np.vstack(rows)
    norms = np.linalg.norm(theta, axis=0)
    norms[norms == 0] = 1.0
    opt = ps.STLSQ(threshold=threshold, alpha=0.0)
    opt.fit(theta / norms, np.vstack(targets))
    coef = opt.coef_ / norms[None, :]  # (n, n_terms + 1): a_i = sum c f
    d_i = channels.index(driving_point)
    dmp, stf, inp = [], [], []
    for i in range(n):
        c = coef[i]
        dmp.append({t: float(-c[k]) for k, t in enumerate(damping) if c[k] != 0})
        stf.append({t: float(-c[len(damping) + k]) for k, t in enumerate(stiff) if c[len(damping) + k] != 0})
        inp.append(float(c[-1]))
    del d_i
    return MdofModel.create(coordinates="physical", mass=(1.0,) * n, input=tuple(inp), damping=tuple(dmp),
                            stiffness=tuple(stf), channels=channels,
                            shapes=tuple(tuple(float(i == j) for j in range(n)) for i in range(n)),
                            driving_point=driving_point, notes="pysindy STLSQ, per unit mass")


def truth_in_coordinates(truth: MdofModel, ident: MdofModel, amp: np.ndarray, rng: np.random.Generator
                         ) -> dict[str, np.ndarray]:
    """The true per-unit-mass forces written in the identified coordinates (least squares on samples).

    Returns ``term -> (n_coords,)`` coefficients of every monomial up to degree 3.
    """
    tmat = ident.phi
    n = tmat.shape[1]
    m_q = tmat.T @ np.diag(truth.mass) @ tmat
    q = rng.uniform(-1, 1, (n, 4000)) * amp[:, None]
    f = np.linalg.solve(m_q, tmat.T @ truth.internal_force(tmat @ q, np.zeros_like(tmat @ q)))
    _d, stiff = _library(n)
    basis = np.column_stack([parse_multi_term(t, n)(q, q) for t in stiff])
    coef, *_ = np.linalg.lstsq(basis, f.T, rcond=None)
    return {t: coef[k] for k, t in enumerate(stiff)}


def coupling_errors(truth: MdofModel, ident: MdofModel, records: list[ChannelRecord]) -> list[str]:
    """Lines comparing the cubic coefficients (per unit mass) with the truth in the same coordinates."""
    proj = np.linalg.pinv(ident.phi)
    amp = np.max(np.hstack([np.abs(proj @ r.x[:, r.window[0]:r.window[1]]) for r in records]), axis=1)
    ref = truth_in_coordinates(truth, ident, amp, np.random.default_rng(0))
    lines, worst = [], 0.0
    cubic_terms = [t for t in ref if parse_multi_term(t, ident.n_coords).degree == 3]
    sizes = [{t: abs(ref[t][i]) * float(np.prod(amp ** parse_multi_term(t, ident.n_coords).exponents[0]))
              for t in cubic_terms} for i in range(ident.n_coords)]
    linear_terms = [t for t in ref if parse_multi_term(t, ident.n_coords).degree == 1]
    for i in range(ident.n_coords):
        cubic = {t: ref[t][i] for t in cubic_terms}
        size = sizes[i]
        # terms carrying at least 10 % of the equation's largest cubic force, in equations whose
        # cubic force is at least 1 % of their linear one (a linear coordinate is not scored on
        # the round-off of the truth's change of coordinates)
        lin = sum(abs(ref[t][i]) * float(np.prod(amp ** parse_multi_term(t, ident.n_coords).exponents[0]))
                  for t in linear_terms)
        big = max(size.values()) if size else 0.0
        if big < 0.01 * lin:
            continue
        for t, c in cubic.items():
            if size[t] < 0.1 * big:
                continue
            got = ident.stiffness[i].get(t, 0.0) / ident.mass[i]
            err = abs(got - c) / abs(c)
            worst = max(worst, err)
            ci = ident.stiffness_ci95[i].get(t) if ident.stiffness_ci95 else None
            if t not in ident.stiffness[i]:
                band = " (pruned: force below 0.3 % of the equation's)"
            elif ci is None:
                band = ""
            else:
                h = ci / ident.mass[i]
                band = f" +- {h:.3g} ({100 * h / abs(got):.1f} %, {'covers' if abs(got - c) <= h else 'MISSES'} the truth)"
            lines.append(f"    eq {i + 1} {t:>10}: {got:.5g}{band} vs true {c:.5g} per unit mass ({100 * err:.2f} %)")
    lines.append(f"    worst coupling/cubic coefficient error {100 * worst:.2f} % (floor 3 % -> "
                 f"{'met' if worst <= 0.03 else 'NOT met'})")
    return lines


def run(name: str, refine: bool, threshold: float, snr_db: float = 45.0) -> None:
    system = load_mdof_system(name)
    truth = system.model()
    peaks = list(system.impacts_n) + [0.7 * max(system.impacts_n)]
    recs = [condition_multichannel(_measurement(mdof_impact_test(system, p, seed=100 + k, snr_db=snr_db)))
            for k, p in enumerate(peaks)]
    t0, c0 = time.perf_counter(), time.process_time()
    ident = identify_mdof(recs[:3], truth.channels, truth.driving_point)
    model = ident.model
    t_ident = time.perf_counter() - t0
    c_ident = time.process_time()
    pre = validate_mdof(model, recs[3])
    if refine:
        from eddi.mdof.refine import refine_identified

        model, _b, _a = refine_identified(ident, recs[:3])
    t_eddi = time.perf_counter() - t0
    c_eddi = time.process_time() - c0
    t0 = time.perf_counter()
    sindy = sindy_model(recs[:3], truth.channels, truth.driving_point, threshold)
    t_sindy = time.perf_counter() - t0
    held = {"EDDI": validate_mdof(model, recs[3]), "pysindy": validate_mdof(sindy, recs[3]),
            "true model": validate_mdof(truth, recs[3])}
    print(f"{name} ({snr_db:g} dB): EDDI in {ident.coordinates} coordinates ({t_eddi:.1f} s), pysindy ({t_sindy:.1f} s); "
          f"tail modes {', '.join(f'{f:.4g}' for f in ident.modes.frequencies_hz)} Hz")
    print(f"  model: {ident.notes[-1]}")
    print(f"  EDDI {t_ident:.1f} s wall, {c_ident - c0:.1f} s CPU (this process); with the polish "
          f"{t_eddi:.1f} s wall, {c_eddi:.1f} s CPU; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    if ident.notes and ident.notes[0].startswith("lumped elements"):
        print(f"  lumped: {ident.notes[0]}")
    if refine:
        print("  held-out nrmse before the polish: "
              + ", ".join(f"{c} {pre.channel_nrmse[c]:.4f}" for c in truth.channels))
    for c in truth.channels:
        e = held["EDDI"].channel_nrmse[c]
        print(f"  held-out nrmse {c}: EDDI {e:.4f} ({'met' if e <= 0.05 else 'NOT met'} vs floor 0.05), "
              f"pysindy {held['pysindy'].channel_nrmse[c]:.4f}, true model {held['true model'].channel_nrmse[c]:.4f}")
    f_true = truth.natural_frequencies_hz()
    for label, m in (("EDDI", model), ("pysindy", sindy)):
        f_id = m.natural_frequencies_hz()
        parts = []
        for k, ft in enumerate(f_true):
            if ft > 0 and k < len(f_id):
                err = abs(f_id[k] - ft) / ft
                parts.append(f"f{k + 1} {f_id[k]:.4f} Hz ({100 * err:.3f} %{'' if err <= 0.03 else ', NOT met'})")
        print(f"  {label} frequencies vs true {', '.join(f'{f:.4f}' for f in f_true if f > 0)} Hz: {'; '.join(parts)}")
    if ident.coordinates == "physical":
        print(f"  EDDI masses {[round(m, 4) for m in model.mass]} kg vs true {list(truth.mass)} (none given)")
    if refine:
        print("  EDDI alone (before the polish) cubic coefficients:")
        for line in coupling_errors(truth, ident.model, recs[:3]):
            print(line)
    print(f"  EDDI{' polished' if refine else ''} cubic coefficients:")
    for line in coupling_errors(truth, model, recs[:3]):
        print(line)


def coupling_sweep(seeds: int, polish: bool = True, masses: tuple[float, ...] = (0.5, 0.2)) -> None:
    """Cubic coupling spring between two masses: estimate error against its printed 95 % interval.

    Chains ground-m1-m2 of our own (m1 = 1 kg, m2 = 0.5 or 0.2 kg; linear springs 3e4 / 2e4 N/m,
    dashpots 4 / 1.5 N s/m) with a cubic spring between the masses whose force at the largest
    blow is 3 %, 10 % or 30 % of the linear coupling spring's (the 3 % one: a weak coupling, small
    relative deflection). Three impacts (60, 150, 300 N), 45 dB, acc only, no mass given,
    ``identify_mdof`` (EDDI), ``seeds`` noise seeds each; with ``polish`` also the output-error
    polish of the lumped fit (:func:`eddi.mdof.refine.refine_lumped`, what ``station diagnose``
    saves by default; :func:`eddi.mdof.refine.refine_identified`). Printed per case and estimator:
    the mean and RMS error of the cubic spring's constant (the ``x2^3`` coefficient of the second
    mass's equation, whichever candidate was kept; bias = mean error), the worst, the mean
    printed ci95 and how many intervals hold the truth.
    """
    from eddi.mdof.refine import refine_identified
    from simulated_rig.mdof_systems import Element, MdofSystem

    print(f"coupling sweep: {seeds} seeds per case, EDDI (lumped element k3(1-2))"
          + (" and EDDI + output-error polish" if polish else "") + f"; load average {os.getloadavg()[0]:.1f}")
    for m2 in masses:
        base = [Element(between=(0, 1), k=3e4, c=4.0), Element(between=(1, 2), k=2e4, c=1.5)]
        lin = MdofSystem(name="sweep", masses_kg=(1.0, m2), elements=tuple(base), impacts_n=(60.0, 150.0, 300.0))
        x = mdof_impact_test(lin, 300.0, snr_db=None).truth_x
        zmax = float(np.max(np.abs(x[0] - x[1])))
        for share in (0.03, 0.1, 0.3):
            k3 = float(f"{share * 2e4 / zmax**2:.3g}")
            els = (base[0], base[1].model_copy(update={"k3": k3}))
            system = lin.model_copy(update={"elements": els})
            rows: dict[str, list[tuple[float, float]]] = {"EDDI": [], "polished": []}
            cpu = {"EDDI": 0.0, "polished": 0.0}
            kinds: set[str] = set()
            for seed in range(seeds):
                recs = [condition_multichannel(_measurement(mdof_impact_test(system, p, seed=200 + 10 * seed + k)))
                        for k, p in enumerate(system.impacts_n)]
                c0 = time.process_time()
                ident = identify_mdof(recs, system.channels, "acc1")
                cpu["EDDI"] += time.process_time() - c0
                kinds.add(ident.coordinates + (" lumped" if ident.lumped is not None else ""))
                models = {"EDDI": ident.model}
                if polish:
                    c0 = time.process_time()
                    models["polished"] = refine_identified(ident, recs)[0]
                    cpu["polished"] += time.process_time() - c0
                for label, model in models.items():
                    # k3 (x2 - x1)^3 in m2's equation: its x2^3 coefficient is k3 (lumped or not)
                    c = model.stiffness[1].get("x2^3", 0.0)
                    h = (model.stiffness_ci95[1].get("x2^3", np.nan) if model.stiffness_ci95 else np.nan)
                    rows[label].append(((c - k3) / k3, h / k3))
            head = f"  m2 {m2} kg, cubic {100 * share:.0f} % of the coupling force (k3 {k3:.3g} N/m^3)"
            for label, vals in rows.items():
                if not vals:
                    continue
                e, ci = np.array([v[0] for v in vals]), np.array([v[1] for v in vals])
                cover = int(np.sum(np.abs(e) <= ci))
                extra = "" if label == "EDDI" else " on top"
                print(f"{head} {label:>8}: mean error {100 * e.mean():+.2f} %, RMS {100 * np.sqrt(np.mean(e**2)):.2f} %, "
                      f"worst {100 * np.max(np.abs(e)):.2f} % ({'met' if np.max(np.abs(e)) <= 0.03 else 'NOT met'} vs 3 %), "
                      f"mean ci95 {100 * np.mean(ci):.2f} %, {cover}/{len(e)} intervals hold the truth "
                      f"({', '.join(sorted(kinds))}; {cpu[label]:.0f} s CPU{extra})", flush=True)


def coupling_anatomy(seeds: int, m2: float = 0.5, share: float = 0.03) -> None:
    """Where the error of a weak cubic coupling comes from (EDDI alone, the lumped fit's ``k3(1-2)``).

    The chain of :func:`coupling_sweep` (``m2``, cubic ``share``), ``seeds`` noise seeds. Printed:
    (a) noise-free records; (b) the 45 dB noise put back in one conditioned state at a time
    (displacement, velocity, acceleration, force; the others from the noise-free record of the
    same blow), rows from 0.6 filter periods; (c) the rows' start fixed (0 to 1.5 periods of the
    column filter's cut-off, :data:`eddi.mdof.physical.SETTLE_CHOICES` are 0.6, 1.0, 1.5) against
    the start the identification picks by training error; mean and RMS error over the seeds.
    """
    from dataclasses import replace

    from eddi.mdof import physical
    from eddi.mdof.physical import identify_lumped
    from simulated_rig.mdof_systems import Element, MdofSystem

    base = [Element(between=(0, 1), k=3e4, c=4.0), Element(between=(1, 2), k=2e4, c=1.5)]
    lin = MdofSystem(name="anatomy", masses_kg=(1.0, m2), elements=tuple(base), impacts_n=(60.0, 150.0, 300.0))
    x = mdof_impact_test(lin, 300.0, snr_db=None).truth_x
    k3 = float(f"{share * 2e4 / float(np.max(np.abs(x[0] - x[1]))) ** 2:.3g}")
    system = lin.model_copy(update={"elements": (base[0], base[1].model_copy(update={"k3": k3}))})
    starts = (0.0, 0.3, 0.6, 1.0, 1.5)
    errs: dict[str, list[float]] = {}
    c0 = time.process_time()

    def k3_error(recs, settle=None) -> float:
        if settle is None:
            fit = identify_lumped(recs, system.channels, "acc1", slow_band=False).lumped
        else:
            fit = physical._fit(recs, 2, 0, 3e-3, settle)
        return 100 * ({e.label: c for e, c in fit.constants.items()}.get("k3(1-2)", 0.0) - k3) / k3

    for seed in range(seeds):
        noisy, clean = [], []
        for k, p in enumerate(system.impacts_n):
            noisy.append(condition_multichannel(_measurement(mdof_impact_test(system, p, seed=200 + 10 * seed + k))))
            clean.append(condition_multichannel(_measurement(mdof_impact_test(system, p, seed=200 + 10 * seed + k,
                                                                               snr_db=None))))
        clean = [replace(c, window=n.window, impact=n.impact, highpass_hz=n.highpass_hz) for c, n in zip(clean, noisy)]
        variants = {"(a) noise-free": clean, "(b) noise in x only": [replace(c, x=n.x) for c, n in zip(clean, noisy)],
                    "(b) noise in v only": [replace(c, v=n.v) for c, n in zip(clean, noisy)],
                    "(b) noise in a only": [replace(c, a=n.a) for c, n in zip(clean, noisy)],
                    "(b) noise in force only": [replace(c, force=n.force) for c, n in zip(clean, noisy)],
                    "(b) all noise (45 dB)": noisy}
        for label, recs in variants.items():
            errs.setdefault(label, []).append(k3_error(recs, 0.6))
        for st in starts:
            errs.setdefault(f"(c) rows from {st:g} periods, 45 dB", []).append(k3_error(noisy, st))
        errs.setdefault("(c) start picked by training error, 45 dB", []).append(k3_error(noisy))
    print(f"coupling anatomy: m2 {m2} kg, cubic {100 * share:g} % of the coupling force (k3 {k3:.3g} N/m^3), "
          f"{seeds} seeds, lumped fit without the slow band; {time.process_time() - c0:.0f} s CPU, "
          f"load average {os.getloadavg()[0]:.1f}")
    for label, e in errs.items():
        a = np.array(e)
        print(f"  {label:<45} k3 error mean {a.mean():+.2f} %, RMS {np.sqrt(np.mean(a**2)):.2f} % "
              f"({', '.join(f'{v:+.2f}' for v in a)})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--systems", default="two-mass-cubic,internal-1-3,nes")
    ap.add_argument("--refine", action="store_true", help="add the output-error refinement (slow: minutes)")
    ap.add_argument("--snr-db", type=float, default=45.0, help="SNR of every accelerometer [dB] (default 45)")
    ap.add_argument("--sindy-threshold", type=float, default=0.05, help="STLSQ threshold on normalised columns")
    ap.add_argument("--coupling-sweep", type=int, metavar="SEEDS", default=0,
                    help="instead: the coupling-coefficient sweep (bias vs printed ci95) with SEEDS seeds per case")
    ap.add_argument("--no-polish", action="store_true", help="coupling sweep: EDDI alone, no output-error polish")
    ap.add_argument("--sweep-m2", default="0.5,0.2", help="coupling sweep: second masses [kg], comma-separated")
    ap.add_argument("--coupling-anatomy", type=int, metavar="SEEDS", default=0,
                    help="instead: where a weak coupling's k3 error comes from (noise per state, rows' start)")
    args = ap.parse_args()
    if args.coupling_anatomy:
        coupling_anatomy(args.coupling_anatomy)
        return
    if args.coupling_sweep:
        coupling_sweep(args.coupling_sweep, polish=not args.no_polish,
                       masses=tuple(float(m) for m in args.sweep_m2.split(",")))
        return
    for name in args.systems.split(","):
        run(name.strip(), args.refine, args.sindy_threshold, args.snr_db)


if __name__ == "__main__":
    main()
