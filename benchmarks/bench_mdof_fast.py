"""Weak, fast-decaying upper modes under a low, large one: per-mode displacement errors (session 18).

Helper s18weak, issue 14. A blind three-accelerometer set (no mass, modes 2.52 / 15.7 / 22.7 Hz by
ERA; described by the lead only) had, after session 17's fixes, the right modal frequencies but the
per-mode held-out displacement nrmse (JSON ``modes``) of its weak modes 2 and 3 at 0.52 / 0.82 with
mode 1 fine, and ``none (uncertain)`` at 2.2x the channels' floor. Own cases of that kind: chains
ground - m1 - m2 - m3 (``grounded``: m3 also held to ground) with a heavy m1 on a soft spring, so
mode 1 lies 5-10x below modes 2-3 and the heavy driving point m1 hardly moves in them (weak
participation); stiffness-proportional dashpots with modes 2-3 1-5 % damped (they ring down in a
fraction of a second while mode 1 fills the record); 40-50 dB, acc only, 2-20 kHz, three blows.

Kinds (each seed draws one chain; its kinds share it): ``lin`` (linear), ``cpl`` (a cubic spring
between m1 and m2 at 3-10 % of its linear force at the largest blow: a nonlinear coupling).

Per case: ``station diagnose`` in-process (``--margin 0.5 --no-refine`` unless ``--refine``, in
one process), and per held-out fold the TRUE model's per-mode error in the fold's basis (the tail's
modes of its training captures, as the diagnosis' ``modes``): what a perfect model leaves, the
fair reference for the per-mode figures. Printed: verdict, channels (baseline, coupled, floor),
per mode the baseline's, the coupled model's and the truth's nrmse and the floor, the final model's
modal frequencies against the truth, CPU seconds of the diagnosis.

    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_fast.py --set tuning --seeds 1-4 --kinds lin,cpl
    PYTHONPATH=. python benchmarks/bench_mdof_fast.py --set heldout --seeds 1-4 --list
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_mdof_nulls import _log, _seeds  # noqa: E402

from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test  # noqa: E402

KINDS = ("lin", "cpl")
SET_TAG = {"tuning": 1801, "heldout": 1802}


def _frequencies(masses: list[float], elements: list[tuple[tuple[int, int], float]]) -> np.ndarray:
    """Undamped natural frequencies [Hz] of masses joined by springs ``((node_i, node_j), k)`` (0: ground)."""
    n = len(masses)
    kmat = np.zeros((n, n))
    for (i, j), k in elements:
        for a, b in ((i, j), (j, i)):
            if a:
                kmat[a - 1, a - 1] += k
                if b:
                    kmat[a - 1, b - 1] -= k
    mi = np.diag(1 / np.sqrt(masses))
    return np.sqrt(np.sort(np.linalg.eigvalsh(mi @ kmat @ mi))) / (2 * np.pi)


def _chain(g: np.random.Generator) -> tuple[list[float], list[tuple[tuple[int, int], float]], np.ndarray]:
    """Masses and springs (before scaling) with f2/f1 in 5-10 and f3/f2 in 1.15-2."""
    while True:
        m1 = _log(g, 1.0, 30.0)
        masses = [m1, m1 * _log(g, 0.05, 0.2)]
        masses.append(masses[1] * _log(g, 0.4, 1.2))
        springs = [((0, 1), _log(g, 0.03, 0.3)), ((1, 2), _log(g, 0.5, 3.0)), ((2, 3), _log(g, 0.3, 2.0))]
        if g.uniform() < 0.5:  # grounded chain: m3 held to ground too
            springs.append(((0, 3), _log(g, 0.2, 1.5)))
        f = _frequencies(masses, springs)
        if 5.0 <= f[1] / f[0] <= 10.0 and 1.15 <= f[2] / f[1] <= 2.0:
            return masses, springs, f


def draw(kind: str, seed: int, which: str) -> tuple[MdofSystem, float, dict]:
    """The system, its SNR [dB] and a row of facts."""
    g = np.random.default_rng([SET_TAG[which], seed])
    masses, springs, f = _chain(g)
    f1 = _log(g, 1.5, 8.0)
    springs = [(b, k * (f1 / f[0]) ** 2) for b, k in springs]
    freqs = f * f1 / f[0]
    zeta2 = _log(g, 0.01, 0.05)
    beta = 2 * zeta2 / (2 * np.pi * freqs[1])  # stiffness-proportional: zeta_i = zeta2 f_i / f2
    rate = float(g.choice([2048.0, 5000.0, 10000.0, 20000.0]))
    record_s = float(g.uniform(4.0, 8.0))
    snr = float(g.uniform(40.0, 50.0))
    drive = 1 if g.uniform() < 0.75 else 2
    peak = max(5.0, masses[0] * (2 * np.pi * f1) ** 2 * 2e-3 * _log(g, 0.5, 2.0))
    levels = [float(g.uniform(0.6, 0.8)), float(g.uniform(0.8, 0.95)), 1.0]
    blows = tuple(float(f"{peak * levels[k]:.3g}") for k in g.permutation(3))
    share = _log(g, 0.03, 0.10)
    els = [Element(between=b, k=k, c=beta * k) for b, k in springs]
    system = MdofSystem(name=f"{which[0]}{seed}-{kind}", masses_kg=tuple(masses), elements=tuple(els),
                        driving_point=drive, rate_hz=rate, pretrigger_s=float(g.uniform(0.05, 0.2)),
                        record_s=record_s, impacts_n=blows, tip="rubber")
    k3 = 0.0
    if kind == "cpl":  # a cubic on the spring m1 - m2 at ``share`` of its linear force at the largest blow
        x = mdof_impact_test(system, max(blows), snr_db=None).truth_x
        k3 = float(f"{share * springs[1][1] / float(np.max(np.abs(x[0] - x[1]))) ** 2:.4g}")
        els[1] = els[1].model_copy(update={"k3": k3})
        system = system.model_copy(update={"elements": tuple(els)})
    facts = {"name": system.name, "kind": kind, "masses_kg": [round(m, 4) for m in masses],
             "grounded": len(springs) == 4, "modes_hz": [round(float(x), 3) for x in freqs],
             "zeta": [round(float(zeta2 * x / freqs[1]), 4) for x in freqs], "rate_hz": rate,
             "record_s": round(record_s, 2), "blows_n": list(blows), "drive": drive, "snr_db": round(snr, 1),
             "share": round(share, 4) if k3 else 0.0, "k3": k3}
    return system, snr, facts


def _records(files: list[str], driving_point: str):
    from station.mdof_commands import _read
    from station.mdof_data import condition_all, reduce_rate

    meas, _note = reduce_rate(_read(files))
    return condition_all(meas, driving_point)


def truth_modes(system: MdofSystem, files: list[str]) -> list[list[float]]:
    """Per held-out fold, the true model's per-mode error in the basis of the fold's training tail
    (:func:`eddi.mdof.modefloor.mode_errors`; ERA of the conditioned training captures, as the
    diagnosis' first identification pass)."""
    from eddi.mdof.coordinates import linear_modes
    from eddi.mdof.modefloor import mode_errors, projector
    from eddi.mdof.validate import validate_mdof

    records, names, dp = _records(files, f"acc{system.driving_point}")
    truth = system.model()
    out = []
    for k, rec in enumerate(records):
        train = [r for j, r in enumerate(records) if j != k]
        modes = linear_modes(train, tail_fraction=0.2, driving_point=names.index(dp))
        proj = projector(modes.shapes)
        v = validate_mdof(truth, rec)
        out.append([float(e) for e in mode_errors(v.measured, v.simulated, proj, v.diverged)])
    return out


def _frequencies_of(model) -> list[float]:
    """Small-amplitude frequencies [Hz] of a delivered model (its linear part)."""
    try:
        return [round(float(f), 3) for f in np.sort(model.natural_frequencies_hz())]
    except (ValueError, np.linalg.LinAlgError):
        return []


def run(job: tuple[str, int, str, bool]) -> dict:
    kind, seed, which, refine = job
    os.environ["STATION_SERIAL"] = "1"  # one process: the CPU figure is the whole diagnosis
    from eddi.mdof.model import MdofModel
    from station.mdof_commands import diagnose_mdof_object

    system, snr, row = draw(kind, seed, which)
    with tempfile.TemporaryDirectory() as tmp:
        files = [str(mdof_impact_test(system, peak, snr_db=snr, seed=1000 * seed + k).write_csv(
            Path(tmp) / f"{system.name}-{k}.csv")) for k, peak in enumerate(system.impacts_n)]
        c0 = time.process_time()
        try:
            obj = diagnose_mdof_object(files, driving_point=f"acc{system.driving_point}", margin=0.5, refine=refine,
                                       save_model=str(Path(tmp) / "model.json"))
        except Exception as exc:  # noqa: BLE001 - reported per case
            row.update(cause=f"(error) {type(exc).__name__}: {str(exc)[:160]}",
                       cpu_s=round(time.process_time() - c0, 1))
            return row
        row["cpu_s"] = round(time.process_time() - c0, 1)
        model = MdofModel.model_validate_json(Path(tmp, "model.json").read_text())
        row["truth_modes"] = truth_modes(system, files)
    m = obj.get("modes") or {}
    row.update(cause=obj["cause"], uncertain=obj.get("uncertain"), coordinates=obj["coordinates"],
               baseline={c: round(v, 4) for c, v in obj["baseline"]["channel_nrmse"].items()},
               coupled={c: round(v, 4) for c, v in obj["coupled"]["channel_nrmse"].items()},
               floor={c: round(v, 4) for c, v in obj["noise_floor"].items()},
               modes=m, model_hz=_frequencies_of(model), notes=[n[:240] for n in obj["notes"]])
    return row


def show(r: dict) -> None:
    m = r.get("modes") or {}
    tm = np.mean(r["truth_modes"], axis=0) if r.get("truth_modes") else []
    per = "; ".join(f"q{i + 1} b {b:.3g} c {c:.3g} true {t:.3g} fl {f:.3g}" for i, (b, c, t, f)
                    in enumerate(zip(m.get("baseline", []), m.get("coupled", []), tm, m.get("floor", []))))
    over = max((b / f for b, f in zip(r.get("baseline", {}).values(), r.get("floor", {}).values()) if f), default=0)
    print(f"{r['name']}: m {r['masses_kg']} {'grounded ' if r['grounded'] else ''}modes {r['modes_hz']} "
          f"zeta {r['zeta']} {r['rate_hz']:g} Hz {r['record_s']} s drive {r['drive']} {r['snr_db']} dB share "
          f"{r['share']}\n    -> {r.get('cause')}{' (uncertain)' if r.get('uncertain') else ''} base "
          f"{r.get('baseline')} cpl {r.get('coupled')} floor {r.get('floor')} (base/floor max {over:.2f}) "
          f"model Hz {r.get('model_hz')} CPU {r.get('cpu_s')} s\n    modes: {per}", flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--set", choices=sorted(SET_TAG), default="tuning")
    ap.add_argument("--seeds", default="1-4", help="e.g. 1-6 or 2,5")
    ap.add_argument("--kinds", default=",".join(KINDS), help=f"comma-separated subset of {','.join(KINDS)}")
    ap.add_argument("--refine", action="store_true", help="polish (the CLI's default; slower)")
    ap.add_argument("--list", action="store_true", help="print the cases only")
    ap.add_argument("--json", help="write the rows to this JSON file")
    args = ap.parse_args(argv)
    kinds = [k for k in args.kinds.split(",") if k]
    if any(k not in KINDS for k in kinds):
        print(f"bench_mdof_fast: unknown kind in {args.kinds!r} (known: {', '.join(KINDS)})", file=sys.stderr)
        return 2
    if args.list:
        for s in _seeds(args.seeds):
            for k in kinds:
                print(json.dumps(draw(k, s, args.set)[2]))
        return 0
    rows = []
    for s in _seeds(args.seeds):
        for k in kinds:
            rows.append(run((k, s, args.set, args.refine)))
            show(rows[-1])
            if args.json:
                Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
