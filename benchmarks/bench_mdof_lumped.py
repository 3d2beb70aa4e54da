"""Lumped mechanisms between masses: quadratic springs and cubic dampers named, with their nulls.

Session 13 (helper s13lump, issue 14). The lumped fit (:mod:`eddi.mdof.lumped`) tries, between
every two masses, a quadratic (asymmetric) spring ``k2 (x_i - x_j)^2`` and a cubic damper
``c3 (v_i - v_j)^3`` beside the dashpot, the linear and the cubic spring; ``station diagnose``
names the determined ones (``mechanism``). This bench draws two-mass chains ground - m1 - m2,
struck at mass 1, as data for the rig (``simulated_rig``):

- masses 0.5-50 kg each, mass 1 on its ground spring 5-80 Hz (modes 3-300 Hz, at most 12x apart), link 0.3-3x the ground spring, stiffness-
  proportional damping 0.5-2 % on the first mode; rates 2-20 kHz (at least 8x the upper mode),
  30-50 dB per channel, 3-4 blows (the largest ~0.3-2 mm at mass 1's mode), records 1.5-3 s;
- one form between the masses, by index: ``quadratic`` (k2, 8-30 % of the link spring's force at
  the largest blow's peak stretch), ``damper`` (c3, 30-100 % of the link dashpot's force at the
  peak stretch rate), and the nulls ``linear`` (none: must stay ``none``) and ``cubic`` (k3,
  8-30 %: must stay a cubic spring, not be renamed a quadratic spring or a cubic damper).

Cases come from ``--seed`` (the family seed) and an index; ``--set tune`` the even indices (used
while changing the code), ``--set heldout`` the odd ones (kept out of that loop; run also with a
fresh ``--seed``). Each case: ``station diagnose FILES --margin 0.5 --no-refine`` in-process;
printed: verdict and mechanism, the hidden coefficient against the truth with its ci95, the
per-channel held-out (leave-one-out) nrmse of the model the verdict judges, the CPU seconds of
the diagnosis; and the lumped fit alone on every record at the recorded rate (``identify_lumped``:
the hidden element's value and ci95, what it names), whatever the verdict.

    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_lumped.py --set tune --n 8 --seed 1 --jobs 2
    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_lumped.py --set heldout --n 8 --seed 2 --jobs 2
    PYTHONPATH=. python benchmarks/bench_mdof_lumped.py --list --n 8        # the cases only
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test

FORMS = ("quadratic", "damper", "linear", "cubic")
#: The element each form hides between masses 1 and 2 and the mechanism that must be named.
HIDDEN = {"quadratic": ("k2", "quadratic spring between masses 1-2"), "damper": ("c3", "cubic damper between masses 1-2"),
          "cubic": ("k3", "cubic spring between masses 1-2"), "linear": (None, None)}


@dataclass(frozen=True)
class Case:
    name: str
    system: MdofSystem
    form: str
    coefficient: float
    snr: float
    info: dict


def _loguni(g, lo, hi):
    return float(np.exp(g.uniform(np.log(lo), np.log(hi))))


def _modes(m1, m2, k1, k12):
    kmat = np.array([[k1 + k12, -k12], [-k12, k12]])
    mi = np.diag(1 / np.sqrt([m1, m2]))
    return np.sqrt(np.linalg.eigvalsh(mi @ kmat @ mi)) / (2 * np.pi)


def draw(index: int, seed: int) -> Case:
    """Case ``index`` of family ``seed`` (module docstring)."""
    g = np.random.default_rng([seed, 1313, index])
    form = FORMS[(index // 2) % len(FORMS)]
    while True:  # modes 3-300 Hz, the upper at most 12x the lower
        m1, m2 = _loguni(g, 0.5, 50), _loguni(g, 0.5, 50)
        f1 = _loguni(g, 5, 80)
        k1 = m1 * (2 * np.pi * f1) ** 2
        k12 = k1 * _loguni(g, 0.3, 3)
        freqs = _modes(m1, m2, k1, k12)
        if freqs[0] >= 3.0 and freqs[1] <= 300.0 and freqs[1] <= 12 * freqs[0]:
            break
    zeta = _loguni(g, 0.005, 0.02)
    beta = 2 * zeta / (2 * np.pi * freqs[0])
    rate = float(g.choice([2000.0, 4096.0, 5000.0, 10000.0, 20000.0]))
    rate = max(rate, float(2 ** np.ceil(np.log2(8 * freqs[-1]))))
    tau = 1.0 / (zeta * 2 * np.pi * freqs[0])
    record_s = float(np.clip(4 * tau, 1.5, 3.0))
    snr = float(g.uniform(30, 50))
    peak = max(2.0, m1 * (2 * np.pi * freqs[0]) ** 2 * 1e-3 * _loguni(g, 0.3, 2))
    n_blows = int(g.integers(3, 5))
    levels = np.sort(g.uniform(0.3, 1.0, n_blows))
    levels[-1] = 1.0
    blows = tuple(float(f"{peak * v:.3g}") for v in g.permutation(levels))
    tip = "rubber" if freqs[-1] < 150 else "plastic"
    share = _loguni(g, 0.3, 1.0) if form == "damper" else _loguni(g, 0.08, 0.3)
    ground = Element(between=(0, 1), k=k1, c=beta * k1)
    link = dict(between=(1, 2), k=k12, c=beta * k12)
    lin = MdofSystem(name=f"l{seed}-{index}", masses_kg=(m1, m2), elements=(ground, Element(**link)), driving_point=1,
                     rate_hz=rate, pretrigger_s=0.02, record_s=record_s, impacts_n=blows, tip=tip)
    kind = HIDDEN[form][0]
    coef = 0.0
    if kind is not None:
        tr = mdof_impact_test(lin, max(blows), snr_db=None)
        d = np.max(np.abs(tr.truth_v[0] - tr.truth_v[1] if kind == "c3" else tr.truth_x[0] - tr.truth_x[1]))
        lin_force = (beta * k12 if kind == "c3" else k12) * d
        coef = float(f"{share * lin_force / d ** {'k2': 2, 'k3': 3, 'c3': 3}[kind]:.4g}")
        link[kind] = coef
    system = MdofSystem(name=lin.name, masses_kg=(m1, m2), elements=(ground, Element(**link)), driving_point=1,
                        rate_hz=rate, pretrigger_s=0.02, record_s=record_s, impacts_n=blows, tip=tip)
    info = {"masses_kg": [round(m1, 3), round(m2, 3)], "modes_hz": [round(float(f), 2) for f in freqs],
            "zeta1": round(zeta, 4), "rate_hz": rate, "record_s": round(record_s, 2), "blows_n": list(blows),
            "form": form, "share": round(share if kind else 0.0, 3), "snr_db": round(snr, 1), "coefficient": coef}
    return Case(lin.name, system, form, coef, snr, info)


def expected(form: str) -> tuple[str, str | None]:
    return ("none", None) if form == "linear" else ("modal_coupling", HIDDEN[form][1])


def _lumped_alone(recs: list, kind: str | None) -> dict:
    """The lumped fit on every record at the recorded rate (``identify_lumped``), whatever the
    diagnosis delivers: the hidden element's value and ci95, the determined couplings named."""
    try:
        from eddi.mdof.mechanisms import mechanisms, named_coupling
    except ImportError:  # a checkout before session 13 (to compare the verdicts)
        return {"error": "no eddi.mdof.mechanisms"}
    from eddi.mdof.physical import identify_lumped
    from station.mdof_data import condition_multichannel
    from station.readers import Measurement

    conditioned = [condition_multichannel(Measurement(t=r.t, channels=r.columns(), rate_hz=r.rate_hz,
                                                      pretrigger_samples=r.pretrigger_samples, mass=None,
                                                      source="bench", metadata={})) for r in recs]
    try:
        fit = identify_lumped(conditioned, ("acc1", "acc2"), "acc1").lumped
    except Exception as exc:  # noqa: BLE001 - reported
        return {"error": f"{type(exc).__name__}: {str(exc)[:120]}"}
    found = mechanisms(fit.constants, fit.ci95)
    hit = [m for m in found if m.kind == kind and m.between == (1, 2)]
    return {"named": named_coupling(found), "found": hit[0].as_dict() if hit else None}


