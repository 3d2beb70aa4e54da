"""Multi-DOF nulls and weak couplings: how often ``station diagnose`` names a coupling that is not there.

Session 13 (helper s13mnull, issue 14). A within-allowance rule for weak couplings
(:mod:`eddi.mdof.allowance`) may be earned only by a false-claim rate measured on nulls. Each seed
draws one case of every kind (all acc only, no mass given, the driving point named):

- ``lin2`` / ``lin3``: a linear chain ground - m1 - m2 (- m3); correct verdict ``none``;
- ``ground``: a two-mass chain whose grounded spring on m1 has a cubic term (2-10 % of its linear
  force at the largest blow): nonlinear but uncoupled between the masses; ``modal_coupling`` is a
  false claim, ``none`` or ``unexplained`` are not;
- ``weak2`` / ``weak3``: a cubic spring between two masses at 1-5 % of the linear spring's force at
  the largest blow (``k3 d^2 / k``); correct verdict ``modal_coupling``;
- ``weakn`` / ``nulln``: the blind M1 profile's kind, noisier (30-38 dB): a two-mass chain built
  from its modes (``bench_mdof_weak.case``: m1 0.3-50 kg, m2 0.15-1.2 m1, first mode 3-40 Hz, ratio
  1.4-3.2, damping 0.3-1.5 %), a cubic coupling spring at 2-5 %, four blows with the largest third
  (a held-out extrapolation in amplitude), 4096-10000 Hz, 3-5 s; ``nulln`` the same chain without it.

Masses 0.05-50 kg (ratios 0.2-5), first mode 4-80 Hz, the highest at most 8x the lowest,
stiffness-proportional damping 0.3-2 % on the first mode, rates 1-20 kHz (at least 8x the
highest mode), 30-50 dB, 3-4 blows of 30-100 % of the largest (~1 mm at the struck mass), records
1-4 s, pre-trigger 20-200 ms, struck at m1 or m2. Sets: ``--set tuning`` and ``--set heldout`` draw
from different generators (the held-out one was not run while the rule's thresholds were chosen);
``--set own20`` (session 20, helper s20mnull) a third generator, run once on the final code only.
Each case is diagnosed in-process as ``station diagnose FILES --margin 0.5 --no-refine
--driving-point accK`` (``--refine`` for the CLI's default polish); the row keeps the evidence of
the within-allowance rule (``allowance``) and the coupling coefficients' value / half-width.

    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_nulls.py --set tuning --seeds 1-12 --jobs 2
    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_nulls.py --set heldout --seeds 1-12 --kinds lin2,weak2
    PYTHONPATH=. python benchmarks/bench_mdof_nulls.py --set tuning --seeds 1-3 --list
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test

KINDS = ("lin2", "lin3", "ground", "weak2", "weak3", "weakn", "nulln")
SET_TAG = {"tuning": 1301, "heldout": 1302, "own20": 2001}


def _log(g, lo, hi):
    return float(np.exp(g.uniform(np.log(lo), np.log(hi))))


def _modes(masses, ks):
    n = len(masses)
    kmat = np.zeros((n, n))
    for i in range(n):  # spring i joins node i (0 ground) to node i + 1
        kmat[i, i] += ks[i]
        if i:
            kmat[i - 1, i - 1] += ks[i]
            kmat[i - 1, i] -= ks[i]
            kmat[i, i - 1] -= ks[i]
    mi = np.diag(1 / np.sqrt(masses))
    return np.sqrt(np.linalg.eigvalsh(mi @ kmat @ mi)) / (2 * np.pi)


def draw_noisy(kind: str, seed: int, which: str) -> tuple[MdofSystem, float, dict]:
    """``weakn`` / ``nulln`` (module notes; the same chain for both at one seed)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_mdof_weak import case

    g = np.random.default_rng([SET_TAG[which], 99, seed])
    while True:  # masses whose springs can give the ratio (bench_mdof_light.pair)
        m1 = _log(g, 0.3, 50)
        m2 = m1 * _log(g, 0.15, 1.2)
        f1, ratio, zeta = _log(g, 3.0, 40.0), float(g.uniform(1.4, 3.2)), _log(g, 0.003, 0.015)
        try:
            case("probe", m1, m2, f1, ratio, zeta, 0.0, 4096.0, 40.0, 0.1, (1.0,))
            break
        except ValueError:
            continue
    share, snr = _log(g, 0.02, 0.05), float(g.uniform(30, 38))
    rate = float(g.choice([4096.0, 5000.0, 10000.0]))
    pre = float(g.choice([0.05, 0.1, 0.2]))
    rec = float(np.clip(2.5 / (zeta * 2 * np.pi * f1), 3.0, 5.0))
    size = m1 * (2 * np.pi * f1) ** 2 * 1e-3 * _log(g, 0.5, 2)
    lv = sorted(g.uniform(0.3, 1.0, 4))
    blows = tuple(float(f"{size * v:.3g}") for v in (lv[0], lv[1], 1.0, lv[2]))
    drive = int(g.choice([1, 2]))
    system, snr = case(f"{which[0]}{seed}-{kind}", m1, m2, f1, ratio, zeta, share if kind == "weakn" else 0.0, rate,
                       snr, pre, blows, record_s=rec, drive=drive)
    k3 = float(system.elements[1].k3)
    facts = {"name": system.name, "kind": kind, "masses_kg": [round(m1, 4), round(m2, 4)],
             "modes_hz": [round(f1, 2), round(f1 * ratio, 2)], "zeta1": round(zeta, 4), "rate_hz": rate,
             "record_s": round(rec, 2), "pre_s": pre, "blows_n": list(blows), "drive": drive, "snr_db": round(snr, 1),
             "share": round(share, 4) if k3 else 0.0, "k3": k3, "pair": [1, 2]}
    return system, snr, facts


