"""Wall time of ``station identify`` on a 45 s, 19.2 kHz force + acceleration record.

Writes the record (the simulated rig's ``duffing-smooth`` system, paper Sec. 3.3.1: 45 s
after a 1 s pre-trigger at 19200 Hz, 600 N blow, 45 dB) to a temporary CSV and times the
CLI end to end in a fresh process (interpreter start, imports, CSV read, conditioning,
identification with ``--route auto``, validation by simulation):

* **cold**: numba's on-disk cache in a fresh, empty directory (``NUMBA_CACHE_DIR``), so the
  compiled kernels (RK4) are compiled in that run, as on the first run after installation,
  unless they were built ahead of time (``python -m eddi.kernels``; the first line says which);
* **warm**: the same cache directory again, ``--runs`` times; minimum and median are printed
  (the machine may be shared: the minimum is the best estimate of an unloaded machine, the
  CPU time (user + sys of the child) is printed too).

Then an in-process breakdown (best of ``--runs``): CSV read, conditioning, identification,
validation. Target (engine issue): < 2 s wall on a 2-core machine, validation included.

In-process speed (``--in-process`` runs only this part; issue 13 target <= 50 ms): the library
call on arrays already in memory (:func:`station.commands.identify.run_identify` on a
:class:`~station.readers.Measurement`: conditioning, identification, validation), min and
median of ``--runs``, printed as ratios to

* the floor: ``np.load`` of the same three columns from a ``.npy`` file plus one numpy pass
  over them (``np.abs(a).sum(axis=0)``): reading and touching the data once;
* pysindy (STLSQ, :func:`eddi.sindy.sindy_identify`) on the same conditioned signals and
  the same candidate terms (regression only: no conditioning, no validation);

both with ``--no-refine`` and with the default (the output-error refinement tried, kept
when it helps; ``--refine-runs`` of them, default 2: each is seconds), and with ``--profile``
the top functions of a cProfile of one ``--no-refine`` call (cumulative time).

``--stages`` (with ``--in-process``): where the library call's CPU goes, stage by stage
(conditioning, EDDI phase one, each phase-two route with its slow-error refits, the
output-error refinement, the validation simulations, the refinement's judge, the model
checks), each as a share of the call and as a ratio to the floor, best of ``--runs`` calls
with the refinement. The stages are timed by wrapping those functions in this process
(``time.process_time``); nested stages are listed under their parent.

Run: ``python benchmarks/bench_identify_speed.py [--runs 5] [--in-process [--stages]] [--profile]``
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):  # one BLAS thread, as the CLI
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402 (after the BLAS thread count)

from simulated_rig.bench import impact_test  # noqa: E402

ARGS = ["--mass", "0.815", "--damping", "v,x^2*v,v^3", "--stiffness", "x,x^2,x^3,x^4,x^5", "--json"]


def _run_cli(path: Path, cache_dir: str) -> tuple[float, float, str]:
    cmd = [sys.executable, "-m", "station.cli", "identify", str(path), *ARGS]
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True, check=True, env=env).stdout
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, out.split('"nrmse": ')[1].split(",")[0]


def _kernels_source() -> str:
    """How this checkout runs the simulator's kernels: built ahead of time or numba's JIT
    (``eddi.kernels``; ``python -m eddi.kernels`` builds them, ``EDDI_JIT=1`` ignores them)."""
    import importlib

    k = importlib.import_module("eddi.simulate")._KERNELS
    k._load()
    return k.source


def _stats(xs: list[float]) -> str:
    return f"min {1000 * min(xs):7.1f} ms, median {1000 * statistics.median(xs):7.1f} ms"


def in_process(rec, runs: int, profile: bool, refine_runs: int = 2, by_stage: bool = False) -> None:
    """Library call on arrays vs the floor (np.load + one pass) and pysindy on the same data."""
    from eddi.sindy import sindy_identify
    from station.commands.identify import run_identify
    from station.readers import Measurement

    damping, stiffness = "v,x^2*v,v^3", "x,x^2,x^3,x^4,x^5"
    meas = Measurement(t=rec.t, channels={"force": rec.force_n, "acc": rec.acc_m_s2}, rate_hz=rec.rate_hz,
                       pretrigger_samples=rec.pretrigger_samples, mass=0.815, source="memory")
    with tempfile.TemporaryDirectory() as tmp:
        npy = Path(tmp) / "record.npy"
        np.save(npy, np.column_stack((rec.t, rec.force_n, rec.acc_m_s2)))
        floor, plain, refined, sindy = [], [], [], []
        res = run_identify(meas, 0.815, damping, stiffness, refine=False)  # warm: imports and JIT
        cond = res.conditioned
        w0, w1 = cond.window
        cpu0 = time.process_time()
        for i in range(runs):
            t0 = time.perf_counter()
            a = np.load(npy)
            np.abs(a).sum(axis=0)
            t1 = time.perf_counter()
            run_identify(meas, 0.815, damping, stiffness, refine=False)
            t2 = time.perf_counter()
            sindy_identify(cond.t[w0:w1], cond.x[w0:w1], cond.v[w0:w1], cond.a[w0:w1], 0.815, damping, stiffness)
            t3 = time.perf_counter()
            floor.append(t1 - t0)
            plain.append(t2 - t1)
            sindy.append(t3 - t2)
            if i < refine_runs:
                run_identify(meas, 0.815, damping, stiffness)  # the default: refinement tried
                refined.append(time.perf_counter() - t3)
        cpu = time.process_time() - cpu0
    f = min(floor)
    print(f"in process, {runs} runs, {rec.n_samples} samples (load average {os.getloadavg()[0]:.1f}; "
          f"this process got {cpu / sum(floor + plain + refined + sindy):.2f} of a core):")
    print(f"  floor (np.load + one numpy pass)           {_stats(floor)}")
    for name, xs in (("station identify --no-refine, on arrays", plain), ("station identify (default: refine)", refined)):
        if xs:
            print(f"  {name:<42} {_stats(xs)}  = {min(xs) / f:6.1f}x the floor, {min(xs) / min(sindy):5.2f}x pysindy; "
                  "target <= 50 ms: " + ("met" if min(xs) <= 0.050 else f"NOT met ({min(xs) / 0.050:.0f}x over)"))
    print(f"  pysindy STLSQ on the same signals          {_stats(sindy)}  = {min(sindy) / f:6.1f}x the floor "
          f"(regression only, on the {w1 - w0} samples of the free-response window)")
    if by_stage:
        stages(meas, runs)
    if profile:
        import cProfile
        import io
        import pstats

        pr = cProfile.Profile()
        pr.enable()
        run_identify(meas, 0.815, damping, stiffness, refine=False)
        pr.disable()
        out = io.StringIO()
        pstats.Stats(pr, stream=out).sort_stats("cumulative").print_stats(25)
        print(out.getvalue())


#: (module, function, label, depth) of the stages --stages times; depth indents nested stages.
STAGES = (
    ("eddi.conditioning.conditioner", "condition", "conditioning (drift-free integration, windows)", 0),
    ("eddi.identify", "identify", "EDDI (decimated window: phase one + both routes)", 0),
    ("eddi.phase_one", "phase_one", "phase one (energy balance, damping)", 1),
    ("eddi.phase_two", "potential_route", "phase two, potential route", 1),
    ("eddi.phase_two", "lagrangian_route", "phase two, Lagrangian route", 1),
    ("eddi.slow_errors", "refit_with_offset", "slow-error refits (sparse normal equations)", 2),
    ("eddi.refine", "refine_output_error", "output-error refinement (RK4 sensitivity passes)", 0),
    ("eddi.fit_record", "validate_conditioned", "validation simulations (fit record: refined, EDDI)", 0),
    ("eddi.judge", "judge_fit_record", "the refinement's judge on the fit record", 0),
    ("eddi.stability", "model_warnings", "model checks (negative stiffness / damping)", 0),
)


def stages(meas, runs: int) -> None:
    """Print the CPU of each stage of one library call (best of ``runs``) as shares and ratios.

    The floor is CPU too: ``np.load`` of the record's three columns from a ``.npy`` + one pass,
    best of ``runs``, in this process.
    """
    import functools
    import importlib

    from station.commands.identify import run_identify

    spent: dict[str, float] = {}
    patched = []
    for mod_name, fn_name, label, _ in STAGES:
        mod = importlib.import_module(mod_name)
        fn = getattr(mod, fn_name)

        def timed(*a, _fn=fn, _label=label, **k):
            c0 = time.process_time()
            try:
                return _fn(*a, **k)
            finally:
                spent[_label] = spent.get(_label, 0.0) + time.process_time() - c0

        functools.update_wrapper(timed, fn)
        # the function where it is defined and wherever it was imported by name
        for other in list(sys.modules.values()):
            if (getattr(other, "__name__", "").startswith(("eddi.", "station.")) and hasattr(other, "__dict__")
                    and vars(other).get(fn_name) is fn):
                patched.append((other, fn_name, fn))
                setattr(other, fn_name, timed)
    try:
        damping, stiffness = "v,x^2*v,v^3", "x,x^2,x^3,x^4,x^5"
        best: tuple[float, dict[str, float]] | None = None
        for _ in range(runs):
            spent.clear()
            c0 = time.process_time()
            run_identify(meas, 0.815, damping, stiffness)
            total = time.process_time() - c0
            if best is None or total < best[0]:
                best = (total, dict(spent))
    finally:
        for mod, name, fn in patched:
            setattr(mod, name, fn)
    assert best is not None
    total, spent = best
    floors = []
    with tempfile.TemporaryDirectory() as tmp:
        npy = Path(tmp) / "record.npy"
        np.save(npy, np.column_stack((meas.t, meas.channels["force"], meas.channels["acc"])))
        for _ in range(runs):
            c0 = time.process_time()
            np.abs(np.load(npy)).sum(axis=0)
            floors.append(time.process_time() - c0)
    floor_s = min(floors)
    print(f"\nwhere the library call goes (default: refinement tried; best of {runs}, CPU, load average "
          f"{os.getloadavg()[0]:.1f}): {1000 * total:.1f} ms = {total / floor_s:.1f}x the floor "
          f"(np.load + one pass, CPU {1000 * floor_s:.1f} ms)")
    covered = 0.0
    for _, _, label, depth in STAGES:
        dt = spent.get(label, 0.0)
        covered += dt if depth == 0 else 0.0
        print(f"  {'  ' * depth}{label:<{56 - 2 * depth}} {1000 * dt:7.1f} ms {100 * dt / total:5.1f} %  "
              f"{dt / floor_s:5.1f}x the floor")
    rest = total - covered
    print(f"  {'the rest (reading the arrays, result objects, warnings)':<56} {1000 * rest:7.1f} ms "
          f"{100 * rest / total:5.1f} %  {rest / floor_s:5.1f}x the floor")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=5, help="warm runs (default 5)")
    ap.add_argument("--in-process", action="store_true", help="only the in-process part (library call on arrays)")
    ap.add_argument("--profile", action="store_true", help="print a cProfile of one in-process call")
    ap.add_argument("--refine-runs", type=int, default=2, help="in-process runs with the refinement (default 2)")
    ap.add_argument("--stages", action="store_true",
                    help="with --in-process: the CPU of each stage of the library call, as shares and ratios to the floor")
    args = ap.parse_args()
    runs = args.runs
    rec = impact_test("duffing-smooth", 600.0, snr_db=45.0, seed=1)
    if args.in_process:
        in_process(rec, runs, args.profile, args.refine_runs, args.stages)
        return
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "long.csv"
        np.savetxt(path, np.column_stack((rec.t, rec.force_n, rec.acc_m_s2)), delimiter=",",
                   header="t,force,acc", comments="", fmt="%.9g")
        print(f"record: {rec.n_samples} samples ({rec.n_samples / rec.rate_hz:.1f} s at "
              f"{rec.rate_hz:.0f} Hz), {path.stat().st_size / 1e6:.1f} MB CSV; "
              f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; kernels: {_kernels_source()}")
        cache = str(Path(tmp) / "numba-cache")
        wall, cpu, nrmse = _run_cli(path, cache)
        print(f"cold (empty numba cache)   wall {wall:5.2f} s, cpu {cpu:5.2f} s, nrmse {nrmse}")
        walls, cpus = [], []
        for _ in range(runs):
            wall, cpu, nrmse = _run_cli(path, cache)
            walls.append(wall)
            cpus.append(cpu)
        print(f"warm x{runs}: wall min {min(walls):.2f} s, median {statistics.median(walls):.2f} s; "
              f"cpu min {min(cpus):.2f} s, median {statistics.median(cpus):.2f} s "
              f"(load average now {os.getloadavg()[0]:.1f})")

        # in-process breakdown (warm: everything imported and compiled)
        from eddi.conditioning import condition
        from eddi.identify import identify
        from eddi.fit_record import identify_measurement
        from station.readers import read_csv

        best: dict[str, float] = {}
        for _ in range(runs):
            t0 = time.perf_counter()
            meas = read_csv(path)
            t1 = time.perf_counter()
            cond = condition(meas.t, acc=meas.channels["acc"], force=meas.channels["force"])
            t2 = time.perf_counter()
            identify(cond.t, cond.x, cond.v, 0.815, damping="v,x^2*v,v^3",
                     stiffness="x,x^2,x^3,x^4,x^5", a=cond.a, window=cond.window)
            t3 = time.perf_counter()
            identify_measurement(cond, 0.815, damping="v,x^2*v,v^3", stiffness="x,x^2,x^3,x^4,x^5")
            t4 = time.perf_counter()
            for key, dt in (("read CSV", t1 - t0), ("conditioning", t2 - t1), ("identify (auto)", t3 - t2),
                            ("identify + validate", t4 - t3)):
                best[key] = min(best.get(key, float("inf")), dt)
        print("in process, best of", runs, ": " + ", ".join(f"{k} {v:.2f} s" for k, v in best.items()))
    in_process(rec, runs, args.profile, args.refine_runs)


if __name__ == "__main__":
    main()
