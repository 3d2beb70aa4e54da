"""The output-error polish of a three-mass chain's folds, as before and as now, same process (issue 14).

Session 13 (helper s13three) measured ``station diagnose`` of a 1 / 0.5 / 2 kg chain (springs 2e6 /
1e6 / 3e6 N/m, 75 / 268 / 489 Hz, 1 % Rayleigh damping on the first and top mode, a 25 % cubic
spring between masses 2 and 3, struck at mass 2, three 3 s captures at 5 kHz of 300 / 200 / 400 N,
35 dB) at over 1000 s CPU: the coupled folds' per-coordinate models (37-43 coefficients) polished
with forward sensitivities in every coefficient at 18-37 RK4 sub-steps per sample. Session 14
(helper s14three): the sub-steps come from the states met (:func:`eddi.mdof.simulate.trajectory_substeps`)
and the polish frees the frequency terms only (:func:`eddi.mdof.refine.frequency_terms`).

This bench draws that chain (``--write DIR`` also saves the captures for ``station diagnose``),
identifies each leave-one-out fold's coupled model, and polishes it in the same process both ways:
``before`` (every coefficient free, sub-steps from every coordinate's peak at once: the former
``auto_substeps``, scipy's default ``ftol``) and ``now`` (the defaults). Per fold: coefficients
freed, sub-steps per training record, Jacobian runs, CPU seconds, held-out nrmse (unpolished /
before / now); then the CPU ratio before / now.

    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_polish_cost.py [--folds 0,1,2] [--write DIR]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

import eddi.mdof.refine as refine
import eddi.mdof.sensitivity as sensitivity
import eddi.mdof.simulate as simulate
from eddi.mdof.identify import identify_mdof
from eddi.mdof.validate import simulation_start, validate_mdof
from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test

MASSES = (1.0, 0.5, 2.0)
SPRINGS = (2e6, 1e6, 3e6)  # ground-1, 1-2, 2-3 [N/m]
SHARE = 0.25  # the 2-3 cubic's force over the linear spring's at the largest blow


def chain() -> MdofSystem:
    """The chain above, its cubic sized from the linear chain's largest 2-3 stretch."""
    m = np.array(MASSES)
    k = np.array([[SPRINGS[0] + SPRINGS[1], -SPRINGS[1], 0], [-SPRINGS[1], SPRINGS[1] + SPRINGS[2], -SPRINGS[2]],
                  [0, -SPRINGS[2], SPRINGS[2]]])
    w = np.sort(np.sqrt(np.linalg.eigvals(k / m[:, None]).real))
    beta = 2 * 0.01 * (w[-1] - w[0]) / (w[-1] ** 2 - w[0] ** 2)
    alpha = 2 * 0.01 * w[0] - beta * w[0] ** 2
    els = [Element(between=(i, i + 1), k=s, c=beta * s) for i, s in enumerate(SPRINGS)]
    els += [Element(between=(0, i + 1), c=alpha * mi) for i, mi in enumerate(MASSES)]
    lin = MdofSystem(name="polish-cost", masses_kg=MASSES, elements=tuple(els), driving_point=2, rate_hz=5000.0,
                     pretrigger_s=0.05, record_s=3.0, impacts_n=(300.0, 200.0, 400.0), tip="plastic")
    x = mdof_impact_test(lin, 400.0, snr_db=None).truth_x
    k3 = SHARE * SPRINGS[2] / float(np.max(np.abs(x[1] - x[2]))) ** 2
    els[2] = Element(between=(2, 3), k=SPRINGS[2], c=els[2].c, k3=k3)
    return lin.model_copy(update={"elements": tuple(els)})


def _old_count(model, dt, x_scale=None, states=None):
    """The former sub-step rule: every coordinate at its own peak over the states at once."""
    return simulate.auto_substeps(model, dt, np.max(np.abs(states), axis=1) if states is not None else x_scale)


def _polish(model, train, held, mode: str) -> dict:
    runs = []
    plain = sensitivity.predict_sensitivities

    def counted(*a, **kw):
        runs.append(1)
        return plain(*a, **kw)

    now, ftol = simulate.step_count, refine.POLISH_FTOL
    if mode == "before":
        simulate.step_count = sensitivity.step_count = _old_count
        refine.POLISH_FTOL = 1e-8  # scipy's default, which the former polish used
    sensitivity.predict_sensitivities = counted
    try:
        steps = [simulate.step_count(model, float(r.t[1] - r.t[0]), states=simulation_start(model, r).states)
                 for r in train]
        start = time.process_time()
        out, _b, _a = refine.refine_mdof(model, train, free="all" if mode == "before" else None)
        cpu = time.process_time() - start
    finally:
        simulate.step_count = sensitivity.step_count = now
        refine.POLISH_FTOL = ftol
        sensitivity.predict_sensitivities = plain
    return {"cpu_s": round(cpu, 1), "substeps": steps, "jacobian_runs": len(runs),
            "held_nrmse": round(validate_mdof(out, held).nrmse, 4)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--folds", default="0,1,2", help="held-out captures (comma-separated, of 0,1,2)")
    ap.add_argument("--write", help="also write the captures (cap0..2.csv) into this folder")
    args = ap.parse_args(argv)
    try:
        folds = [int(v) for v in args.folds.split(",")]
    except ValueError:
        ap.error("--folds: expected comma-separated integers")
    if not set(folds) <= {0, 1, 2}:
        ap.error("--folds: expected indices among 0, 1, 2")
    from station.mdof_commands import _read
    from station.mdof_data import condition_all

    system = chain()
    out = Path(args.write) if args.write else Path(tempfile.mkdtemp(prefix="polish-cost-"))
    out.mkdir(parents=True, exist_ok=True)
    files = []
    for k, peak in enumerate(system.impacts_n):
        files.append(str(out / f"cap{k}.csv"))
        mdof_impact_test(system, peak, snr_db=35.0, seed=300 + k).write_csv(files[-1])
    records, names, dp = condition_all(_read(files), "acc2")
    total = {"before": 0.0, "now": 0.0}
    for k in folds:
        train = [r for j, r in enumerate(records) if j != k]
        model = identify_mdof(train, names, dp, coupling=True).model
        n_all = sum(len(d) + len(s) for d, s in zip(model.damping, model.stiffness))
        row = {"fold": k, "coordinates": model.coordinates, "coefficients": n_all,
               "freed_now": int(refine.frequency_terms(model).size),
               "held_unpolished": round(validate_mdof(model, records[k]).nrmse, 4)}
        for mode in ("before", "now"):
            row[mode] = _polish(model, train, records[k], mode)
            total[mode] += row[mode]["cpu_s"]
        print(json.dumps(row), flush=True)
    print(f"polish CPU before {total['before']:.1f} s, now {total['now']:.1f} s, "
          f"ratio {total['before'] / max(total['now'], 1e-9):.1f}; captures in {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
