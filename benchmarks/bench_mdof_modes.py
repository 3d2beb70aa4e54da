"""Couplings that live in the weak modes: is ``modal_coupling`` named by the per-mode rule, and do
nulls stay silent? (session 17, helper s17modes, issue 14 item 4)

The profile (blind unseen11 M2, described by the lead only): three velocity channels, no mass given,
a hidden coupling whose motion is in modes 2-3 while mode 1 dominates every channel; the channels'
mean gain 29 % (< 50 % margin), modal gains 0.060 -> 0.036 and 0.109 -> 0.038. Here: chains
ground - m1 - m2 (- m3) whose last mass is light on a stiff spring, so in mode 1 it rides with its
neighbour and the spring between them stretches in the upper modes only; the blows are at m1 or m2.
Kinds (each seed draws one chain; its kinds share it):

- ``up2`` / ``up3``: a cubic spring between the last two masses (3-10 % of that spring's linear force
  at the largest blow): must be named (``modal_coupling``);
- ``lin2`` / ``lin3``: the same chain, linear: ``modal_coupling`` is a false claim;
- ``gnd2`` / ``gnd3``: the same chain with the cubic on the ground spring of m1 instead (the mode-1
  nonlinearity, 3-10 %): nonlinear but not a coupling between masses: ``modal_coupling`` is a false claim.

Masses 0.1-30 kg, lowest mode 5-40 Hz, stiffness-proportional damping 0.2-1 % on mode 1, 35-55 dB per
channel, velocity channels (m/s or mm/s by capture: the rig's true velocity plus white noise) or the
rig's accelerometers (by seed), rates 2048-25600 Hz, three captures of 1.5-3 s at 60-100 % of the
largest blow. ``--set tuning`` and ``--set heldout`` draw from different generators (``SET_TAG``).
Each case is diagnosed in-process as ``station diagnose FILES --margin 0.5 --driving-point <ch>``
(``--no-refine`` unless ``--refine``); the row keeps the per-mode evidence (JSON ``modes``).

    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_modes.py --set tuning --seeds 1-4 --kinds up2,lin2,gnd2
    PYTHONPATH=. python benchmarks/bench_mdof_modes.py --set heldout --seeds 1-3 --list
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_mdof_nulls import _log, _modes, _seeds  # noqa: E402

from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test  # noqa: E402

KINDS = ("up2", "lin2", "gnd2", "up3", "lin3", "gnd3")
SET_TAG = {"tuning": 1701, "heldout": 1702}


def _chain(g: np.random.Generator, n: int) -> tuple[list[float], list[float], np.ndarray]:
    """Masses and springs (spring i joins node i to i + 1, node 0 the ground) whose last mass is light
    on a stiff spring, and the modes [Hz] before scaling."""
    while True:
        masses = [_log(g, 0.1, 30)]
        if n == 3:
            masses.append(masses[0] * _log(g, 0.4, 1.5))
        masses.append(masses[-1] * _log(g, 0.1, 0.4))
        ks = [_log(g, 0.5, 2)] + [_log(g, 0.5, 3) for _ in range(n - 1)]
        f = _modes(masses, ks)
        if 1.6 <= f[1] / f[0] and f[-1] / f[0] <= 9 and (n == 2 or f[2] / f[1] >= 1.3):
            return masses, ks, f


def draw(kind: str, seed: int, which: str) -> tuple[MdofSystem, float, str, dict]:
    """The system, its SNR [dB], the channel quantity (``vel`` / ``acc``) and a row of facts."""
    n = int(kind[-1])
    g = np.random.default_rng([SET_TAG[which], n, seed])  # one chain per seed and size
    masses, ks, f = _chain(g, n)
    f1 = _log(g, 5.0, 40.0)
    ks = [k * (f1 / f[0]) ** 2 for k in ks]
    freqs = f * f1 / f[0]
    zeta = _log(g, 0.002, 0.01)
    beta = 2 * zeta / (2 * np.pi * f1)
    rate = float(g.choice([2048.0, 5000.0, 10000.0, 25600.0]))
    rate = max(rate, float(2 ** np.ceil(np.log2(10 * freqs[-1]))))
    record_s = float(g.uniform(1.5, 3.0))
    snr = float(g.uniform(35, 55))
    quantity = "vel" if g.uniform() < 0.6 else "acc"
    drive = int(g.choice([1, 2]))
    peak = max(2.0, masses[drive - 1] * (2 * np.pi * f1) ** 2 * 1e-3 * _log(g, 0.5, 2))
    levels = [float(g.uniform(0.6, 0.8)), float(g.uniform(0.8, 0.95)), 1.0]
    blows = tuple(float(f"{peak * levels[k]:.3g}") for k in g.permutation(3))
    share = _log(g, 0.03, 0.10)
    els = [Element(between=(i, i + 1), k=ks[i], c=beta * ks[i]) for i in range(n)]
    system = MdofSystem(name=f"{which[0]}{seed}-{kind}", masses_kg=tuple(masses), elements=tuple(els),
                        driving_point=drive, rate_hz=rate, pretrigger_s=0.05, record_s=record_s, impacts_n=blows,
                        tip="rubber" if freqs[-1] < 150 else "plastic")
    k3 = 0.0
    if not kind.startswith("lin"):
        x = mdof_impact_test(system, max(blows), snr_db=None).truth_x
        el = n - 1 if kind.startswith("up") else 0  # spring n-1 joins the last two masses; spring 0 grounds m1
        d = x[n - 2] - x[n - 1] if kind.startswith("up") else x[0]
        k3 = float(f"{share * ks[el] / float(np.max(np.abs(d))) ** 2:.4g}")
        els[el] = els[el].model_copy(update={"k3": k3})
        system = system.model_copy(update={"elements": tuple(els)})
    facts = {"name": system.name, "kind": kind, "masses_kg": [round(m, 4) for m in masses],
             "modes_hz": [round(float(x), 2) for x in freqs], "zeta1": round(zeta, 4), "rate_hz": rate,
             "record_s": round(record_s, 2), "blows_n": list(blows), "drive": drive, "snr_db": round(snr, 1),
             "quantity": quantity, "share": round(share, 4) if k3 else 0.0, "k3": k3}
    return system, snr, quantity, facts


def write(system: MdofSystem, peak: float, snr: float, quantity: str, seed: int, path: Path, mm: bool) -> Path:
    """One capture as ``t,force,<q>1..n``: velocity (m/s, or mm/s with ``mm``) from the rig's truth with
    white noise at ``snr`` per channel, or the rig's own acceleration capture (as s16mverdict's bench)."""
    rec = mdof_impact_test(system, peak, snr_db=snr, seed=seed)
    if quantity == "acc":
        return rec.write_csv(path)
    g = np.random.default_rng(seed)
    v = np.array(rec.truth_v, float)
    v = v if v.shape[0] == rec.t.size else v.T
    noise = g.standard_normal(v.shape) * np.sqrt(np.mean(v**2, axis=0)) * 10 ** (-snr / 20)
    scale, unit = (1e3, "mm/s") if mm else (1.0, "m/s")
    data = np.column_stack([rec.t, rec.force_n, scale * (v + noise)])
    head = "t [s],force [N]," + ",".join(f"vel{k + 1} [{unit}]" for k in range(v.shape[1]))
    np.savetxt(path, data, delimiter=",", header=head, comments="", fmt="%.10g")
    return path


def run(job: tuple[str, int, str, bool]) -> dict:
    kind, seed, which, refine = job
    from station.mdof_commands import diagnose_mdof_object

    system, snr, quantity, row = draw(kind, seed, which)
    with tempfile.TemporaryDirectory() as tmp:
        files = [str(write(system, peak, snr, quantity, 1000 * seed + k, Path(tmp) / f"{system.name}-{k}.csv",
                           mm=bool(k % 2))) for k, peak in enumerate(system.impacts_n)]
        c0 = time.process_time()
        try:
            obj = diagnose_mdof_object(files, driving_point=f"{quantity}{system.driving_point}", margin=0.5,
                                       refine=refine)
        except Exception as exc:  # noqa: BLE001 - reported per case
            row.update(cause=f"(error) {type(exc).__name__}: {str(exc)[:160]}", cpu_s=round(time.process_time() - c0, 1))
            return row
        row["cpu_s"] = round(time.process_time() - c0, 1)
    z = [[abs(v) / h for t, (v, h) in eq.items() if ("^" in t or "*" in t) and h] for eq in obj["coupling_coefficients"]]
    row.update(cause=obj["cause"], uncertain=obj.get("uncertain"), gain=round(obj["gain"], 3),
               raw_gain=round(obj["raw_gain"], 3), coordinates=obj["coordinates"], allowance=obj.get("allowance"),
               modes=obj.get("modes"), baseline={c: round(v, 4) for c, v in obj["baseline"]["channel_nrmse"].items()},
               coupled={c: round(v, 4) for c, v in obj["coupled"]["channel_nrmse"].items()},
               folds_b=[round(f, 4) for f in obj["baseline"]["folds"]],
               folds_c=[round(f, 4) for f in obj["coupled"]["folds"]],
               floor={c: round(v, 4) for c, v in obj["noise_floor"].items()},
               coupling_z=round(max((x for e in z for x in e), default=0.0), 2),
               fold_terms=[n for n in obj["notes"] if "nonlinear term between coordinates on" in n],
               notes=[n[:240] for n in obj["notes"]])
    return row


def outcome(row: dict) -> str:
    cause = row.get("cause", "")
    if cause == "modal_coupling":
        return "named" if row["kind"].startswith("up") else "FALSE"
    return cause if cause in ("unexplained", "none") else "error"


def show(r: dict) -> None:
    m = r.get("modes") or {}
    per = "; ".join(f"q{i + 1} {b:.3g}->{c:.3g} fl {f:.3g} ex {e:.2f} {n}/{m.get('folds')}" for i, (b, c, f, e, n)
                    in enumerate(zip(m.get("baseline", []), m.get("coupled", []), m.get("floor", []),
                                     m.get("excess_gain", []), m.get("better_folds", []))))
    print(f"{r['name']}: {r['quantity']} {r['snr_db']} dB m {r['masses_kg']} modes {r['modes_hz']} "
          f"{r['rate_hz']:g} Hz drive {r['drive']} share {r['share']} -> {r.get('cause')} ({outcome(r)}) "
          f"raw {r.get('raw_gain')} folds b {r.get('folds_b')} c {r.get('folds_c')} floor {r.get('floor')} | "
          f"modes [{per}] earned {m.get('earned')} decided {m.get('decided')} z {r.get('coupling_z')} "
          f"CPU {r.get('cpu_s')} s", flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--set", choices=sorted(SET_TAG), default="tuning")
    ap.add_argument("--seeds", default="1-4", help="e.g. 1-6 or 2,5")
    ap.add_argument("--kinds", default=",".join(KINDS), help=f"comma-separated subset of {','.join(KINDS)}")
    ap.add_argument("--refine", action="store_true", help="polish (the CLI's default; slower)")
    ap.add_argument("--jobs", type=int, default=1, help="cases at once (at most 2 on the shared machine)")
    ap.add_argument("--list", action="store_true", help="print the cases only")
    ap.add_argument("--json", help="write the rows to this JSON file")
    args = ap.parse_args(argv)
    kinds = [k for k in args.kinds.split(",") if k]
    if any(k not in KINDS for k in kinds):
        print(f"bench_mdof_modes: unknown kind in {args.kinds!r} (known: {', '.join(KINDS)})", file=sys.stderr)
        return 2
    if args.list:
        for s in _seeds(args.seeds):
            for k in kinds:
                _sys, _snr, _q, facts = draw(k, s, args.set)
                print(json.dumps(facts))
        return 0
    jobs = [(k, s, args.set, args.refine) for s in _seeds(args.seeds) for k in kinds]
    if args.jobs > 1:
        from multiprocessing import get_context

        with get_context("fork").Pool(min(args.jobs, 2)) as pool:
            rows = []
            for r in pool.imap(run, jobs, chunksize=1):
                show(r)
                rows.append(r)
    else:
        rows = []
        for j in jobs:
            rows.append(run(j))
            show(rows[-1])
    counts: dict[str, dict[str, int]] = {}
    for r in rows:
        counts.setdefault(r["kind"], {}).setdefault(outcome(r), 0)
        counts[r["kind"]][outcome(r)] += 1
    for k, c in counts.items():
        print(f"{k}: " + ", ".join(f"{o} {n}" for o, n in sorted(c.items())))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
