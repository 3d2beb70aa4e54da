"""Three-mass chains with a hidden cubic (or none): ``station diagnose`` with three accelerometers.

Session 13 (helper s13three, issue 14). Blind scorecards reported three-channel chains with a
nonlinear coupling read `none` or `unexplained` instead of `modal_coupling`, one of them over
600 s CPU. This family draws such chains as data for the rig (``simulated_rig``):

- ground - m1 - m2 - m3 (a spring from m3 to ground on some), masses 0.5-50 kg each,
  Rayleigh damping (dashpots beside the springs and from each mass to ground) of 0.3-3 % on
  the first and on the highest mode (the first at least enough to ring down to a third of its
  amplitude within the record), the highest mode at most a tenth of the rate;
- one hidden form: a ``cubic`` spring between masses 1-2 (``c12``) or 2-3 (``c23``), hardening or
  softening, or a cubic spring from mass 1 to ground (``ground``, not a coupling between masses:
  the expected verdict is not `modal_coupling`), sized by its share ``k3 d^2 / k`` at the largest
  blow (5-30 %; softening at most 12 %); ``null``: a linear chain (must read `none`);
- rates 1-20 kHz, 30-50 dB, 2-3 captures of 1-4 s, pre-trigger 10-100 ms, blows of 40-100 %
  of the largest, struck at mass 1 or 2 (named with ``--driving-point``).

``--set tuning`` is the even indices of family seed ``--seed`` (default 1; the set the code was
changed on); ``--set heldout`` the odd indices of seed ``--seed`` + 100 (default 101: other
masses, rates and noise draws, kept out of the loop). Each case is diagnosed in-process as
``station diagnose FILES --margin 0.5 --driving-point accK`` (``--no-refine`` unless
``--refine``) and printed: verdict, per-channel baseline / coupled held-out nrmse and floors, the
coupling estimate of the delivered model against the truth (physical coordinates: the ``xi^3``
coefficient of equation ``i``, i.e. ``k3``; modal: none), CPU seconds of the diagnosis.

    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_three.py --set tuning [--n 8] [--jobs 2]
    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_three.py --set heldout --n 8
    PYTHONPATH=. python benchmarks/bench_mdof_three.py --set tuning --list
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test

FORMS = ("c12", "c23", "ground", "null")
RATES = (1000.0, 2000.0, 2048.0, 4096.0, 5000.0, 10000.0, 20000.0)


@dataclass(frozen=True)
class Case:
    """One drawn case: the system (hidden cubic included), its test and the truth."""

    name: str
    system: MdofSystem
    form: str
    share: float
    k3: float
    snr: float
    info: dict


def _loguni(g, lo, hi):
    return float(np.exp(g.uniform(np.log(lo), np.log(hi))))


def _modes_hz(masses, els) -> np.ndarray:
    n = len(masses)
    k = np.zeros((n, n))
    for e in els:
        i, j = e.between[0] - 1, e.between[1] - 1
        for a, b, s in ((i, i, 1), (j, j, 1), (i, j, -1), (j, i, -1)):
            if a >= 0 and b >= 0:
                k[a, b] += s * e.k
    mi = np.diag(1 / np.sqrt(masses))
    return np.sqrt(np.abs(np.linalg.eigvalsh(mi @ k @ mi))) / (2 * np.pi)


def _linear(g, seed: int, index: int):
    masses = [_loguni(g, 0.5, 50.0) for _ in range(3)]
    grounded_end = bool(g.uniform() < 0.3)
    while True:
        ks = [_loguni(g, 0.2, 5.0) for _ in range(3)] + ([_loguni(g, 0.1, 1.0)] if grounded_end else [])
        pairs = [(0, 1), (1, 2), (2, 3)] + ([(0, 3)] if grounded_end else [])
        els = [Element(between=p, k=k) for p, k in zip(pairs, ks)]
        f = _modes_hz(masses, els)
        if f[-1] / f[0] <= 15:
            break
    rate = float(g.choice(RATES))
    record_s = float(g.choice([1.0, 1.5, 2.0, 3.0, 4.0]))
    f1 = _loguni(g, max(15.0 / record_s, 5.0), max(rate / 10 * f[0] / f[-1], 20.0))
    rate = max(rate, 1000.0 * np.ceil(10 * f[-1] * f1 / f[0] / 1000.0))
    scale = (f1 / f[0]) ** 2
    zeta = max(_loguni(g, 0.003, 0.03), 1.2 / (2 * np.pi * f1 * record_s))  # e^-1.2 ~ 0.3 left
    zeta_top = _loguni(g, 0.003, 0.03)
    # Rayleigh damping C = alpha M + beta K through zeta1 and the highest mode's zeta_top
    # (stiffness-proportional alone damps a mode 15x higher 15x more: gone within a few cycles)
    w1, w3 = 2 * np.pi * f1, 2 * np.pi * f1 * f[-1] / f[0]
    beta = max(2 * (zeta_top * w3 - zeta * w1) / (w3 ** 2 - w1 ** 2), 0.0)
    alpha = max(2 * zeta * w1 - beta * w1 ** 2, 0.0)
    els = [Element(between=e.between, k=e.k * scale, c=beta * e.k * scale) for e in els]
    els += [Element(between=(0, i + 1), c=alpha * m) for i, m in enumerate(masses)]  # to ground (air)
    return masses, els, rate, record_s, zeta


def draw(index: int, seed: int) -> Case:
    """Case ``index`` of family ``seed`` (module docstring)."""
    g = np.random.default_rng([seed, index, 3])
    masses, els, rate, record_s, zeta = _linear(g, seed, index)
    form = str(g.choice(FORMS, p=[0.3, 0.3, 0.15, 0.25]))
    soft = form != "null" and g.uniform() < 0.25
    share = _loguni(g, 0.05, 0.12 if soft else 0.30) if form != "null" else 0.0
    drive = int(g.choice([1, 2]))
    snr = float(g.uniform(30, 50))
    n_blows = int(g.integers(2, 4))
    pre = float(g.choice([0.01, 0.02, 0.05, 0.1]))
    f = _modes_hz(masses, els)
    peak = max(masses[drive - 1] * (2 * np.pi * f[0]) ** 2 * 1e-3 * _loguni(g, 0.3, 3), 2.0)
    levels = np.sort(g.uniform(0.4, 1.0, n_blows))
    levels[-1] = 1.0
    blows = tuple(float(f"{peak * levels[k]:.3g}") for k in g.permutation(n_blows))
    tip = "rubber" if f[-1] < 150 else "plastic"
    lin = MdofSystem(name=f"t{seed}-{index}", masses_kg=tuple(masses), elements=tuple(els), driving_point=drive,
                     rate_hz=rate, pretrigger_s=pre, record_s=record_s, impacts_n=blows, tip=tip)
    k3 = 0.0
    if form != "null":
        el = {"c12": 1, "c23": 2, "ground": 0}[form]
        x = mdof_impact_test(lin, max(blows), snr_db=None).truth_x
        a, b = els[el].between
        d = (x[a - 1] if a else 0.0) - x[b - 1]
        k3 = (-1.0 if soft else 1.0) * share * els[el].k / float(np.max(np.abs(d))) ** 2
        k3 = float(f"{k3:.4g}")
        new = list(els)
        new[el] = Element(between=els[el].between, k=els[el].k, c=els[el].c, k3=k3)
        lin = lin.model_copy(update={"elements": tuple(new)})
    info = {"masses_kg": [round(m, 3) for m in masses], "modes_hz": [round(float(x), 2) for x in f],
            "zeta1": round(zeta, 4), "rate_hz": rate, "record_s": record_s, "pre_s": pre, "blows_n": list(blows),
            "drive": drive, "form": form + ("-soft" if soft else ""), "share": round(share, 3), "k3": k3,
            "snr_db": round(snr, 1), "grounded_end": any(e.k and e.between == (0, 3) for e in els)}
    return Case(lin.name, lin, form, share, k3, snr, info)


def coupling_estimate(case: Case, model) -> float | None:
    """The delivered model's ``k3`` for the hidden element (physical coordinates), else None."""
    if model is None or model.coordinates != "physical" or case.form == "null":
        return None
    i = {"c12": 0, "c23": 1, "ground": 0}[case.form]  # equation i holds +k3 xi^3
    return float(model.stiffness[i].get(f"x{i + 1}^3", 0.0))


