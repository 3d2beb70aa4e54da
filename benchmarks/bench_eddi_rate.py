"""EDDI's working rate: coefficients and CPU at two values of ``eddi.calculus.DECIMATE_H_OMEGA``.

The pipeline runs EDDI (phase one and both phase-two routes) on a decimated copy of a densely
sampled free response (:func:`eddi.calculus.decimate_centred`: ``x, v`` at every ``q``-th
sample, the acceleration from curvature-corrected block means), ``q`` the largest odd factor
with ``omega_max q dt <= DECIMATE_H_OMEGA`` (``omega_max`` a 1.5x bound on the fastest local
angular frequency). This benchmark simulates a set of impact records (the half-sine hammer of
``tests/eddi/impact_cases.py``, force + accelerometer, white noise, 24-bit), identifies each with
the pipeline (its own terms; refinement tried, as ``station identify``) at ``--before`` and at
``--after`` in the same process, and prints, per record and over the set:

* the largest change of a **returned** coefficient in units of its 95 % half width (the
  ``before`` run's ``ci95``), and of **EDDI's** estimate (printed in ``refinement``, the answer
  when the refinement is rejected) in the same units and in those of EDDI's own interval
  (:func:`eddi.refine.bounded_intervals`: ``|EDDI - fit| + ci95``, what is printed when EDDI's
  estimate is returned);
* whether the route, the refinement's decision or the returned terms changed;
* the coverage of the truth by ``ci95`` before and after (``|c - c_true| <= ci95``);
* the CPU of the fit (``Pipeline.fit``, conditioning excluded) after / before.

The set (``--cases``, default 48; a seeded draw, reproducible): masses 0.01-1000 kg
(log-uniform), natural frequencies 2-500 Hz, rates 2-40 kHz (records with fewer than 20
samples a cycle are redrawn), 30-60 dB, damping 0.5-3 %, and one of five kinds: hardening
(``x^3``), softening (``x^3 < 0``), asymmetric (``x^2`` + ``x^3``), dry friction (``sign(v)``)
and quadratic drag (``abs(v)*v``). Even case numbers are the **tuning** half, odd ones the
**held-out** half (printed apart; decide on the tuning half, confirm on the other).

Run: ``python benchmarks/bench_eddi_rate.py [--cases 48] [--before 0.1] [--after 0.2] [--jobs 2]``
(a few seconds a case). Test-free: it only prints.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):  # one BLAS thread, as the CLI
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

KINDS = ("hard", "soft", "asym", "friction", "drag")
RATES = (2_000.0, 5_000.0, 10_000.0, 20_000.0, 40_000.0)


def draw_case(i: int, seed: int = 2026) -> dict:
    """Case ``i`` of the set: a system, its record's sampling and noise (reproducible)."""
    rng = np.random.default_rng([seed, i])
    kind = KINDS[i % len(KINDS)]
    while True:
        mass = float(10 ** rng.uniform(-2, 3))
        f0 = float(10 ** rng.uniform(math.log10(2.0), math.log10(500.0)))
        rate = float(rng.choice(RATES))
        if rate / f0 >= 20:
            break
    zeta = float(rng.uniform(0.005, 0.03))
    w0 = 2 * math.pi * f0
    k1, b1 = mass * w0**2, 2 * zeta * mass * w0
    x0 = 1e-3  # first peak [m] (the coefficients scale with it; the physics does not)
    damping, stiffness = {"v": b1}, {"x": k1}
    if kind == "hard":
        stiffness["x^3"] = float(rng.uniform(0.3, 1.0)) * k1 / x0**2
    elif kind == "soft":
        stiffness["x^3"] = -float(rng.uniform(0.1, 0.2)) * k1 / x0**2
    elif kind == "asym":
        stiffness["x^2"] = float(rng.uniform(0.1, 0.25)) * k1 / x0
        stiffness["x^3"] = float(rng.uniform(0.2, 0.5)) * k1 / x0**2
    elif kind == "friction":
        damping["sign(v)"] = float(rng.uniform(0.002, 0.006)) * k1 * x0
    else:
        damping["abs(v)*v"] = float(rng.uniform(1.0, 3.0)) * b1 / (w0 * x0)
    pulse = min(1e-3, 0.2 / f0)
    peak = mass * w0 * x0 * math.pi / (2 * pulse)  # impulse ~ m v0, v0 ~ w0 x0
    # ring down to ~ -50 dB (or 40 cycles of friction), at most 600k samples
    decay = 8.0 / (zeta * w0)
    duration = 0.2 + float(min(max(decay, 40.0 / f0), 600_000 / rate, 30.0))  # after a 0.2 s pre-trigger
    return dict(i=i, kind=kind, mass=mass, f0=f0, rate=rate, zeta=zeta, snr=float(rng.uniform(30, 60)),
                damping=damping, stiffness=stiffness, peak_n=peak, pulse=pulse, duration=duration,
                half="tuning" if i % 2 == 0 else "held-out")


