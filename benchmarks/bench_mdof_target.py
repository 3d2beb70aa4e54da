"""Issue 14's measured target, case by case: `station diagnose` (no mass) then `station validate` held out.

Session 14 (helper s14mfit). The issue's item 5: on the rig's multi-DOF systems, accelerometers
only, 45 dB, no mass given, the held-out nrmse of EVERY channel <= 0.05 and the modal frequencies
and coupling coefficients within 3 %. Each case here is run as a user would:

1. three training captures (the system's blows, noise seeds 100-102) written as CSV
   ``t,force,acc1..accN``; ``station diagnose C1 C2 C3 --driving-point accK --save-model M.json
   --json`` (no ``--mass``; the CLI defaults, polish included unless ``--no-refine``);
2. two held-out captures never trained on (70 % and 45 % of the largest blow, noise seeds 103-104):
   ``station validate M.json H1 H2 --json`` -> per-channel nrmse; the true model validated the same
   way is printed beside it (what the measurement allows: the noise floor of that channel);
3. the saved model's linear natural frequencies against the truth's, and its coupling / nonlinear
   stiffness coefficients against the truth's written in the model's coordinates (per unit mass;
   the terms carrying at least 10 % of their equation's largest nonlinear force, in equations whose
   nonlinear force is at least 1 % of the linear one; ``bench_mdof.truth_in_coordinates``; a term
   the model lacks counts 100 %).

PASS needs all three (every channel <= 0.05, every frequency and scored coefficient within 3 %).
Each channel's held-out prediction floor (the true model's ``channel_floor`` from ``station validate``:
acceleration noise and the impulse's uncertainty, :mod:`station.mdof_floor`) is printed; a second count
scores only the channels whose floor allows 0.05 (session 16: an energy sink's channel can sit above it
for the true model itself).

Sets: ``rig`` (the three systems of ``simulated_rig/mdof`` at 45 dB), ``tuning`` (even indices of
family seed 1) and ``heldout`` (odd indices of seed 2; not tuned on). The family (:func:`draw`):
two masses (cubic spring between them, a nonlinear energy sink = purely cubic light attachment,
a 1:3 pair with a cubic spring to ground, a quadratic spring between them) and three-mass chains
(``bench_mdof_three``'s chains with a cubic between 1-2 or 2-3); masses 0.05-50 kg, 30-45 dB,
rates 1-20 kHz, captures of 2-4 s.

    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_target.py --set rig --jobs 2
    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_target.py --set tuning --n 8 --jobs 2
    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_target.py --set heldout --n 8 --jobs 2
    PYTHONPATH=. python benchmarks/bench_mdof_target.py --set tuning --n 8 --list
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_mdof import truth_in_coordinates  # noqa: E402
from eddi.mdof.model import MdofModel  # noqa: E402
from eddi.mdof.terms import parse_multi_term  # noqa: E402
from simulated_rig.mdof_systems import Element, MdofSystem, load_mdof_system, mdof_impact_test  # noqa: E402

RIG = ("two-mass-cubic", "nes", "internal-1-3")
FORMS = ("chain", "nes", "1:3", "quadratic", "three")
RATES = (1000.0, 2000.0, 2048.0, 4096.0, 5000.0, 10000.0, 20000.0)
LIMIT_NRMSE, LIMIT_REL = 0.05, 0.03


@dataclass(frozen=True)
class Case:
    """A system to test (hidden nonlinearity included), its SNR and what it was drawn as."""

    name: str
    system: MdofSystem
    snr: float
    info: dict


def _loguni(g, lo, hi):
    return float(np.exp(g.uniform(np.log(lo), np.log(hi))))


def _modes_hz(masses, els) -> np.ndarray:
    sys_ = MdofSystem(masses_kg=tuple(masses), elements=tuple(Element(between=e.between, k=e.k) for e in els))
    return np.sort(sys_.model().natural_frequencies_hz())


def _damped(g, masses, els, f, record_s):
    """Rayleigh dashpots: zeta1 0.5-2 % (rings down to ~0.3 within the record), the top mode 0.3-3 %."""
    zeta = max(_loguni(g, 0.005, 0.02), 1.2 / (2 * np.pi * f[0] * record_s))
    zeta_top = _loguni(g, 0.003, 0.03)
    w1, w2 = 2 * np.pi * f[0], 2 * np.pi * f[-1]
    beta = max(2 * (zeta_top * w2 - zeta * w1) / (w2 ** 2 - w1 ** 2), 0.0)
    alpha = max(2 * zeta * w1 - beta * w1 ** 2, 0.0)
    out = [Element(between=e.between, k=e.k, c=beta * e.k) for e in els]
    return out + [Element(between=(0, i + 1), c=alpha * m) for i, m in enumerate(masses)], zeta


def _two_mass(g, form: str):
    m1 = _loguni(g, 0.05, 50.0)
    f1 = _loguni(g, 8.0, 150.0)
    k1 = m1 * (2 * np.pi * f1) ** 2
    if form == "nes":  # a light sink on a purely cubic spring (its linear part absent)
        m2 = m1 * _loguni(g, 0.02, 0.1)
        els = [Element(between=(0, 1), k=k1)]
    elif form == "1:3":  # two masses tuned so that f2 / f1 ~ 3 (2.9-3.1)
        m2 = m1 * _loguni(g, 0.1, 0.5)
        target = g.uniform(2.9, 3.1)
        lo, hi = 0.01, 100.0
        for _ in range(60):  # bisection on the link stiffness ratio for the modal frequency ratio
            mid = np.sqrt(lo * hi)
            f = _modes_hz([m1, m2], [Element(between=(0, 1), k=k1), Element(between=(1, 2), k=mid * k1)])
            lo, hi = (mid, hi) if f[1] / f[0] < target else (lo, mid)
        els = [Element(between=(0, 1), k=k1), Element(between=(1, 2), k=mid * k1)]
    else:
        m2 = m1 * _loguni(g, 0.2, 2.0)
        els = [Element(between=(0, 1), k=k1), Element(between=(1, 2), k=k1 * _loguni(g, 0.3, 2.0))]
    return [m1, m2], els


def draw(index: int, seed: int) -> Case:
    """Case ``index`` of family ``seed``: the form cycles through :data:`FORMS`, the rest is drawn."""
    form = FORMS[index % len(FORMS)]
    g = np.random.default_rng([seed, index, 14])
    record_s = float(g.choice([2.0, 2.5, 3.0, 4.0]))
    if form == "three":
        from bench_mdof_three import draw as draw_three

        j = index
        while True:  # a chain with a coupling between masses (not a null, not a ground cubic)
            c3 = draw_three(j, seed + 1000)
            if c3.form in ("c12", "c23"):
                break
            j += 7
        masses = list(c3.system.masses_kg)
        lin = [Element(between=e.between, k=e.k, c=e.c) for e in c3.system.elements]
        f = _modes_hz(masses, [e for e in lin if e.k])
        system = c3.system.model_copy(update={"record_s": max(record_s, c3.system.record_s)})
        rate, drive, pre = system.rate_hz, system.driving_point, system.pretrigger_s
        hidden = {"c12": (1, 2), "c23": (2, 3)}[c3.form]
        share = c3.share
    else:
        masses, lin = _two_mass(g, form)
        f = _modes_hz(masses, [e for e in lin if e.k] or [Element(between=(0, 1), k=1.0)])
        f = f[f > 0]  # the sink has no linear spring: one linear mode
        rate = float(g.choice(RATES))
        rate = max(rate, 1000.0 * np.ceil(12 * f[-1] / 1000.0))
        drive, pre = 1, float(g.choice([0.02, 0.05, 0.1]))
        els, _z = _damped(g, masses, lin, f if len(f) > 1 else np.array([f[0], 3 * f[0]]), record_s)
        if form == "nes":  # the sink's dashpot: 0.5-2 % of its mass's critical at the primary's frequency
            els.append(Element(between=(1, 2), c=2 * _loguni(g, 0.005, 0.02) * masses[1] * 2 * np.pi * f[0]))
        system = MdofSystem(name="x", masses_kg=tuple(masses), elements=tuple(els), driving_point=drive,
                            rate_hz=rate, pretrigger_s=pre, record_s=record_s, impacts_n=(1.0,),
                            tip="rubber" if f[-1] < 150 else "plastic")
        hidden = (0, 1) if form == "1:3" else (1, 2)
        share = _loguni(g, 0.08, 0.3)
    peak = max(masses[drive - 1] * (2 * np.pi * f[0]) ** 2 * 1e-3 * _loguni(g, 0.3, 2.0), 2.0)
    blows = tuple(float(f"{peak * s:.3g}") for s in (0.3, 0.6, 1.0))
    system = system.model_copy(update={"impacts_n": blows, "name": f"{form.replace(':', 'to')}-{seed}-{index}"})
    if form != "three":
        x = mdof_impact_test(system, max(blows), snr_db=None).truth_x
        a, b = hidden
        d = np.abs((x[a - 1] if a else 0.0) - x[b - 1]).max()
        els = list(system.elements)
        if form == "nes":  # purely cubic: sized on the primary's spring at the same stretch
            k_ref = els[0].k
        else:
            k_ref = next(e.k for e in els if e.between == hidden and e.k)
        coef = share * k_ref / d ** (1 if form == "quadratic" else 2)  # share of k_ref d at the peak stretch
        key = "k2" if form == "quadratic" else "k3"
        coef = float(f"{coef:.4g}")
        els.append(Element(between=hidden, **{key: coef}))
        system = system.model_copy(update={"elements": tuple(els)})
    snr = float(g.uniform(30, 45))
    info = {"form": form, "masses_kg": [round(m, 4) for m in masses], "modes_hz": [round(float(v), 2) for v in f],
            "rate_hz": system.rate_hz, "record_s": system.record_s, "blows_n": list(blows), "drive": drive,
            "share": round(share, 3), "snr_db": round(snr, 1)}
    return Case(system.name, system, snr, info)


def rig_case(name: str) -> Case:
    s = load_mdof_system(name)
    info = {"form": "rig", "masses_kg": list(s.masses_kg),
            "modes_hz": [round(float(v), 2) for v in np.sort(s.model().natural_frequencies_hz())],
            "rate_hz": s.rate_hz, "record_s": s.record_s, "blows_n": list(s.impacts_n), "drive": s.driving_point,
            "share": None, "snr_db": 45.0}
    return Case(name, s, 45.0, info)


def frequency_errors(truth: MdofModel, model: MdofModel) -> list[float]:
    """Relative error of the model's nearest linear natural frequency to each of the truth's
    oscillating ones (an energy sink has no linear spring: its 0 Hz mode is not scored, and a
    model's weak linear link may add a low mode there, which is not the primary's)."""
    fm = np.array([f for f in model.natural_frequencies_hz() if f > 0])
    return [float(np.min(np.abs(fm - v)) / v) if fm.size else 1.0 for v in truth.natural_frequencies_hz() if v > 0]


def coefficient_errors(truth: MdofModel, model: MdofModel, amp: np.ndarray) -> dict[str, float]:
    """``eq:term -> relative error`` of the scored nonlinear stiffness terms (module docstring)."""
    n = model.n_coords
    ref = truth_in_coordinates(truth, model, amp, np.random.default_rng(0))
    deg = {t: parse_multi_term(t, n).degree for t in ref}
    size = {t: float(np.prod(amp ** parse_multi_term(t, n).exponents[0])) for t in ref}
    out = {}
    for i in range(n):
        nl = {t: abs(ref[t][i]) * size[t] for t in ref if deg[t] >= 2}
        lin = sum(abs(ref[t][i]) * size[t] for t in ref if deg[t] == 1)
        big = max(nl.values())
        if big < 0.01 * lin:
            continue
        for t, s in nl.items():
            if s >= 0.1 * big:
                got = model.stiffness[i].get(t, 0.0) / model.mass[i]
                out[f"{i + 1}:{t}"] = float(abs(got - ref[t][i]) / abs(ref[t][i]))
    return out


def _station(args: list[str], cwd: str) -> tuple[int, dict | None, str]:
    env = dict(os.environ, STATION_SERIAL="1")
    p = subprocess.run([shutil.which("station") or "station", *args], cwd=cwd, env=env, capture_output=True, text=True)
    try:
        return p.returncode, json.loads(p.stdout), p.stderr[-300:]
    except json.JSONDecodeError:
        return p.returncode, None, (p.stdout + p.stderr)[-300:]


def run(case: Case, refine: bool) -> dict:
    row = {"name": case.name, **case.info}
    s = case.system
    truth = s.model()
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory(prefix="s14-target-") as tmp:
        try:
            train = [mdof_impact_test(s, p, snr_db=case.snr, seed=100 + k) for k, p in enumerate(s.impacts_n)]
            held = [mdof_impact_test(s, r * max(s.impacts_n), snr_db=case.snr, seed=103 + k)
                    for k, r in enumerate((0.7, 0.45))]
        except Exception as exc:  # noqa: BLE001 - a case the rig cannot run is reported, not fatal
            row.update(cause="(rig) " + str(exc)[:120])
            return row
        files = [r.write_csv(Path(tmp) / f"train{k}.csv").name for k, r in enumerate(train)]
        hfiles = [r.write_csv(Path(tmp) / f"held{k}.csv").name for k, r in enumerate(held)]
        Path(tmp, "truth.json").write_text(truth.to_json())
        argv = ["diagnose", *files, "--driving-point", f"acc{s.driving_point}", "--save-model", "m.json", "--json"]
        rc, obj, err = _station(argv + ([] if refine else ["--no-refine"]), tmp)
        if obj is None or not Path(tmp, "m.json").exists():
            row.update(cause=f"(diagnose exit {rc}) {err.strip()[-200:]}")
            return row
        rc_v, val, err_v = _station(["validate", "m.json", *hfiles, "--json"], tmp)
        _rc, tval, _e = _station(["validate", "truth.json", *hfiles, "--json"], tmp)
        # the delivered model on its own training captures beside the truth's (a fit short of the
        # truth there is the fit's, not the noise's)
        _rc, trn, _e = _station(["validate", "m.json", *files, "--json"], tmp)
        _rc, ttrn, _e = _station(["validate", "truth.json", *files, "--json"], tmp)
        row["model_json"] = Path(tmp, "m.json").read_text()
        model = MdofModel.from_json(row["model_json"])
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    row["cpu_s"] = round(c1.ru_utime + c1.ru_stime - c0.ru_utime - c0.ru_stime, 1)
    row.update(cause=obj["cause"], coordinates=obj["coordinates"], kept=model.notes.split(";")[0][:90])
    if val is None:
        row["validate"] = f"(validate exit {rc_v}) {err_v.strip()[-200:]}"
        return row
    row["held"] = {c: round(v, 4) for c, v in val["channel_nrmse"].items()}
    row["true_held"] = {c: round(v, 4) for c, v in tval["channel_nrmse"].items()} if tval else {}
    # each channel's prediction floor on the held-out captures (station.mdof_floor), the truth's: what
    # the measurement allows any model (acceleration noise, and the impulse's uncertainty carried through)
    row["floor"] = {c: round(v, 4) for c, v in tval["channel_floor"].items()} if tval else {}
    row["train"] = {c: round(v, 4) for c, v in trn["channel_nrmse"].items()} if trn else {}
    row["true_train"] = {c: round(v, 4) for c, v in ttrn["channel_nrmse"].items()} if ttrn else {}
    row["f_err"] = [round(e, 4) for e in frequency_errors(truth, model)]
    proj = np.linalg.pinv(model.phi)
    amp = np.max(np.hstack([np.abs(proj @ r.truth_x) for r in train]), axis=1)
    row["k_err"] = {t: round(e, 4) for t, e in coefficient_errors(truth, model, amp).items()}
    return row


def verdict(row: dict) -> dict:
    """PASS / FAIL per criterion (None where the row has no figure)."""
    if "held" not in row:
        return {"nrmse": False, "freq": False, "coef": False, "all": False, "reachable": False}
    out = {"nrmse": max(row["held"].values()) <= LIMIT_NRMSE, "freq": max(row["f_err"]) <= LIMIT_REL,
           "coef": max(row["k_err"].values(), default=0.0) <= LIMIT_REL}
    out["all"] = all(out.values())
    # the same with the channels no model can meet excluded (their floor above the limit; scored on the rest)
    reach = [v for c, v in row["held"].items() if row.get("floor", {}).get(c, 0.0) <= LIMIT_NRMSE]
    out["reachable"] = out["freq"] and out["coef"] and max(reach, default=0.0) <= LIMIT_NRMSE
    return out


def show(row: dict) -> None:
    print(f"{row['name']}: {row['form']} m {row['masses_kg']} kg | modes {row['modes_hz']} Hz | {row['rate_hz']:g} Hz "
          f"3x{row['record_s']} s | blows {row['blows_n']} N at mass {row['drive']} | {row['snr_db']} dB"
          + (f" | share {row['share']}" if row.get("share") else ""), flush=True)
    if "cause" not in row:
        return
    if "held" not in row:
        print(f"    -> {row['cause']} {row.get('validate', '')} FAIL", flush=True)
        return
    v = verdict(row)
    tag = {True: "ok", False: "FAIL"}
    worst_k = max(row["k_err"].items(), key=lambda kv: kv[1], default=("-", 0.0))
    print(f"    -> {row['cause']} ({row['coordinates']}; {row['kept']}) CPU {row['cpu_s']} s", flush=True)
    print(f"       held-out nrmse {row['held']} (true model {row['true_held']}) {tag[v['nrmse']]}; "
          f"f err {[f'{100 * e:.2f}%' for e in row['f_err']]} {tag[v['freq']]}; "
          f"coef worst {worst_k[0]} {100 * worst_k[1]:.1f}% of {len(row['k_err'])} {tag[v['coef']]} "
          f"=> {'PASS' if v['all'] else 'FAIL'}", flush=True)
    print(f"       training nrmse {row.get('train')} (true model {row.get('true_train')})", flush=True)
    print(f"       held-out floor {row.get('floor')} (channels above {LIMIT_NRMSE} excluded: "
          f"{'PASS' if v['reachable'] else 'FAIL'})", flush=True)


def table(rows: list[dict]) -> None:
    print("\n| case | form | verdict | worst channel (true) | worst f err | worst coef err | nrmse | f | coef | all |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        v = verdict(r)
        if "held" in r:
            c = max(r["held"], key=r["held"].get)
            ch = f"{c} {r['held'][c]:.4f} ({r['true_held'].get(c, float('nan')):.4f})"
            fe = f"{100 * max(r['f_err']):.2f} %"
            ke = f"{100 * max(r['k_err'].values(), default=0.0):.1f} %"
        else:
            ch, fe, ke = r.get("validate", r.get("cause", "?"))[:60], "-", "-"
        p = {True: "PASS", False: "FAIL"}
        print(f"| {r['name']} | {r['form']} | {r.get('cause', '-')} | {ch} | {fe} | {ke} | {p[v['nrmse']]} | "
              f"{p[v['freq']]} | {p[v['coef']]} | **{p[v['all']]}** |")
    n = sum(verdict(r)["all"] for r in rows)
    m = sum(verdict(r)["reachable"] for r in rows)
    print(f"\n{n}/{len(rows)} PASS ({m}/{len(rows)} on the channels whose floor allows {LIMIT_NRMSE}); CPU {sum(r.get('cpu_s', 0) for r in rows):.0f} s; "
          f"load average {os.getloadavg()[0]:.1f}", flush=True)


def cases(args) -> list[Case]:
    if args.set == "rig":
        return [rig_case(n) for n in (args.cases.split(",") if args.cases else RIG)]
    seed = args.seed if args.seed is not None else (1 if args.set == "tuning" else 2)
    first = 0 if args.set == "tuning" else 1
    idx = [int(x) for x in args.cases.split(",")] if args.cases else list(range(first, 2 * args.n, 2))
    return [draw(i, seed) for i in idx]


def _one(job):
    case, refine = job
    return run(case, refine)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", choices=("rig", "tuning", "heldout"), default="rig")
    ap.add_argument("--seed", type=int, default=None, help="family seed (tuning 1, heldout 2)")
    ap.add_argument("--n", type=int, default=5, help="cases in a family set (default 5)")
    ap.add_argument("--cases", default="", help="comma-separated indices (or rig system names)")
    ap.add_argument("--jobs", type=int, default=1, help="cases in parallel (at most 2 on this machine)")
    ap.add_argument("--no-refine", action="store_true", help="diagnose without the polish (not the CLI default)")
    ap.add_argument("--snr", type=float, default=None, help="every case at this SNR in dB (the issue's 45)")
    ap.add_argument("--list", action="store_true", help="print the cases only")
    ap.add_argument("--json", help="write the rows to this JSON file")
    args = ap.parse_args(argv)
    if args.n < 1 or not 1 <= args.jobs <= 2:
        ap.error("--n: expected >= 1; --jobs: 1 or 2")
    try:
        todo = cases(args)
        if args.snr is not None:
            from dataclasses import replace

            todo = [replace(c, snr=args.snr, info={**c.info, "snr_db": args.snr}) for c in todo]
    except ValueError as exc:
        ap.error(f"--cases: {exc}")
    if args.list:
        for c in todo:
            show({"name": c.name, **c.info})
        return 0
    t0 = time.time()
    jobs = [(c, not args.no_refine) for c in todo]
    rows = []
    if args.jobs > 1:
        from multiprocessing import get_context

        with get_context("fork").Pool(args.jobs) as pool:
            for row in pool.imap(_one, jobs):
                show(row)
                rows.append(row)
    else:
        for job in jobs:
            row = _one(job)
            show(row)
            rows.append(row)
    table(rows)
    print(f"wall {time.time() - t0:.0f} s", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
