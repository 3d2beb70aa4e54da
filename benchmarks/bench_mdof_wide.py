"""A wide family of multi-DOF chains with a nonlinear coupling (and their nulls): the verdict.

Session 12 (helper s12two, issue 14). Three blind scorecards reported two- and three-mass chains
whose nonlinear coupling ``station diagnose`` did not find (`none`, or a baseline near 0.05 and
no `modal_coupling`). The session-11 benches (``bench_mdof_weak.py``, ``bench_mdof_chain.py``)
pass; this one draws a wider family at random, as data for the rig (``simulated_rig``):

- chains ground - m1 - m2 (optionally m2 - ground: close modes) or ground - m1 - m2 - m3;
  masses 0.05-500 kg, mass ratios 0.05-20, first mode 3-300 Hz (modes up to 300 Hz), stiffness-proportional
  damping 0.2-3 % on the first mode;
- one coupling form between masses 1 and 2 (or 2 and 3): ``cubic`` spring, ``softening`` cubic,
  ``quadratic`` spring (``k2 (x_i - x_j)^2``), cubic ``damper`` (``c3 (v_i - v_j)^3``), or a
  cubic spring to ``ground`` on one mass only (not a coupling between masses: reported, judged
  apart), sized by its share of the linear element's force (or of the dashpot's) at the largest
  blow, 2-30 %; ``null`` has none (a linear chain) - every null must stay ``none``;
- rates 1-20 kHz, 30-60 dB, records 1-10 s (at least 2.5 ring-down time constants and 15 periods, at most 10 s), pre-trigger
  5-250 ms, 2-6 blows of 25-100 % of the largest, struck at mass 1 or 2, the driving point
  named (``--driving-point``) or not (the first channel: right only when struck at mass 1),
  and on some two-mass chains a third accelerometer (a second sensor on mass 2).

Cases are drawn from ``--seed`` (the family seed) and an index; the indices split in two
halves: ``--set tune`` the even ones (used while changing the code), ``--set heldout`` the odd
ones (kept out of the loop; run with a fresh ``--seed`` as well). Each case is diagnosed
in-process as ``station diagnose FILES --margin 0.5 [--driving-point accK]`` (``--no-refine``
unless ``--refine``), its cause, per-channel baseline / coupled held-out nrmse, floors, gain,
CPU seconds printed; ``--json OUT`` writes every row.

    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_wide.py --set tune --n 12 [--seed 1] [--null]
    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_wide.py --set heldout --n 12 --seed 2
    PYTHONPATH=. python benchmarks/bench_mdof_wide.py --set tune --n 12 --list    # the cases only
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from dataclasses import dataclass, field
from math import comb
from pathlib import Path

import numpy as np

from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test

FORMS = ("cubic", "softening", "quadratic", "damper", "ground", "null")


@dataclass
class Case:
    """One drawn case: the system, how it is tested and what is hidden."""

    name: str
    system: MdofSystem
    form: str
    share: float
    pair: tuple[int, int]
    snr: float
    named: bool
    extra_sensor: bool
    model: object = None
    info: dict = field(default_factory=dict)

    @property
    def coupled(self) -> bool:
        return self.form in ("cubic", "softening", "quadratic", "damper")


def _loguni(g, lo, hi):
    return float(np.exp(g.uniform(np.log(lo), np.log(hi))))


def _chain(g, n: int, grounded_end: bool):
    masses = [_loguni(g, 0.05, 500)]
    for _ in range(n - 1):
        masses.append(float(np.clip(masses[0] * _loguni(g, 0.05, 20), 0.05, 500)))
    ks = [_loguni(g, 0.2, 5) for _ in range(n)] + ([_loguni(g, 0.05, 1)] if grounded_end else [])
    return masses, ks


def _frequencies(masses, ks, n, grounded_end):
    kmat = np.zeros((n, n))
    for i in range(n):  # element i joins node i (0 ground) to node i + 1
        kmat[i, i] += ks[i]
        if i > 0:
            kmat[i - 1, i - 1] += ks[i]
            kmat[i - 1, i] -= ks[i]
            kmat[i, i - 1] -= ks[i]
    if grounded_end:
        kmat[n - 1, n - 1] += ks[n]
    mi = np.diag(1 / np.sqrt(masses))
    return np.sqrt(np.linalg.eigvalsh(mi @ kmat @ mi)) / (2 * np.pi)


def draw(index: int, seed: int) -> Case:
    """Case ``index`` of family ``seed`` (module docstring)."""
    g = np.random.default_rng([seed, index])
    n = 3 if g.uniform() < 0.25 else 2
    grounded_end = n == 2 and g.uniform() < 0.3
    while True:  # modes within 1-300 Hz, the highest at most 12x the lowest
        masses, ks = _chain(g, n, grounded_end)
        f = _frequencies(masses, ks, n, grounded_end)
        if f[-1] / f[0] <= 12:
            break
    f1 = _loguni(g, 3.0, 300.0 * f[0] / f[-1])
    scale = (f1 / f[0]) ** 2
    ks = [k * scale for k in ks]
    freqs = f * f1 / f[0]
    zeta = _loguni(g, 0.002, 0.03)
    beta = 2 * zeta / (2 * np.pi * f1)
    rate = float(g.choice([1000.0, 2000.0, 2048.0, 4096.0, 5000.0, 10000.0, 20000.0]))
    rate = max(rate, float(2 ** np.ceil(np.log2(8 * freqs[-1]))))
    tau = 1.0 / (zeta * 2 * np.pi * f1)
    record_s = float(np.clip(g.choice([1.0, 2.0, 4.0, 8.0]) if g.uniform() < 0.5 else 6 * tau, 1.0, 40.0))
    record_s = float(np.clip(record_s, min(10.0, max(2.5 * tau, 15.0 / f1)), 10.0))
    rate = min(rate, max(1000.0, 2.0 ** np.floor(np.log2(200000 / record_s))))  # at most ~200k samples
    pre = float(g.choice([0.005, 0.01, 0.02, 0.05, 0.1, 0.25]))
    n_blows = int(g.integers(2, 7))
    drive = int(g.choice([1, 2]))
    form = str(g.choice(FORMS))
    share = _loguni(g, 0.02, 0.3)
    pair = (1, 2) if n == 2 or g.uniform() < 0.5 else (2, 3)
    snr = float(g.uniform(30, 60))
    named = bool(g.uniform() < 0.6) or drive != 1  # unnamed: the default (first channel) is right
    extra = n == 2 and g.uniform() < 0.25
    tip = "rubber" if freqs[-1] < 150 else "plastic"
    els = [Element(between=(i, i + 1), k=ks[i], c=beta * ks[i]) for i in range(n)]
    if grounded_end:
        els.append(Element(between=(0, n), k=ks[n], c=beta * ks[n]))
    # blows: the largest gives a displacement of order 1 mm at the struck mass's first mode
    peak = masses[drive - 1] * (2 * np.pi * f1) ** 2 * 1e-3 * _loguni(g, 0.3, 3)
    peak = max(peak, 2.0)  # a hammer blow of at least 2 N (the force channel's noise is absolute)
    levels = np.sort(g.uniform(0.25, 1.0, n_blows))
    levels[-1] = 1.0
    order = g.permutation(n_blows)
    blows = tuple(float(f"{peak * levels[k]:.3g}") for k in order)
    lin = MdofSystem(name=f"c{seed}-{index}", masses_kg=tuple(masses), elements=tuple(els), driving_point=drive,
                     rate_hz=rate, pretrigger_s=pre, record_s=record_s, impacts_n=blows, tip=tip)
    case = Case(lin.name, lin, form, share if form != "null" else 0.0, pair, snr, named, extra)
    case.model = _truth(case)
    case.info = {"masses_kg": [round(m, 4) for m in masses], "modes_hz": [round(float(x), 3) for x in freqs],
                 "zeta1": round(zeta, 4), "rate_hz": rate, "record_s": round(record_s, 2), "pre_s": pre,
                 "blows_n": list(blows), "drive": drive, "form": form, "share": round(case.share, 4),
                 "pair": list(pair), "snr_db": round(snr, 1), "named": named, "extra_sensor": extra,
                 "grounded_end": grounded_end, "tip": tip}
    return case


def _truth(case: Case):
    """The system's model with the hidden form added (and the extra sensor)."""
    sys_ = case.system
    base = sys_.model()
    n = base.n_coords
    i, j = case.pair[0] - 1, case.pair[1] - 1
    stiff = [dict(d) for d in base.stiffness]
    damp = [dict(d) for d in base.damping]
    if case.form != "null":
        x = mdof_impact_test(sys_, max(sys_.impacts_n), snr_db=None).truth_x
        v = np.gradient(x, axis=1) * sys_.rate_hz
        el = sys_.elements[case.pair[0]] if case.form != "ground" else sys_.elements[0]
        if case.form == "ground":
            z, zv, order, on_v = x[0], v[0], 3, False
        else:
            z, zv = x[i] - x[j], v[i] - v[j]
            order = {"cubic": 3, "softening": 3, "quadratic": 2, "damper": 3}[case.form]
            on_v = case.form == "damper"
        amp = float(np.max(np.abs(zv if on_v else z)))
        lin_force = (el.c if on_v else el.k) * amp
        coef = case.share * lin_force / amp ** order * (-1.0 if case.form == "softening" else 1.0)
        coef = float(f"{coef:.4g}")
        case.info["coefficient"] = coef
        target = damp if on_v else stiff
        letter = "v" if on_v else "x"
        nodes = (i, j) if case.form != "ground" else (i, -1)
        for side, node in enumerate(nodes):
            if node < 0:
                continue
            sign = 1.0 if side == 0 else -1.0
            for p in range(order + 1):  # (z_i - z_j)^order expanded
                q = order - p
                if nodes[1] < 0 and q:
                    continue
                powers = {}
                if p:
                    powers[nodes[0]] = p
                if q:
                    powers[nodes[1]] = powers.get(nodes[1], 0) + q
                term = "*".join(f"{letter}{k + 1}" + (f"^{e}" if e > 1 else "") for k, e in sorted(powers.items()))
                target[node][term] = target[node].get(term, 0.0) + sign * coef * comb(order, p) * (-1.0) ** q
    chans = list(base.channels)
    shapes = [list(r) for r in base.phi]
    if case.extra_sensor:
        chans.append(f"acc{n + 1}")
        shapes.append([0.0] * (n - 1) + [1.0])
    from eddi.mdof.model import MdofModel

    return MdofModel.create(coordinates="physical", mass=base.mass, input=base.input, damping=tuple(damp),
                            stiffness=tuple(stiff), channels=tuple(chans), shapes=tuple(map(tuple, shapes)),
                            driving_point=base.driving_point, notes=f"bench_mdof_wide {case.name}")