def _fit(case: dict, h_omega: float, rec) -> tuple:
    import eddi.calculus as ec
    from eddi.fit_record import Pipeline

    ec.DECIMATE_H_OMEGA = h_omega
    pipe = Pipeline(damping=tuple(case["damping"]), stiffness=tuple(case["stiffness"]))
    cond = pipe.condition(rec.t, acc=rec.acc, force=rec.force)
    c0 = time.process_time()
    res = pipe.fit(cond, case["mass"])
    cpu = time.process_time() - c0
    return res, cpu


def run_case(args: tuple[dict, float, float]) -> dict:
    """Both fits of one case, and what moved."""
    case, before, after = args
    from tests.eddi.impact_cases import impact_record

    out = dict(case)
    try:
        rec = impact_record(case, rate_hz=case["rate"], duration_s=case["duration"], pretrigger_s=0.2,
                            pulse_s=case["pulse"], snr_db=case["snr"], seed=case["i"])
        (r0, cpu0), (r1, cpu1) = _fit(case, before, rec), _fit(case, after, rec)
        (r0, cpu0b), (r1, cpu1b) = _fit(case, before, rec), _fit(case, after, rec)  # warm, best of 2
    except Exception as exc:  # noqa: BLE001 (a benchmark row, not a crash)
        out["error"] = f"{type(exc).__name__}: {exc}"
        return out
    moved, moved_eddi, moved_own, cover0, cover1 = 0.0, 0.0, 0.0, 0, 0
    err_eddi: tuple[list, list] = ([], [])
    n_true = 0
    e0 = r0.model.unrefined or r0.model.eom
    e1 = r1.model.unrefined or r1.model.eom
    for group in ("damping", "stiffness"):
        g0, g1 = getattr(r0.model.eom, group), getattr(r1.model.eom, group)
        for term, c_true in case[group].items():
            half = r0.ci95.get(group, {}).get(term, math.nan)
            n_true += 1
            if term in g0 and term in g1 and half > 0:
                moved = max(moved, abs(g1[term] - g0[term]) / half)
            else:
                moved = max(moved, math.inf if (term in g0) != (term in g1) else 0.0)
            ee0, ee1 = getattr(e0, group).get(term), getattr(e1, group).get(term)
            h1 = r1.ci95.get(group, {}).get(term, math.nan)
            if ee0 is not None and ee1 is not None and half > 0:
                moved_eddi = max(moved_eddi, abs(ee1 - ee0) / half)
                # in EDDI's own interval (eddi.refine.bounded_intervals: |EDDI - fit| + the fit's)
                own = abs(ee0 - g0[term]) + half if term in g0 else math.inf
                moved_own = max(moved_own, abs(ee1 - ee0) / own)
                # EDDI's error against the truth in its own interval, before and after
                err_eddi[0].append(abs(ee0 - c_true) / own)
                own1 = abs(ee1 - g1[term]) + h1 if term in g1 else math.inf
                err_eddi[1].append(abs(ee1 - c_true) / own1)
            cover0 += int(term in g0 and abs(g0[term] - c_true) <= half)
            cover1 += int(term in g1 and abs(g1[term] - c_true) <= h1)
    out.update(q0=r0.choices.decimation, q1=r1.choices.decimation, moved=moved, moved_eddi=moved_eddi, moved_own=moved_own, err_eddi=err_eddi,
               route=(r0.choices.route, r1.choices.route), refinement=(r0.choices.refinement, r1.choices.refinement),
               cover=(cover0, cover1), n_true=n_true, cpu=(min(cpu0, cpu0b), min(cpu1, cpu1b)),
               nrmse=(r0.validation.nrmse, r1.validation.nrmse))
    return out


