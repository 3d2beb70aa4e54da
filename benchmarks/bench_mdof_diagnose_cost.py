"""Cost of ``station diagnose`` on multi-channel captures with long, fast-sampled records.

For each system (``benchmarks/mdof_speed/*.toml`` by default: two- and three-mass chains with
a cubic coupling spring, 5-20 kHz, 5-12 s, 3-5 captures, 45 dB, accelerometers only, no mass
given) the captures are written as CSV and ``station diagnose FILES --json --save-model M``
(default ``--refine``) runs in this process. Printed per system:

* ``floor``: CPU seconds of one plain simulation of every capture with the TRUE model at the
  record's rate (:func:`eddi.mdof.simulate.simulate_mdof`, as the rig made them), measured in
  the same run; the diagnose's CPU (this process and forked fold workers) and wall, and the
  ratio CPU / floor;
* the verdict, the baseline / coupled held-out nrmse (leave-one-capture-out folds), the notes
  that say where the diagnosis worked at a reduced rate;
* the saved model's nrmse on a FRESH capture (another blow size and noise seed, not among the
  diagnosed ones) and the true model's on the same capture (what the measurement allows).

``--profile N`` prints the N most expensive functions (cProfile, CPU clock; use with
``STATION_SERIAL=1`` so the folds run in this process).

    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_diagnose_cost.py
    PYTHONPATH=. python benchmarks/bench_mdof_diagnose_cost.py --systems benchmarks/mdof_speed/tune-two-mass-5k.toml --profile 30
    PYTHONPATH=. python benchmarks/bench_mdof_diagnose_cost.py --keep-rate --no-refine   # the same at the captures' rate
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import resource
import tempfile
import time
from pathlib import Path

DEFAULT = ("benchmarks/mdof_speed/tune-three-mass-10k.toml,benchmarks/mdof_speed/tune-two-mass-5k.toml,"
           "benchmarks/mdof_speed/heldout-three-mass-20k.toml,benchmarks/mdof_speed/heldout-two-mass-16k.toml")


def _cpu() -> float:
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


def _floor(records, tip: str) -> float:
    """CPU seconds of one plain simulation of every capture (true model, record rate)."""
    from eddi.mdof.simulate import simulate_mdof
    from simulated_rig.mdof_systems import _amplitude_guess
    from simulated_rig.hammer import HammerSpec

    start = time.process_time()
    for rec in records:
        simulate_mdof(rec.model, rec.t, rec.force_n,
                      x_scale=_amplitude_guess(rec.model, rec.peak_force_n, HammerSpec(tip=tip)))
    return time.process_time() - start


def _run(argv: list[str], profile: int) -> tuple[int, str, str]:
    from station.cli import main

    out, err = io.StringIO(), io.StringIO()
    prof = None
    if profile:
        import cProfile

        prof = cProfile.Profile(time.process_time)
        prof.enable()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    if prof is not None:
        import pstats

        prof.disable()
        pstats.Stats(prof).sort_stats("cumulative").print_stats(profile)
    return code, out.getvalue(), err.getvalue()


def _one(path: str, args: argparse.Namespace, tmp: Path) -> None:
    from eddi.mdof.validate import validate_mdof
    from eddi.mdof.model import MdofModel
    from simulated_rig.mdof_systems import load_mdof_system, mdof_impact_test
    from station.mdof_data import condition_all
    from station.session import read_measurement

    system = load_mdof_system(path)
    recs = [mdof_impact_test(system, p, seed=args.seed + k, snr_db=args.snr_db) for k, p in enumerate(system.impacts_n)]
    files = [str(r.write_csv(tmp / f"{system.name}-c{k}.csv")) for k, r in enumerate(recs)]
    fresh_peak = 0.6 * max(system.impacts_n)
    fresh = mdof_impact_test(system, fresh_peak, seed=args.seed + 100, snr_db=args.snr_db)
    fresh_file = str(fresh.write_csv(tmp / f"{system.name}-fresh.csv"))
    floor = _floor(recs, system.tip)
    model_path = tmp / f"{system.name}-model.json"
    argv = (["diagnose", *files, "--json", "--save-model", str(model_path)] + ([] if args.refine else ["--no-refine"])
            + ([] if system.driving_point == 1 else ["--driving-point", f"acc{system.driving_point}"]))  # CSV holds none
    c0, w0 = _cpu(), time.perf_counter()
    code, out, err = _run(argv, args.profile)
    cpu, wall = _cpu() - c0, time.perf_counter() - w0
    n = recs[0].t.size
    print(f"{system.name}: {len(files)} captures x {n} samples ({n / system.rate_hz:.1f} s at {system.rate_hz:g} Hz), "
          f"{len(system.masses_kg)} masses")
    if code not in (0, 1):
        print(f"  diagnose exit {code}: {err.strip()[-400:]}")
        return
    obj = json.loads(out)
    num = lambda x: float("nan") if x is None else float(x)  # noqa: E731 - JSON null is a non-finite value
    print(f"  diagnose cpu {cpu:7.1f} s  wall {wall:7.1f} s  floor {floor:6.2f} s  cpu/floor {cpu / max(floor, 1e-9):6.1f}"
          f"  exit {code}")
    print(f"  cause {obj['cause']}  gain {num(obj['gain']):.4f}  baseline {num(obj['baseline']['nrmse']):.5f} "
          f"{[round(num(x), 5) for x in obj['baseline']['folds']]}  coupled {num(obj['coupled']['nrmse']):.5f} "
          f"{[round(num(x), 5) for x in obj['coupled']['folds']]}  polished {obj.get('polished_folds')}")
    for w in obj.get("warnings", []):
        print(f"  warning: {w}")
    for note in obj["notes"]:
        if "rate" in note or "decimat" in note or "budget" in note:
            print(f"  note: {note}")
    for line in err.strip().splitlines():
        print(f"  stderr: {line}")
    records, _names, _dp = condition_all([read_measurement(fresh_file)], f"acc{system.driving_point}")
    model = MdofModel.from_json(model_path.read_text())
    got = validate_mdof(model, records[0])
    truth = validate_mdof(fresh.model, records[0])
    print(f"  fresh capture {fresh_peak:g} N: saved model nrmse {got.nrmse:.5f} "
          f"{ {c: round(v, 5) for c, v in got.channel_nrmse.items()} }  true model {truth.nrmse:.5f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--systems", default=DEFAULT, help="comma-separated system TOML files")
    ap.add_argument("--snr-db", type=float, default=45.0)
    ap.add_argument("--seed", type=int, default=10, help="noise seed of the first capture (then +1, +2, ...)")
    ap.add_argument("--no-refine", dest="refine", action="store_false", help="diagnose with --no-refine")
    ap.add_argument("--profile", type=int, default=0, help="print the N most expensive functions (cProfile)")
    ap.add_argument("--keep-rate", action="store_true",
                    help="diagnose at the captures' own rate (no working-rate reduction: the comparison run)")
    args = ap.parse_args(argv)
    if args.keep_rate:
        import eddi.mdof.rate as rate

        rate.SAMPLES_PER_PERIOD = rate.MIN_SAMPLES_PER_PERIOD = float("inf")
        rate.MAX_SAMPLES = 1 << 62
    with tempfile.TemporaryDirectory() as tmp:
        for path in args.systems.split(","):
            _one(path.strip(), args, Path(tmp))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