def run(case: Case, refine: bool, null: bool) -> dict:
    from station.mdof_commands import diagnose_mdof_object

    if null and case.form != "null":
        case = Case(case.name + "-null", case.system, "null", 0.0, case.pair, case.snr, case.named,
                    case.extra_sensor, info=dict(case.info, form="null", share=0.0))
        case.model = _truth(case)
    row = {"name": case.name, **case.info}
    with tempfile.TemporaryDirectory() as tmp:
        files = []
        try:
            for k, peak in enumerate(case.system.impacts_n):
                rec = mdof_impact_test(case.system, peak, snr_db=case.snr, seed=100 + k, model=case.model)
                files.append(str(rec.write_csv(Path(tmp) / f"{case.name}-{k}.csv")))
        except Exception as exc:  # noqa: BLE001 - a case the rig cannot run is reported, not fatal
            row.update(cause="(rig) " + str(exc)[:120])
            return row
        c0 = time.process_time()
        w0 = time.perf_counter()
        try:
            obj = diagnose_mdof_object(files, driving_point=f"acc{case.system.driving_point}" if case.named else None,
                                       margin=0.5, refine=refine)
        except Exception as exc:  # noqa: BLE001
            row.update(cause=f"(error) {type(exc).__name__}: {str(exc)[:160]}",
                       cpu_s=round(time.process_time() - c0, 1))
            return row
        row["cpu_s"] = round(time.process_time() - c0, 1)
        row["wall_s"] = round(time.perf_counter() - w0, 1)
    row.update(cause=obj["cause"], gain=round(obj["gain"], 3), coordinates=obj["coordinates"],
               baseline={c: round(v, 4) for c, v in obj["baseline"]["channel_nrmse"].items()},
               coupled={c: round(v, 4) for c, v in obj["coupled"]["channel_nrmse"].items()},
               folds_b=[round(f, 4) for f in obj["baseline"]["folds"]],
               folds_c=[round(f, 4) for f in obj["coupled"]["folds"]],
               floor={c: round(v, 4) for c, v in obj["noise_floor"].items()},
               terms=obj["coupling_terms"], notes=[n[:240] for n in obj["notes"]],
               symptoms=[s["text"][:200] for s in obj["symptoms"]],
               hz=[round(f, 3) for f in obj["natural_frequencies_hz"]])
    return row