def _line(r: dict) -> str:
    head = (f"{r['i']:3d} {r['half']:8s} {r['kind']:8s} m {r['mass']:9.3g} kg f0 {r['f0']:6.1f} Hz "
            f"{r['rate'] / 1000:4.0f} kHz {r['snr']:4.1f} dB")
    if "error" in r:
        return head + f"  ERROR {r['error']}"
    flags = []
    if r["route"][0] != r["route"][1]:
        flags.append(f"route {r['route'][0]}->{r['route'][1]}")
    if r["refinement"][0] != r["refinement"][1]:
        flags.append(f"refinement {r['refinement'][0]}->{r['refinement'][1]}")
    return (head + f"  q {r['q0']:3d}->{r['q1']:3d}  returned {r['moved']:.3g} ci95, EDDI {r['moved_eddi']:.3g} ci95 ({r['moved_own']:.3g} of its own)"
            f"  covers {r['cover'][0]}/{r['n_true']}->{r['cover'][1]}/{r['n_true']}"
            f"  cpu {1000 * r['cpu'][0]:6.1f}->{1000 * r['cpu'][1]:6.1f} ms  {' '.join(flags)}")


def _summary(rows: list[dict], label: str) -> None:
    ok = [r for r in rows if "error" not in r]
    dec = [r for r in ok if r["q0"] != r["q1"]]
    if not ok:
        print(f"{label}: no rows")
        return
    mv = np.array([r["moved"] for r in dec]) if dec else np.zeros(0)
    me = np.array([r["moved_eddi"] for r in dec]) if dec else np.zeros(0)
    mo = np.array([r["moved_own"] for r in dec]) if dec else np.zeros(0)
    c0 = sum(r["cover"][0] for r in ok)
    c1 = sum(r["cover"][1] for r in ok)
    n = sum(r["n_true"] for r in ok)
    cpu = [r["cpu"][1] / r["cpu"][0] for r in dec]
    e0 = np.array([e for r in dec for e in r["err_eddi"][0]])
    e1 = np.array([e for r in dec for e in r["err_eddi"][1]])
    print(f"{label}: {len(ok)} records ({len(rows) - len(ok)} errors), {len(dec)} with another q"
          + (f"; returned coefficients moved median {np.median(mv):.3g} / max {np.max(mv):.3g} ci95; "
             f"EDDI's median {np.median(me):.3g} / max {np.max(me):.3g} ci95 (of its own interval, "
             f"|EDDI - fit| + ci95: median {np.median(mo):.3g} / max {np.max(mo):.3g}); fit CPU after/before median "
             f"{np.median(cpu):.2f} (min {min(cpu):.2f}, max {max(cpu):.2f}); EDDI's error / its own interval "
             f"(those records) mean {np.mean(e0):.3f} -> {np.mean(e1):.3f}, covers {int(np.sum(e0 <= 1))}/{e0.size} -> "
             f"{int(np.sum(e1 <= 1))}/{e1.size}" if dec else "")
          + f"; ci95 covers {c0}/{n} -> {c1}/{n}; route changed {sum(r['route'][0] != r['route'][1] for r in ok)}, "
          f"refinement decision changed {sum(r['refinement'][0] != r['refinement'][1] for r in ok)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", type=int, default=48, help="records in the set (default 48; even = tuning, odd = held out)")
    ap.add_argument("--before", type=float, default=0.1, help="DECIMATE_H_OMEGA before (default 0.1)")
    ap.add_argument("--after", type=float, default=0.2, help="DECIMATE_H_OMEGA after (default 0.2)")
    ap.add_argument("--jobs", type=int, default=1, help="processes (default 1; at most 2 on a shared 2-core box)")
    ap.add_argument("--only", choices=("tuning", "held-out"), help="one half of the set")
    a = ap.parse_args()
    cases = [draw_case(i) for i in range(a.cases)]
    if a.only:
        cases = [c for c in cases if c["half"] == a.only]
    work = [(c, a.before, a.after) for c in cases]
    print(f"DECIMATE_H_OMEGA {a.before} -> {a.after}, {len(cases)} records, load average {os.getloadavg()[0]:.1f}")
    if a.jobs > 1:
        import multiprocessing as mp

        with mp.get_context("fork").Pool(a.jobs) as pool:
            rows = []
            for r in pool.imap(run_case, work):
                print(_line(r), flush=True)
                rows.append(r)
    else:
        rows = []
        for w in work:
            r = run_case(w)
            print(_line(r), flush=True)
            rows.append(r)
    for half in ("tuning", "held-out"):
        _summary([r for r in rows if r["half"] == half], half)
    print(f"load average now {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