def draw(kind: str, seed: int, which: str) -> tuple[MdofSystem, float, dict]:
    """The case of ``kind`` for ``seed`` in set ``which``: the system, its SNR [dB] and a row of facts."""
    if kind in ("weakn", "nulln"):
        return draw_noisy(kind, seed, which)
    g = np.random.default_rng([SET_TAG[which], KINDS.index(kind), seed])
    n = 3 if kind in ("lin3", "weak3") else 2
    while True:
        masses = [_log(g, 0.05, 50)]
        masses += [float(np.clip(masses[0] * _log(g, 0.2, 5), 0.05, 50)) for _ in range(n - 1)]
        ks = [_log(g, 0.3, 3) for _ in range(n)]
        f = _modes(masses, ks)
        if f[-1] / f[0] <= 8 and f[1] / f[0] >= 1.3:
            break
    f1 = _log(g, 4.0, 80.0)
    ks = [k * (f1 / f[0]) ** 2 for k in ks]
    freqs = f * f1 / f[0]
    zeta = _log(g, 0.003, 0.02)
    beta = 2 * zeta / (2 * np.pi * f1)
    rate = float(g.choice([1000.0, 2000.0, 2048.0, 4096.0, 5000.0, 10000.0, 20000.0]))
    rate = max(rate, float(2 ** np.ceil(np.log2(8 * freqs[-1]))))
    tau = 1.0 / (zeta * 2 * np.pi * f1)
    record_s = float(np.clip(3 * tau, max(1.0, 20.0 / f1), 4.0))
    pre = float(g.choice([0.02, 0.05, 0.1, 0.2]))
    drive = int(g.choice([1, 2]))
    n_blows = int(g.integers(3, 5))
    snr = float(g.uniform(30, 50))
    peak = max(2.0, masses[drive - 1] * (2 * np.pi * f1) ** 2 * 1e-3 * _log(g, 0.5, 2))
    levels = np.sort(g.uniform(0.3, 1.0, n_blows))
    levels[-1] = 1.0
    blows = tuple(float(f"{peak * levels[k]:.3g}") for k in g.permutation(n_blows))
    els = [Element(between=(i, i + 1), k=ks[i], c=beta * ks[i]) for i in range(n)]
    share = _log(g, 0.01, 0.05) if kind.startswith("weak") else _log(g, 0.02, 0.1) if kind == "ground" else 0.0
    pair = (1, 2) if n == 2 or g.uniform() < 0.5 else (2, 3)
    system = MdofSystem(name=f"{which[0]}{seed}-{kind}", masses_kg=tuple(masses), elements=tuple(els),
                        driving_point=drive, rate_hz=rate, pretrigger_s=pre, record_s=record_s, impacts_n=blows,
                        tip="rubber" if freqs[-1] < 150 else "plastic")
    k3 = 0.0
    if share:  # sized on the linear system's largest blow
        x = mdof_impact_test(system, max(blows), snr_db=None).truth_x
        el = 0 if kind == "ground" else pair[0]  # spring pair[0] joins masses pair[0] and pair[0] + 1
        d = x[0] if kind == "ground" else x[pair[0] - 1] - x[pair[0]]
        k3 = float(f"{share * ks[el] / float(np.max(np.abs(d))) ** 2:.4g}")
        els[el] = els[el].model_copy(update={"k3": k3})
        system = system.model_copy(update={"elements": tuple(els)})
    facts = {"name": system.name, "kind": kind, "masses_kg": [round(m, 4) for m in masses],
             "modes_hz": [round(float(x), 2) for x in freqs], "zeta1": round(zeta, 4), "rate_hz": rate,
             "record_s": round(record_s, 2), "pre_s": pre, "blows_n": list(blows), "drive": drive,
             "snr_db": round(snr, 1), "share": round(share, 4), "k3": k3,
             "pair": list(pair) if kind != "ground" else [0, 1]}
    return system, snr, facts