def _cpu() -> float:
    """CPU seconds of this process and its reaped children (the diagnosis forks its folds)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def run(case: Case) -> dict:
    from station.mdof_commands import diagnose_mdof_object

    row = {"name": case.name, **case.info}
    with tempfile.TemporaryDirectory() as tmp:
        files, recs = [], []
        for k, peak in enumerate(case.system.impacts_n):
            rec = mdof_impact_test(case.system, peak, snr_db=case.snr, seed=200 + k)
            files.append(str(rec.write_csv(Path(tmp) / f"{case.name}-{k}.csv")))
            recs.append(rec)
        row["lumped"] = _lumped_alone(recs, HIDDEN[case.form][0])
        c0 = _cpu()
        try:
            obj = diagnose_mdof_object(files, driving_point="acc1", margin=0.5, refine=False)
        except Exception as exc:  # noqa: BLE001 - a case that fails is reported, not fatal
            row.update(cause=f"(error) {type(exc).__name__}: {str(exc)[:160]}", cpu_s=round(_cpu() - c0, 1))
            return row
        row["cpu_s"] = round(_cpu() - c0, 1)
    kind = HIDDEN[case.form][0]
    got = [m for m in obj.get("mechanisms", []) if m["kind"] == kind and m["between"] == [1, 2]] if kind else []
    row.update(cause=obj["cause"], mechanism=obj.get("mechanism"), gain=round(obj["gain"], 3),
               coordinates=obj["coordinates"],
               heldout={c: round(v, 4) for c, v in obj["coupled" if obj["cause"] != "none" else "baseline"]
                        ["channel_nrmse"].items()},
               floor={c: round(v, 4) for c, v in obj["noise_floor"].items()},
               found=got[0] if got else None,
               others=[m["name"] for m in obj.get("mechanisms", []) if m["determined"] and m["kind"] != kind])
    return row


def judged(row: dict) -> bool:
    cause, mech = expected(row["form"])
    if row.get("cause") != cause:
        return False
    if mech is None:
        return True
    return mech in (row.get("mechanism") or "") and not any(
        w in (row.get("mechanism") or "") for w in ("quadratic spring", "cubic damper", "cubic spring")
        if w not in mech)


def show(row: dict) -> None:
    print(f"{row['name']}: {row['form']} {100 * row['share']:.0f}% | m {row['masses_kg']} kg | {row['modes_hz']} Hz "
          f"z{row['zeta1']} | {row['rate_hz']:g} Hz {row['record_s']} s | {len(row['blows_n'])} blows | "
          f"{row['snr_db']} dB", flush=True)
    if "cause" not in row:
        return
    print(f"    -> {row['cause']} ({'OK' if judged(row) else 'MISS'}) mechanism: {row.get('mechanism')}"
          f" | CPU {row.get('cpu_s')} s", flush=True)
    if "heldout" not in row:
        return
    f = row.get("found")
    if row["coefficient"]:
        if f:
            err = 100 * (f["value"] / row["coefficient"] - 1)
            ci = "" if f["ci95"] is None else f" +- {100 * f['ci95'] / abs(row['coefficient']):.1f} %"
            cover = "" if f["ci95"] is None else (" covered" if abs(f["value"] - row["coefficient"]) <= f["ci95"]
                                                  else " NOT covered")
            print(f"       {f['kind']} truth {row['coefficient']:.4g}, got {f['value']:.4g} ({err:+.2f} %{ci}{cover})",
                  flush=True)
        else:
            print(f"       {HIDDEN[row['form']][0]} truth {row['coefficient']:.4g}, not in the model", flush=True)
    lum = row.get("lumped") or {}
    g = lum.get("found")
    if row["coefficient"] and g:
        print(f"       lumped fit alone: {g['kind']} {100 * (g['value'] / row['coefficient'] - 1):+.2f} % "
              f"+- {100 * (g['ci95'] or float('nan')) / abs(row['coefficient']):.1f} %; named: {lum.get('named')!r}",
              flush=True)
    else:
        print(f"       lumped fit alone: named {lum.get('named', lum.get('error'))!r}", flush=True)
    print(f"       held-out nrmse {row['heldout']} floor {row['floor']} gain {100 * row['gain']:.0f} % "
          f"others {row['others']}", flush=True)


def _indices(args) -> list[int]:
    if args.cases:
        return [int(c) for c in args.cases.split(",")]
    first = 0 if args.set == "tune" else 1
    return [first + 2 * k for k in range(args.n)]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("tune", "heldout"), default="tune")
    ap.add_argument("--seed", type=int, default=1, help="family seed (default 1)")
    ap.add_argument("--n", type=int, default=8, help="cases in the set (default 8: two of each form)")
    ap.add_argument("--cases", default="", help="comma-separated indices instead of the set's")
    ap.add_argument("--jobs", type=int, default=1, help="cases in parallel processes (default 1; at most 2 here)")
    ap.add_argument("--list", action="store_true", help="print the cases only")
    ap.add_argument("--json", help="write the rows to this JSON file")
    args = ap.parse_args(argv)
    if args.n < 1 or args.jobs < 1:
        print("bench_mdof_lumped: --n and --jobs must be >= 1", file=sys.stderr)
        return 2
    cases = [draw(i, args.seed) for i in _indices(args)]
    if args.list:
        for c in cases:
            show({"name": c.name, **c.info})
        return 0
    if args.jobs > 1:
        import multiprocessing as mp

        with mp.get_context("fork").Pool(min(args.jobs, len(cases))) as pool:
            rows = []
            for row in pool.imap(run, cases):
                show(row)
                rows.append(row)
    else:
        rows = []
        for c in cases:
            rows.append(run(c))
            show(rows[-1])
    ok = sum(judged(r) for r in rows)
    cpu = sum(r.get("cpu_s", 0.0) for r in rows)
    print(f"{args.set} seed {args.seed}: {ok}/{len(rows)} as expected; CPU {cpu:.0f} s in all")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
