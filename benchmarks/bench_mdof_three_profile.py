"""Where a three-mass ``station diagnose`` spends its CPU: per stage (cProfile) and per candidate.

Session 15 (helper s15three, issue 14). Default captures: session 13's 1 / 0.5 / 2 kg chain
(``bench_mdof_polish_cost.chain``, three 3 s captures at 5 kHz, 35 dB, struck at mass 2), or
``--files`` with ``--driving-point``. Two parts, in this process (``STATION_SERIAL=1`` is set so the
folds run here, where the profiler sees them):

* ``--stages``: the whole ``station diagnose FILES --json`` (CLI defaults, polish on) under cProfile
  with the CPU clock; printed: total CPU, verdict, and the cumulative CPU of the stages (held-out
  folds, fold polish, final model, identification, candidate choice, lumped fit, simulations,
  sensitivities). Cumulative times nest (a stage includes the ones it calls); the profiler adds
  ~25 % to the CPU.
* ``--fold K``: the identification of held-out fold ``K`` alone (no polish), each candidate timed
  (inclusive CPU per call kind: the per-coordinate fits, the lumped fit and its stages, the
  candidate choices, the simulations of validation).

    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_three_profile.py --fold 0
    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_three_profile.py --stages
    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_three_profile.py --stages --before   # session 15's polish

``--before`` (session 16): the polish as it was before the noise stop (:data:`eddi.mdof.refine.NOISE_STOP`
off, :data:`eddi.mdof.refine.BROYDEN_RUN` 0), for a same-run ratio.
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import functools
import io
import json
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

STAGES = ("diagnose_mdof_object", "_held_out_folds", "_fold_fits", "polish_folds", "_final_coupled", "_final_baseline",
          "refine_mdof", "refine_lumped", "identify_mdof", "identify_lumped", "choose_candidate", "training_error",
          "validate_mdof", "simulate_mdof", "predict_sensitivities", "_earned")


def _captures(out: Path) -> list[str]:
    from bench_mdof_polish_cost import chain
    from simulated_rig.mdof_systems import mdof_impact_test

    system = chain()
    files = []
    for k, peak in enumerate(system.impacts_n):
        files.append(str(out / f"cap{k}.csv"))
        mdof_impact_test(system, peak, snr_db=35.0, seed=300 + k).write_csv(files[-1])
    return files


def stages(files: list[str], dp: str) -> None:
    import cProfile
    import pstats

    from station.cli import main

    prof = cProfile.Profile(time.process_time)
    start = time.process_time()
    buf = io.StringIO()
    prof.enable()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
        code = main(["diagnose", *files, "--driving-point", dp, "--json"])
    prof.disable()
    obj = json.loads(buf.getvalue())
    print(f"diagnose: exit {code}, {time.process_time() - start:.1f} s CPU (profiled), cause {obj['cause']}, gain "
          f"{obj['gain']:.3f}, coupled folds {[round(v, 4) for v in obj['coupled']['folds']]}")
    rows = [(ct, nc, name) for (_f, _l, name), (_cc, nc, _tt, ct, _c) in pstats.Stats(prof).stats.items()
            if name in STAGES]
    for ct, nc, name in sorted(rows, reverse=True):
        print(f"  {ct:8.1f} s  {nc:5d} calls  {name}")


def fold(files: list[str], dp: str, k: int) -> None:
    import eddi.mdof.candidates as cand
    import eddi.mdof.identify as ident
    import eddi.mdof.physical as phys
    import eddi.mdof.validate as val
    import station.mdof_commands as mc
    import station.mdof_folds as mf
    from station.mdof_data import condition_all, reduce_rate

    spent: dict[str, float] = collections.defaultdict(float)
    calls: collections.Counter = collections.Counter()

    def timed(mod, name, label):
        f = getattr(mod, name)

        @functools.wraps(f)
        def g(*a, **kw):
            lab, t0 = label(a, kw), time.process_time()
            try:
                return f(*a, **kw)
            finally:
                spent[lab] += time.process_time() - t0
                calls[lab] += 1
        setattr(mod, name, g)

    timed(ident, "_identify_twice", lambda a, kw: f"per-coordinate fit: {a[4]}, coupling {a[5]}, prune {a[8]:.2g}"
          + (", filtered" if kw.get("prefilter") else ""))
    timed(ident, "choose_candidate", lambda a, kw: f"candidate choice among {len(a[0])}")
    timed(mf, "identify_mdof", lambda a, kw: f"identify_mdof {kw.get('coordinates', 'auto')}, "
                                             f"coupling {kw.get('coupling', True)}")
    timed(mf, "validate_mdof", lambda a, kw: "held-out validations")
    for name in ("identify_lumped", "_stages", "_iv_fit", "_slow_fit", "_undetermined_back"):
        timed(phys, name, lambda a, kw, name=name: f"lumped: {name}")
    timed(val, "simulate_mdof", lambda a, kw: "simulations (validate_mdof, all)")
    timed(cand, "training_error", lambda a, kw: "training errors of the choices")
    meas, _note = reduce_rate(mc._read(files))
    records, names, dpn = condition_all(meas, dp)
    start = time.process_time()
    out, _span = mf._fold_fits(records, names, dpn, k)
    print(f"fold {k}: {time.process_time() - start:.1f} s CPU; held out "
          + ", ".join(f"{kind} {v[0].nrmse:.4f} ({v[1].coordinates}{', lumped' if v[1].lumped is not None else ''})"
                      for kind, v in out.items()))
    for lab, s in sorted(spent.items(), key=lambda x: -x[1]):
        print(f"  {s:7.2f} s  {calls[lab]:4d}x  {lab}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--files", nargs="+", help="captures (default: the chain above, written to a temp folder)")
    ap.add_argument("--driving-point", default="acc2")
    ap.add_argument("--stages", action="store_true", help="profile the whole diagnose")
    ap.add_argument("--fold", type=int, help="time the candidates of this held-out fold's identification")
    ap.add_argument("--before", action="store_true",
                    help="the polish before session 16 (no noise stop; run beside the default for a same-run ratio)")
    args = ap.parse_args(argv)
    if args.before:
        import eddi.mdof.refine as refine

        refine.NOISE_STOP, refine.BROYDEN_RUN = False, 0
    if not args.stages and args.fold is None:
        ap.error("give --stages and/or --fold K")
    os.environ["STATION_SERIAL"] = "1"
    files = args.files or _captures(Path(tempfile.mkdtemp(prefix="three-profile-")))
    if args.fold is not None:
        if not 0 <= args.fold < len(files):
            ap.error(f"--fold: expected 0..{len(files) - 1}")
        fold(files, args.driving_point, args.fold)
    if args.stages:
        stages(files, args.driving_point)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