def expected(kind: str) -> str:
    return "modal_coupling" if kind.startswith("weak") else "none"


def false_claim(row: dict) -> bool:
    return not row["kind"].startswith("weak") and row.get("cause") == "modal_coupling"


def run(job: tuple[str, int, str, bool]) -> dict:
    kind, seed, which, refine = job
    from station.mdof_commands import diagnose_mdof_object

    system, snr, row = draw(kind, seed, which)
    with tempfile.TemporaryDirectory() as tmp:
        files = []
        for k, peak in enumerate(system.impacts_n):
            rec = mdof_impact_test(system, peak, snr_db=snr, seed=1000 * seed + k)
            files.append(str(rec.write_csv(Path(tmp) / f"{system.name}-{k}.csv")))
        c0 = time.process_time()
        try:
            obj = diagnose_mdof_object(files, driving_point=f"acc{system.driving_point}", margin=0.5, refine=refine)
        except Exception as exc:  # noqa: BLE001 - reported per case
            row.update(cause=f"(error) {type(exc).__name__}: {str(exc)[:160]}", cpu_s=round(time.process_time() - c0, 1))
            return row
        row["cpu_s"] = round(time.process_time() - c0, 1)
    z = [[abs(v) / h for t, (v, h) in eq.items() if ("^" in t or "*" in t) and h] for eq in obj["coupling_coefficients"]]
    row.update(cause=obj["cause"], gain=round(obj["gain"], 3), agreement=obj.get("coupling_agreement"),
               refit=obj.get("refit_checked"), pfloor_before_refit=obj.get("prediction_floor_before_refit"), raw_gain=round(obj["raw_gain"], 3),
               coordinates=obj["coordinates"], allowance=obj.get("allowance"), modes=obj.get("modes"),
               baseline={c: round(v, 4) for c, v in obj["baseline"]["channel_nrmse"].items()},
               coupled={c: round(v, 4) for c, v in obj["coupled"]["channel_nrmse"].items()},
               folds_b=[round(f, 4) for f in obj["baseline"]["folds"]],
               folds_c=[round(f, 4) for f in obj["coupled"]["folds"]],
               floor={c: round(v, 4) for c, v in obj["noise_floor"].items()},
               pfloor={c: round(v, 4) for c, v in (obj.get("prediction_floor") or obj["noise_floor"]).items()},
               floor_parts=obj.get("floor_parts"),
               # the session-18 floor (noise and the held-out blow's impulse, no identification part), from the parts
               ratio_s18=(round(max(obj["coupled" if obj["cause"] == "modal_coupling" else "baseline"]["channel_nrmse"][c]
                                    / max(0.01, float(np.hypot(obj["floor_parts"]["noise"][c],
                                                               obj["floor_parts"]["impulse"][c])))
                                    for c in obj["channels"]), 3) if obj.get("floor_parts") else None),
               ratio=round(max(obj["coupled" if obj["cause"] == "modal_coupling" else "baseline"]["channel_nrmse"][c]
                               / v for c, v in (obj.get("prediction_floor") or obj["noise_floor"]).items()), 3),
               coupling_z=round(max((x for e in z for x in e), default=0.0), 2),
               terms=obj["coupling_terms"], notes=[n[:200] for n in obj["notes"]],
               uncertain=obj.get("uncertain"), short_coupling=obj.get("short_coupling"))
    return row