def expected(row: dict) -> str:
    return "modal_coupling" if row["form"] in ("cubic", "softening", "quadratic", "damper") else "none"


def show(row: dict) -> None:
    ok = row.get("cause") == expected(row)
    head = (f"{row['name']}: {row['form']} {100 * row['share']:.0f}% pair {row['pair']} | m {row['masses_kg']} "
            f"| {row['modes_hz']} Hz z{row['zeta1']} | {row['rate_hz']:g} Hz {row['record_s']} s pre {row['pre_s']} "
            f"| {len(row['blows_n'])} blows | drive {row['drive']} {'named' if row['named'] else 'unnamed'}"
            f"{' +sensor' if row['extra_sensor'] else ''} | {row['snr_db']} dB")
    print(head, flush=True)
    if "cause" not in row:  # --list
        return
    if "baseline" not in row:
        print(f"    -> {row.get('cause')}  {'OK' if ok else 'MISS'}", flush=True)
        return
    print(f"    -> {row['cause']} ({'OK' if ok else 'MISS'}) gain {100 * row['gain']:.0f} % coords {row['coordinates']} "
          f"base {row['baseline']} cpl {row['coupled']} floor {row['floor']} CPU {row['cpu_s']} s", flush=True)
    print(f"       folds b {row['folds_b']} c {row['folds_c']} terms {row['terms']}", flush=True)
    for s in row["symptoms"][:3]:
        print("       symptom:", s, flush=True)
    for s in row["notes"][:4]:
        print("       note:", s, flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("tune", "heldout"), default="tune")
    ap.add_argument("--seed", type=int, default=1, help="family seed (default 1)")
    ap.add_argument("--n", type=int, default=12, help="cases in the set (default 12)")
    ap.add_argument("--cases", default="", help="comma-separated indices instead of the set's")
    ap.add_argument("--refine", action="store_true", help="polish (the CLI's default; slower)")
    ap.add_argument("--null", action="store_true", help="each case's linear null instead")
    ap.add_argument("--list", action="store_true", help="print the cases only")
    ap.add_argument("--json", help="write the rows to this JSON file")
    args = ap.parse_args(argv)
    if args.n < 1:
        ap.error("--n: expected >= 1")
    first = 0 if args.set == "tune" else 1
    idx = [int(x) for x in args.cases.split(",")] if args.cases else list(range(first, 2 * args.n, 2))
    rows = []
    for i in idx:
        case = draw(i, args.seed)
        if args.list:
            show({"name": case.name, **case.info})
            continue
        row = run(case, args.refine, args.null)
        show(row)
        rows.append(row)
    if rows:
        miss = [r["name"] for r in rows if r.get("cause") != expected(r)]
        print(f"{len(rows) - len(miss)}/{len(rows)} as expected; misses: {', '.join(miss) or '-'}; "
              f"CPU {sum(r.get('cpu_s', 0) for r in rows):.0f} s", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