def run(case: Case, refine: bool) -> dict:
    from eddi.mdof.model import MdofModel
    from station.mdof_commands import diagnose_mdof_object

    row = {"name": case.name, **case.info}
    with tempfile.TemporaryDirectory() as tmp:
        files = []
        try:
            for k, peak in enumerate(case.system.impacts_n):
                rec = mdof_impact_test(case.system, peak, snr_db=case.snr, seed=200 + k)
                files.append(str(rec.write_csv(Path(tmp) / f"{case.name}-{k}.csv")))
        except Exception as exc:  # noqa: BLE001 - a case the rig cannot run is reported, not fatal
            row.update(cause="(rig) " + str(exc)[:120])
            return row
        c0 = time.process_time()
        saved = str(Path(tmp) / "model.json")
        try:
            obj = diagnose_mdof_object(files, driving_point=f"acc{case.system.driving_point}", margin=0.5,
                                       refine=refine, save_model=saved)
        except Exception as exc:  # noqa: BLE001
            row.update(cause=f"(error) {type(exc).__name__}: {str(exc)[:160]}",
                       cpu_s=round(time.process_time() - c0, 1))
            return row
        row["cpu_s"] = round(time.process_time() - c0, 1)
        model = MdofModel.from_json(Path(saved).read_text())
    est = coupling_estimate(case, model)
    row.update(cause=obj["cause"], gain=round(obj["gain"], 3), coordinates=obj["coordinates"],
               baseline={c: round(v, 4) for c, v in obj["baseline"]["channel_nrmse"].items()},
               coupled={c: round(v, 4) for c, v in obj["coupled"]["channel_nrmse"].items()},
               floor={c: round(v, 4) for c, v in obj["noise_floor"].items()},
               k3_est=est, k3_err=None if est is None or not case.k3 else round(est / case.k3 - 1, 4),
               terms=obj["coupling_terms"], notes=[n[:240] for n in obj["notes"]])
    return row