def show(row: dict) -> None:
    head = (f"{row['name']}: m {row['masses_kg']} | {row['modes_hz']} Hz z{row['zeta1']} | {row['rate_hz']:g} Hz "
            f"{row['record_s']} s | {len(row['blows_n'])} blows at m{row['drive']} | {row['snr_db']} dB"
            + (f" | k3 {row['k3']:.4g} ({100 * row['share']:.1f} %) pair {row['pair']}" if row["share"] else ""))
    print(head, flush=True)
    if "cause" not in row:
        return
    ok = "FALSE CLAIM" if false_claim(row) else ("OK" if row["cause"] == expected(row["kind"]) else "miss")
    print(f"    -> {row['cause']}{' (uncertain)' if row.get('uncertain') else ''} ({ok})", end="", flush=True)
    if "baseline" not in row:
        print(flush=True)
        return
    a = row.get("allowance") or {}
    print(f" gain {100 * row['gain']:.0f} % raw {100 * row['raw_gain']:.0f} % base {row['baseline']} cpl {row['coupled']} "
          f"floor {row['floor']} pred {row.get('pfloor')} ratio {row.get('ratio')} (s18 floor {row.get('ratio_s18')}) | allowance: base_over {a.get('base_over', float('nan')):.2f} coupled_over "
          f"{a.get('coupled_over', float('nan')):.2f} excess {a.get('excess_gain', float('nan')):.2f} "
          f"worse folds {a.get('worse_folds')} | z {row['coupling_z']} agree {row.get('agreement')} refit {row.get('refit')} (floor before {row.get('pfloor_before_refit')}) | CPU {row['cpu_s']} s", flush=True)
    m = row.get("modes") or {}
    if m:  # per mode (eddi.mdof.modefloor): baseline -> coupled, floor, excess gain, folds better
        print("    modes: " + "; ".join(f"q{i + 1} {b:.3g}->{c:.3g} floor {f:.3g} excess {e:.2f} better {n}/{m['folds']}"
                                     for i, (b, c, f, e, n) in enumerate(zip(m["baseline"], m["coupled"], m["floor"],
                                                                            m["excess_gain"], m["better_folds"])))
              + f" | earned {m['earned']} decided {m.get('decided')}", flush=True)


def _seeds(text: str) -> list[int]:
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b) + 1)) if b else [int(a)]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=tuple(SET_TAG), default="tuning")
    ap.add_argument("--seeds", default="1-6", help="seeds, e.g. 1-12 or 3,5,7 (default 1-6)")
    ap.add_argument("--kinds", default=",".join(KINDS), help=f"comma-separated subset of {','.join(KINDS)}")
    ap.add_argument("--jobs", type=int, default=1, help="cases run at once (at most 2 on the shared machine)")
    ap.add_argument("--refine", action="store_true", help="polish (the CLI's default; slower)")
    ap.add_argument("--permissive", action="store_true",
                    help="calibration: the within-allowance rule's cuts opened (every candidate's coefficient seen)")
    ap.add_argument("--list", action="store_true", help="print the cases only")
    ap.add_argument("--json", help="write the rows to this JSON file")
    try:
        args = ap.parse_args(argv)
        seeds = _seeds(args.seeds)
    except ValueError:
        print("bench_mdof_nulls: --seeds: expected e.g. 1-12 or 3,5,7", file=sys.stderr)
        return 2
    kinds = [k for k in args.kinds.split(",") if k]
    if not kinds or any(k not in KINDS for k in kinds) or args.jobs < 1:
        print(f"bench_mdof_nulls: --kinds: expected names among {', '.join(KINDS)}; --jobs >= 1", file=sys.stderr)
        return 2
    jobs = [(k, s, args.set, args.refine) for s in seeds for k in kinds]
    if args.permissive:  # before the workers fork
        from eddi.mdof import allowance

        allowance.BASE_OVER, allowance.COUPLED_WITHIN, allowance.COEFFICIENT_Z, allowance.WORSE_FOLDS = 1.0, 3.5, 0.0, 9
    if args.list:
        for k, s, w, _r in jobs:
            show(draw(k, s, w)[2])
        return 0
    if args.jobs > 1:
        os.environ["STATION_SERIAL"] = "1"  # the cases in parallel, each diagnosis serial
        import multiprocessing

        with multiprocessing.get_context("fork").Pool(args.jobs) as pool:
            rows = []
            for row in pool.imap(run, jobs):
                show(row)
                rows.append(row)
    else:
        rows = []
        for job in jobs:
            rows.append(run(job))
            show(rows[-1])
    for kind in kinds:
        mine = [r for r in rows if r["kind"] == kind]
        ok = sum(r.get("cause") == expected(kind) for r in mine)
        fc = sum(false_claim(r) for r in mine)
        print(f"{kind}: {ok}/{len(mine)} {expected(kind)}" + (f"; false claims {fc}/{len(mine)}" if expected(kind) == "none"
                                                                else "") + "; causes "
              + ", ".join(f"{c} {sum(r.get('cause') == c for r in mine)}" for c in sorted({r.get('cause') for r in mine})),
              flush=True)
    print(f"CPU {sum(r.get('cpu_s', 0) for r in rows):.0f} s (diagnoses only)", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
