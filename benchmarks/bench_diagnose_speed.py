"""Diagnosis speed as ratios to a floor measured in the same run (issue 13 item 2).

Two cases:

* ``three``: three 6 s captures at 10 kHz of the 12.3 Hz test system with a hidden clearance
  (the simulated rig, acceleration-only chain at 45 dB; made before timing starts);
* ``beam``: the nine real double-beam ring-downs (``/work/shared/data/resonant-double-beam``
  or ``tests/data/resonant-double-beam``; velocity at 5120 Hz, no force).

For each, the **floor** is reading and conditioning the same records (what any analysis of
them must pay: ``condition`` on the arrays for ``three``, CSV read + conditioning for
``beam``); the diagnosis is :func:`eddi.diagnosis.diagnose` on the conditioned records
(library call, default catalogue). Printed: min and median wall time over ``--runs``, the
process CPU time, the ratio to the floor, and the 1-minute load average before and after.
Targets (issue 13): ``three`` <= 3 s, ``beam`` <= 8 s on a quiet 2-core machine.

    python benchmarks/bench_diagnose_speed.py                  # both cases, 3 runs each
    python benchmarks/bench_diagnose_speed.py --case three --runs 1 --profile 25
    python benchmarks/bench_diagnose_speed.py --case cli --runs 3    # whole processes, wall + CPU
    git worktree add /tmp/before HEAD~3    # then, whole processes from both trees, interleaved:
    python benchmarks/bench_diagnose_speed.py --case cli --runs 3 --before /tmp/before

    python benchmarks/bench_diagnose_speed.py --case estimate   # quiet 2-core wall, modelled
    python benchmarks/bench_diagnose_speed.py --case estimate --runs 3 --before /tmp/before

``--case estimate``: each ``station diagnose`` runs once in one process with every item of every
fork map timed (CPU); the wall time on ``--jobs`` idle cores is modelled as the CPU outside the
maps plus, per map, the time ``jobs`` processes take to share its items the way
:class:`station.forkmap.ForkMap` hands them out (item ``k < jobs`` to process ``k``, then each
item to the first process free). This is the quiet-machine figure the targets speak of, from
CPU measured at whatever load (CPU rises with the load too: read it as an upper bound), and the
same model with the items dealt round robin (how ForkMap shared them before session 8). The
maps are made for ``--jobs`` processes (``STATION_JOBS``; their items still run in turn, timed):
work a forking map computes beside the rest (the forward term selection's start) is counted
as it runs, and so are the jobs queued with :meth:`station.forkmap.ForkMap.beside` (taken, as
ForkMap takes them, by a process with no item left while another still runs one). With ``--before TREE`` each of ``--runs`` rounds also runs from that checkout,
interleaved (alternating which goes first), and the medians' ratio and the JSON's sameness are printed.

``--case cli``: whole ``station diagnose`` processes (imports, reading, conditioning, the
pipeline baseline, the diagnosis). CPU is the process's and its forked workers'. Each case
runs twice per round: in one process (``STATION_SERIAL=1``) and with the folds in ``--jobs``
processes (``STATION_JOBS``, :mod:`station.forkmap`; the same JSON bit for bit, checked here).
``--jobs`` also gives the library call a :class:`station.forkmap.ForkMap` (default 1: in turn).
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BEAM_DIRS = (Path("/work/shared/data/resonant-double-beam"), ROOT / "tests" / "data" / "resonant-double-beam")


def _three_raw() -> list:
    """Three raw rig captures (6 s at 10 kHz, hidden clearance 0.1) as ImpactRecords."""
    from eddi.model import EquationOfMotion
    from simulated_rig.bench import impact_test
    from simulated_rig.systems import hide_effect

    eom = EquationOfMotion.create(mass=0.1, damping={"v": 0.06}, stiffness={"x": 600.0, "x^3": 2e7})
    r = impact_test(eom, 25.0, rate_hz=10000.0, pretrigger_s=0.05, record_s=0.5, snr_db=None, seed=0)
    amp, vel = float(np.max(np.abs(r.truth_x))), float(np.max(np.abs(r.truth_v)))
    truth = hide_effect(eom, "clearance", 0.1, 0, amplitude_m=amp, velocity_m_s=vel)
    return [impact_test(truth, f, rate_hz=10000.0, pretrigger_s=0.2, record_s=6.0, snr_db=45.0, seed=i)
            for i, f in enumerate((20.0, 25.0, 30.0))]


def _three_floor(raw: list) -> list:
    from eddi.conditioning import condition
    from eddi.diagnosis import Record

    out = []
    for i, r in enumerate(raw):
        c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
        out.append(Record.from_conditioned(c, label=f"impact {i + 1}", pretrigger_samples=r.pretrigger_samples))
    return out


def _beam_files() -> list[str]:
    for d in BEAM_DIRS:
        files = sorted(str(p) for p in d.glob("ringdown-*.csv"))
        if len(files) >= 2:
            return files
    raise SystemExit("no double-beam ring-downs found in " + " or ".join(map(str, BEAM_DIRS)))


def _beam_floor(files: list[str]) -> list:
    from station.commands.diagnose import load_records

    return load_records(files)[0]


def _time(fn, runs: int) -> tuple[list[float], float, object]:
    walls, out = [], None
    c0 = time.process_time()
    for _ in range(runs):
        t0 = time.perf_counter()
        out = fn()
        walls.append(time.perf_counter() - t0)
    return walls, (time.process_time() - c0) / runs, out


def run_case(case: str, runs: int, profile: int, jobs: int = 1) -> None:
    from eddi.diagnosis import diagnose as _diagnose
    from station.forkmap import ForkMap

    def diagnose(records, **kw):  # type: ignore[no-untyped-def]
        return _diagnose(records, mapper=ForkMap(jobs), **kw)

    if case == "three":
        raw = _three_raw()
        floor_fn = lambda: _three_floor(raw)  # noqa: E731
        kw = dict(mass=0.1, damping="v,x^2*v,v^3", stiffness="x,x^2,x^3,x^4,x^5")
        target = 3.0
    else:
        files = _beam_files()
        floor_fn = lambda: _beam_floor(files)  # noqa: E731
        kw = dict(mass=1.0)
        target = 8.0
    load0 = os.getloadavg()[0]
    fwall, fcpu, records = _time(floor_fn, runs)
    diagnose(records, **kw)  # warm: imports, numba caches
    if profile:
        prof = cProfile.Profile()
        prof.enable()
        d = diagnose(records, **kw)
        prof.disable()
        pstats.Stats(prof).sort_stats("cumulative").print_stats(profile)
        pstats.Stats(prof).sort_stats("tottime").print_stats(profile)
    dwall, dcpu, d = _time(lambda: diagnose(records, **kw), runs)
    load1 = os.getloadavg()[0]
    fmin, dmin = min(fwall), min(dwall)
    print(f"{case}: {len(records)} records; floor (read + condition) min {fmin:.3f} s median "
          f"{statistics.median(fwall):.3f} s (CPU {fcpu:.3f} s)")
    print(f"{case}: diagnose min {dmin:.2f} s median {statistics.median(dwall):.2f} s (CPU {dcpu:.2f} s "
          f"per run) = {dmin / fmin:.1f}x the floor; target {target:g} s "
          f"({'met' if dmin <= target else 'NOT met'} at this load); cause {d.cause}")  # type: ignore[attr-defined]
    print(f"{case}: load average (1 min) {load0:.2f} before, {load1:.2f} after; {os.cpu_count()} CPUs; "
          f"folds in {jobs} process(es) (CPU of this process only)")


def _child_run(cmd: list[str], env: dict[str, str], cwd: str | None = None) -> tuple[float, float, bytes]:
    """Wall and CPU time (user + sys of the process and its own children) of one command, and
    its output. ``cwd``: where it runs (``python -m`` puts it first on the path: not a checkout)."""
    import resource
    import subprocess

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run(cmd, env=env, check=True, stdout=subprocess.PIPE, cwd=cwd).stdout
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), out


def run_cli(runs: int, cases: tuple[str, ...] = ("three", "beam"), jobs: int = 2,
            before: str | None = None) -> None:
    """``station diagnose`` as a whole process: the ``three`` captures written as CSV (with and
    without the pipeline baseline's refinement) and the nine double-beam ring-downs; floor:
    ``python -c "import numpy"``. Wall and CPU (the process and its children), min and median
    over ``--runs``, runs interleaved; each diagnosis in one process and in ``jobs``. With
    ``before`` (another checkout of the project), each one-process diagnosis also runs from it,
    interleaved, and the CPU ratio after / before and whether the JSON is the same are printed."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
        old = {**env, "PYTHONPATH": str(Path(before).resolve()), "STATION_SERIAL": "1"} if before else None
        env.pop("STATION_JOBS", None)
        serial = {**env, "STATION_SERIAL": "1"}
        forked = {**{k: v for k, v in env.items() if k != "STATION_SERIAL"}, "STATION_JOBS": str(jobs)}
        cmds: dict[str, tuple[list[str], dict[str, str]]] = {
            "import numpy (floor)": ([sys.executable, "-c", "import numpy"], env)}
        if "three" in cases:
            files = []
            for i, r in enumerate(_three_raw()):
                path = Path(tmp) / f"c{i}.csv"
                np.savetxt(path, np.column_stack((r.t, r.force_n, r.acc_m_s2)), delimiter=",",
                           header="t,force,acc", comments="", fmt="%.10g")
                files.append(str(path))
            three = [sys.executable, "-m", "station.cli", "diagnose", *files, "--mass", "0.1", "--json"]
            cmds["three: station diagnose --no-refine"] = (three + ["--no-refine"], serial)
            cmds["three: station diagnose"] = (three, serial)
            if old is not None:
                cmds["three: station diagnose, before"] = (three, old)
            cmds[f"three: station diagnose, {jobs} jobs"] = (three, forked)
        if "beam" in cases:
            beam = [sys.executable, "-m", "station.cli", "diagnose", *_beam_files(), "--mass", "1", "--json"]
            cmds["beam: station diagnose"] = (beam, serial)
            if old is not None:
                cmds["beam: station diagnose, before"] = (beam, old)
            cmds[f"beam: station diagnose, {jobs} jobs"] = (beam, forked)
        load0 = os.getloadavg()[0]
        walls: dict[str, list[float]] = {}
        cpus: dict[str, list[float]] = {}
        outs: dict[str, bytes] = {}
        for _ in range(runs):
            for name, (cmd, e) in cmds.items():
                w, c, out = _child_run(cmd, e, cwd=tmp)
                walls.setdefault(name, []).append(w)
                cpus.setdefault(name, []).append(c)
                outs[name] = out
        for case in cases:
            one, many = outs.get(f"{case}: station diagnose"), outs.get(f"{case}: station diagnose, {jobs} jobs")
            if one is not None and many is not None:
                print(f"cli: {case}: JSON in one process and in {jobs} jobs "
                      f"{'identical' if one == many else 'DIFFERENT'}")
            prior = outs.get(f"{case}: station diagnose, before")
            if one is not None and prior is not None:
                a, b = cpus[f"{case}: station diagnose"], cpus[f"{case}: station diagnose, before"]
                print(f"cli: {case}: one process, after / before (same run, interleaved): CPU min "
                      f"{min(a) / min(b):.3f}, median {statistics.median(a) / statistics.median(b):.3f}; "
                      f"JSON {'identical' if one == prior else 'different (numbers moved)'}")
        fw, fc = min(walls["import numpy (floor)"]), min(cpus["import numpy (floor)"])
        for name in cmds:
            w, c = walls[name], cpus[name]
            target = {"three": 3.0, "beam": 8.0}.get(name.split(":")[0])
            print(f"cli: {name:<38} wall min {min(w):6.2f} s median {statistics.median(w):6.2f} s "
                  f"({min(w) / fw:5.1f}x the floor); CPU min {min(c):6.2f} s median {statistics.median(c):6.2f} s "
                  f"({min(c) / fc:5.1f}x)" + (f"; target {target:g} s wall: {'met' if min(w) <= target else 'NOT met'}"
                                               if target else ""))
        print(f"cli: load average (1 min) {load0:.2f} before, {os.getloadavg()[0]:.2f} after; "
              f"{os.cpu_count()} CPUs")


def _makespan(items: list[float], jobs: int, dealt: bool = False) -> float:
    """Time ``jobs`` processes take for items of these CPU times: round robin (``dealt``), or
    item ``k < jobs`` to process ``k`` and then each to the first process free (ForkMap)."""
    if jobs < 2 or len(items) < 2:
        return float(sum(items))
    n = min(jobs, len(items))
    if dealt:
        return max(sum(items[w::n]) for w in range(n))
    return max(_finish_times(items, jobs))


def _finish_times(items: list[float], jobs: int) -> list[float]:
    """When each of ``min(jobs, len(items))`` processes runs out of items (ForkMap's order)."""
    import heapq

    n = min(jobs, len(items))
    free = list(items[:n])
    heapq.heapify(free)
    for t in items[n:]:
        heapq.heappush(free, heapq.heappop(free) + t)
    return sorted(free)


_ESTIMATE_CHILD = r"""
import json, os, sys, time
c0 = time.process_time()
import station.forkmap as fm
sys.path.insert(0, os.environ["BENCH_DIR"])
from bench_diagnose_speed import _finish_times
calls, spans, sides = [], [], []
def timed(self, fn, items):
    out, ts = [], []
    for x in items:
        t0 = time.process_time(); out.append(fn(x)); ts.append(time.process_time() - t0)
    calls.append(ts)
    # jobs queued with ForkMap.beside: taken by a process with no item left while another still
    # runs one (as ForkMap does), timed here; where the map's items leave a core idle
    free = _finish_times(ts, self.jobs) if min(self.jobs, len(ts)) >= 2 else []
    end, side = max(free, default=0.0), []
    while free and getattr(self, "_queued", None) and min(free) < end:
        key, job = next(iter(self._queued.items()))
        t0 = time.process_time()
        try:
            self._done[key] = (job, job())
        except Exception:
            pass
        self._queued.pop(key, None)
        c = time.process_time() - t0
        side.append(c)
        free[free.index(min(free))] += c
    spans.append(max(free, default=sum(ts)))
    sides.append(side)
    return out
fm.ForkMap.__call__ = timed
def dump():
    if not os.path.exists(sys.argv[1]):
        c2 = time.process_time()
        with open(sys.argv[1], "w") as f:
            json.dump({"total": c2 - c0, "maps": calls, "spans": spans, "sides": sides}, f)
import station.process as sp
if hasattr(sp, "end_now"):  # a whole process may end without the teardown (written first)
    real_end = sp.end_now
    sp.end_now = lambda code: (dump(), real_end(code))
from station.cli import main
try:
    try:  # as the station executable runs it (station.cli.run)
        main(sys.argv[2:], whole_process=True)
    except TypeError:  # an older tree
        main(sys.argv[2:])
finally:
    dump()
"""


def _estimate_once(tree: Path, args: list[str], tmp: str, jobs: int) -> tuple[dict, bytes]:
    """One timed ``station diagnose`` from ``tree`` (its fork maps made for ``jobs`` processes, each
    item run here in turn and timed): the child's CPU figures and its JSON."""
    import json
    import subprocess

    env = {**os.environ, "PYTHONPATH": str(tree) + os.pathsep + os.environ.get("PYTHONPATH", ""),
           "STATION_JOBS": str(jobs), "BENCH_DIR": str(Path(__file__).resolve().parent)}
    env.pop("STATION_SERIAL", None)
    out = Path(tmp) / "estimate.json"
    out.unlink(missing_ok=True)
    import resource

    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    got = subprocess.run([sys.executable, "-c", _ESTIMATE_CHILD, str(out), *args], env=env, cwd=tmp,
                         stdout=subprocess.PIPE, check=False).stdout
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    figures = json.loads(out.read_text())
    # the whole process's CPU (Python's start-up, imports, the interpreter's teardown if it runs)
    figures["process"] = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return figures, got


def _modelled(got: dict, jobs: int) -> tuple[float, float, float, float]:
    """(modelled wall, the same dealt round robin, CPU outside the maps, CPU inside)."""
    maps, sides = got["maps"], got.get("sides") or [[] for _ in got["maps"]]
    inside = sum(sum(m) + sum(b) for m, b in zip(maps, sides))
    outside = got["total"] - inside
    spans = got.get("spans") or [_makespan(m, jobs) for m in maps]
    return (outside + sum(spans),
            outside + sum(_makespan(m + b, jobs, dealt=True) for m, b in zip(maps, sides)), outside, inside)


def _modelled_process(got: dict, jobs: int) -> float:
    """The modelled wall of the whole process: :func:`_modelled`'s plus Python's start-up and
    the interpreter's teardown (the process's CPU not inside a map, serial)."""
    maps, sides = got["maps"], got.get("sides") or [[] for _ in got["maps"]]
    inside = sum(sum(m) + sum(b) for m, b in zip(maps, sides))
    spans = got.get("spans") or [_makespan(m, jobs) for m in maps]
    return got["process"] - inside + sum(spans)


def run_estimate(jobs: int, detail: bool = False, runs: int = 1, before: str | None = None) -> None:
    """The quiet-machine wall time of ``station diagnose`` on ``jobs`` idle cores, modelled (see
    the module notes) from timed runs in one process; with ``before`` (another checkout), each
    round runs that tree's too, interleaved, and prints the medians' ratio and whether the JSON
    is the same."""
    import tempfile

    trees = [("tree", ROOT)] + ([("before", Path(before).resolve())] if before else [])
    with tempfile.TemporaryDirectory() as tmp:
        files = []
        for i, r in enumerate(_three_raw()):
            path = Path(tmp) / f"c{i}.csv"
            np.savetxt(path, np.column_stack((r.t, r.force_n, r.acc_m_s2)), delimiter=",",
                       header="t,force,acc", comments="", fmt="%.10g")
            files.append(str(path))
        cases = {"three": ["diagnose", *files, "--mass", "0.1", "--json"],
                 "beam": ["diagnose", *_beam_files(), "--mass", "1", "--json"]}
        for case, args in cases.items():
            walls: dict[str, list[float]] = {name: [] for name, _ in trees}
            whole: dict[str, list[float]] = {name: [] for name, _ in trees}
            outs: dict[str, bytes] = {}
            load0 = os.getloadavg()[0]
            for rnd in range(runs):
                for name, tree in (trees if rnd % 2 == 0 else trees[::-1]):
                    got, outs[name] = _estimate_once(tree, args, tmp, jobs)
                    wall, dealt, outside, inside = _modelled(got, jobs)
                    walls[name].append(wall)
                    whole[name].append(_modelled_process(got, jobs))
                    maps = got["maps"]
                    target = {"three": 3.0, "beam": 8.0}[case]
                    label = f"{case}" + (f" ({name})" if before else "")
                    print(f"estimate: {label}: CPU {got['total']:.2f} s in one process after Python's start-up "
                          f"(outside the {len(maps)} fork maps {outside:.2f} s, inside {inside:.2f} s); on {jobs} "
                          f"idle cores: {wall:.2f} s wall ({dealt:.2f} s with the items dealt round robin); "
                          f"target {target:g} s: {'met' if wall <= target else 'NOT met'}; load "
                          f"{os.getloadavg()[0]:.2f} (CPU inflates with the load)", flush=True)
                    print(f"estimate: {label}: the whole process (start-up and end included): CPU "
                          f"{got['process']:.2f} s, on {jobs} idle cores {whole[name][-1]:.2f} s wall", flush=True)
                    if detail:
                        sides = got.get("sides") or [[] for _ in maps]
                        spans = got.get("spans") or [_makespan(m, jobs) for m in maps]
                        for k, m in enumerate(maps):
                            print(f"estimate: {label}:   map {k + 1:2d}: {len(m):3d} items, CPU {sum(m):6.2f} s, "
                                  f"largest {max(m, default=0.0):5.2f} s, on {jobs} cores "
                                  f"{spans[k]:5.2f} s" + (f" (with {len(sides[k])} queued jobs beside, CPU "
                                                          f"{sum(sides[k]):.2f} s)" if sides[k] else ""))
            if before:
                a, b = statistics.median(walls["tree"]), statistics.median(walls["before"])
                print(f"estimate: {case}: median modelled wall tree {a:.2f} s, before {b:.2f} s: ratio "
                      f"{a / b:.3f} ({runs} interleaved rounds; load {load0:.2f} -> {os.getloadavg()[0]:.2f}); "
                      f"JSON {'identical' if outs['tree'] == outs['before'] else 'DIFFERENT'}", flush=True)
                a, b = statistics.median(whole["tree"]), statistics.median(whole["before"])
                print(f"estimate: {case}: whole process, median modelled wall tree {a:.2f} s, before {b:.2f} s: "
                      f"ratio {a / b:.3f}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--case", choices=("three", "beam", "both", "cli", "cli-three", "cli-beam", "estimate"),
                    default="both",
                    help="cli: whole station diagnose processes (the three captures as CSV and the "
                         "nine ring-downs; cli-three / cli-beam: one of them); estimate: their wall "
                         "time on --jobs (default 2) idle cores, modelled from timed fork-map items")
    ap.add_argument("--runs", type=int, default=None,
                    help="timed runs per case (default: 3; --case estimate: 1, rounds interleaved with --before)")
    ap.add_argument("--jobs", type=int, default=None, metavar="N",
                    help="processes for the folds (station.forkmap): the library call's (default 1) and "
                         "the cli case's second row per case (default 2)")
    ap.add_argument("--before", default=None, metavar="TREE",
                    help="cli and estimate cases: also run each one-process diagnosis from this checkout (e.g. a "
                         "`git worktree` of the previous commit), interleaved, and print after / before")
    ap.add_argument("--detail", action="store_true",
                    help="--case estimate: also each fork map's items (count, CPU, largest, makespan)")
    ap.add_argument("--profile", type=int, default=0, metavar="N",
                    help="print the N top cProfile lines of one extra run (default: off)")
    args = ap.parse_args()
    np.seterr(all="ignore")
    if args.case == "estimate":
        run_estimate(args.jobs or 2, args.detail, max(1, args.runs or 1), args.before)
        return
    if args.case.startswith("cli"):
        run_cli(max(1, args.runs or 3), ("three", "beam") if args.case == "cli" else (args.case[4:],),
                args.jobs or 2, args.before)
        return
    for case in (("three", "beam") if args.case == "both" else (args.case,)):
        run_case(case, max(1, args.runs or 3), args.profile, args.jobs or 1)


if __name__ == "__main__":
    main()