def expected(row: dict) -> str:
    return "modal_coupling" if row["form"].startswith("c") else "none"


def show(row: dict) -> None:
    print(f"{row['name']}: {row['form']} {100 * row['share']:.0f}% k3 {row['k3']:.4g} | m {row['masses_kg']} kg "
          f"| {row['modes_hz']} Hz z{row['zeta1']} | {row['rate_hz']:g} Hz {len(row['blows_n'])}x{row['record_s']} s "
          f"pre {row['pre_s']} | drive {row['drive']}{' +ground end' if row['grounded_end'] else ''} "
          f"| {row['snr_db']} dB", flush=True)
    if "cause" not in row:
        return
    ok = "OK" if row["cause"] == expected(row) else ("(ground)" if row["form"] == "ground" else "MISS")
    if "baseline" not in row:
        print(f"    -> {row['cause']} {ok} CPU {row.get('cpu_s')} s", flush=True)
        return
    k3 = "-" if row["k3_est"] is None else f"{row['k3_est']:.4g} ({100 * (row['k3_err'] or 0):+.1f} %)"
    print(f"    -> {row['cause']} {ok} gain {100 * row['gain']:.0f} % {row['coordinates']} | base {row['baseline']} "
          f"cpl {row['coupled']} floor {row['floor']} | k3 est {k3} | CPU {row['cpu_s']} s", flush=True)
    for s in row["notes"][:3]:
        print("       note:", s, flush=True)


def _one(args_tuple):
    index, seed, refine = args_tuple
    return run(draw(index, seed), refine)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("tuning", "heldout"), default="tuning")
    ap.add_argument("--seed", type=int, default=None, help="family seed (tuning 1, heldout 101)")
    ap.add_argument("--n", type=int, default=8, help="cases in the set (default 8)")
    ap.add_argument("--cases", default="", help="comma-separated indices instead of the set's")
    ap.add_argument("--jobs", type=int, default=1, help="cases in parallel (at most 2 on this machine)")
    ap.add_argument("--refine", action="store_true", help="polish (the CLI's default; slower)")
    ap.add_argument("--list", action="store_true", help="print the cases only")
    ap.add_argument("--json", help="write the rows to this JSON file")
    args = ap.parse_args(argv)
    if args.n < 1 or args.jobs < 1:
        ap.error("--n and --jobs: expected >= 1")
    seed = args.seed if args.seed is not None else (1 if args.set == "tuning" else 101)
    first = 0 if args.set == "tuning" else 1
    try:
        idx = [int(x) for x in args.cases.split(",")] if args.cases else list(range(first, 2 * args.n, 2))
    except ValueError:
        ap.error("--cases: expected comma-separated integers")
    if args.list:
        for i in idx:
            case = draw(i, seed)
            show({"name": case.name, **case.info})
        return 0
    if args.jobs > 1:
        os.environ.setdefault("STATION_SERIAL", "1")  # the cases in parallel, each serial
        from multiprocessing import get_context

        with get_context("fork").Pool(args.jobs) as pool:
            rows = []
            for row in pool.imap(_one, [(i, seed, args.refine) for i in idx]):
                show(row)
                rows.append(row)
    else:
        rows = []
        for i in idx:
            row = _one((i, seed, args.refine))
            show(row)
            rows.append(row)
    named = sum(r.get("cause") == "modal_coupling" for r in rows if r["form"].startswith("c"))
    coupled = [r for r in rows if r["form"].startswith("c")]
    other = [r for r in rows if not r["form"].startswith("c")]
    print(f"couplings: {named} named, {sum(r.get('cause') == 'none' for r in coupled)} none, "
          f"{sum(r.get('cause') == 'unexplained' for r in coupled)} unexplained of {len(coupled)}; "
          f"null/ground: " + ", ".join(f"{r['name']} {r['form']} {r.get('cause')}" for r in other)
          + f"; CPU {sum(r.get('cpu_s', 0) for r in rows):.0f} s", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
