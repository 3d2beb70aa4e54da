"""Whole-process start-up of the station CLI, as ratios to the floor (issue 13, item 1).

    python benchmarks/bench_startup.py [--repeats 5] [--importtime COMMAND] [--identify [--no-refine]]
    python benchmarks/bench_startup.py --libraries [--repeats 7]

Times each command line in a fresh interpreter (wall and CPU, best of --repeats) beside two
floors measured in the same run: ``python -c pass`` and ``python -c "import numpy"`` (the
least any numerical command pays). Budgets: ``station --help`` <= 0.3 s and no heavier than
the numpy floor; a command's ``--help`` imports only what that command uses (no matplotlib,
pysindy or numba on the acquisition commands). Then lists, from ``python -X importtime``, the
largest imports of one command line (default: ``identify --help``), so a regression names
its module. Test-free: it only prints.

``--identify``: whole-process ``station identify`` on the 45 s x 19.2 kHz record (the rig's
``duffing-smooth``, 600 N, 45 dB, as ``bench_identify_speed.py``), warm (best and median of
--repeats) and once with an empty ``NUMBA_CACHE_DIR`` (every kernel compiled), as ratios to the
floor process (``python -c`` that ``np.load``s the same three columns and makes one pass),
beside the process that only imports what the command imports (no work: the import budget),
and once more with the project's bytecode cached (``PYTHONPYCACHEPREFIX``; where
``PYTHONDONTWRITEBYTECODE`` is set, as on the shared machine, every other line compiles
eddi/ and station/ at each start, which an installed package does not);
then the import budget of that command line from ``python -X importtime``: total, the largest
top-level packages, and the libraries it must not import (matplotlib, pysindy, dask, h5py,
pyarrow, scipy.signal). Issue 13 targets: <= 0.5 s warm, <= 1.5 s cold.

In the same run (``--identify``), the library call on arrays in memory (in process:
:func:`station.commands.identify.run_identify` on the record read once, one BLAS thread as the
CLI sets, CPU of the best of ``--repeats`` after one warm-up call), beside the in-process floor
(``np.load`` of the ``.npy`` + one pass, timed in that same child process). Issue 13 target:
<= 50 ms. Every line states the load average: on a shared machine compare ratios.

``--libraries``: what the libraries cost before the command's own work, CPU of ``python -c``
lines each adding to the last (numpy; scipy.sparse; pydantic's ``BaseModel``; ``eddi.model``;
``np.loadtxt`` of the 33 MB CSV, and instead the reader's compiled pass (``eddi.decimal_text``,
session 19: what ``station identify`` runs when the kernels are built); and session 16's chain
with scipy.linalg, ``least_squares`` and scipy.interpolate, which the identify path no longer
imports), with the modules each loaded.

The kernels (``eddi.kernels``) run two ways, both timed: numba's JIT (``EDDI_JIT=1``; cold: an
empty ``NUMBA_CACHE_DIR``, every kernel compiled) and built ahead of time (``python -m
eddi.kernels`` into a temporary directory, used through ``EDDI_AOT_DIR``; no numba in the
process, nothing compiled on a first run).
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

REPO = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)}
STATION = [sys.executable, "-m", "station.cli"]
LINES = [
    ("station --help", STATION + ["--help"]),
    ("station --version", STATION + ["--version"]),
    ("station demo --help", STATION + ["demo", "--help"]),
    ("station acquire --help", STATION + ["acquire", "--help"]),
    ("station rig --help", STATION + ["rig", "--help"]),
    ("station devices --help", STATION + ["devices", "--help"]),
    ("station identify --help", STATION + ["identify", "--help"]),
    ("station validate --help", STATION + ["validate", "--help"]),
    ("station diagnose --help", STATION + ["diagnose", "--help"]),
    ("station report --help", STATION + ["report", "--help"]),
    ("station replay --help", STATION + ["replay", "--help"]),
    ("station export --help", STATION + ["export", "--help"]),
    ("station campaign --help", STATION + ["campaign", "--help"]),
]


#: Libraries ``station identify FILE.csv`` must not import (it draws nothing, fits no SINDy, runs
#: no campaign, reads no HDF5; scipy.signal is for modal sums only; since session 18 no scipy at all).
NOT_FOR_IDENTIFY = ("matplotlib", "pysindy", "dask", "distributed", "pyarrow", "h5py", "scipy")
IDENTIFY_ARGS = ["--mass", "0.815", "--damping", "v,x^2*v,v^3", "--stiffness", "x,x^2,x^3,x^4,x^5", "--json"]


def run(cmd: list[str], env: dict[str, str] | None = None) -> tuple[float, float]:
    """(wall, CPU) seconds of one run of ``cmd``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env or ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def best(cmd: list[str], repeats: int) -> tuple[float, float]:
    runs = [run(cmd) for _ in range(repeats)]
    return min(r[0] for r in runs), min(r[1] for r in runs)


def _importtime_rows(argv: list[str], env: dict[str, str] | None = None) -> list[tuple[int, int, str]]:
    """(self us, cumulative us, indented name) of every import of ``station ARGV``."""
    res = subprocess.run([sys.executable, "-X", "importtime", "-m", "station.cli", *argv], env=env or ENV,
                         capture_output=True, text=True)
    rows = []
    for line in res.stderr.splitlines():
        if line.startswith("import time:") and "|" in line:
            own, cum, name = line[len("import time:"):].split("|")
            if cum.strip().isdigit():
                rows.append((int(own), int(cum), name.rstrip()[1:]))
    return rows


def importtime(argv: list[str], top: int = 12) -> list[tuple[int, str]]:
    """The ``top`` largest cumulative imports [us] of ``station ARGV``."""
    rows = [(cum, name) for _, cum, name in _importtime_rows(argv) if not name.startswith(" ")]
    return sorted(rows, reverse=True)[:top]


def import_budget(argv: list[str], top: int = 8, env: dict[str, str] | None = None, how: str = "") -> None:
    """Print the total import time of ``station ARGV``, its largest packages and forbidden imports."""
    rows = _importtime_rows(argv, env)
    names = {name.strip() for _, _, name in rows}
    per_package: dict[str, int] = {}
    for own, _, name in rows:
        root = name.strip().split(".")[0]
        per_package[root] = per_package.get(root, 0) + own
    total = sum(per_package.values())
    print(f"\nimport budget of `station identify FILE`{how} (python -X importtime, self times summed): {total / 1e3:.0f} ms")
    for root, us in sorted(per_package.items(), key=lambda kv: -kv[1])[:top]:
        print(f"  {us / 1e3:8.1f} ms  {root}")
    bad = [m for m in NOT_FOR_IDENTIFY if m in names]
    print("  must not import " + ", ".join(NOT_FOR_IDENTIFY) + ": " + ("ok" if not bad else "IMPORTED " + ", ".join(bad)))


#: Child process of the in-process measurement: prints ``floor_cpu identify_cpu ...`` (seconds).
IN_PROCESS = """
import sys, time
import numpy as np
from station.commands.identify import run_identify
from station.readers import read_measurement
csv, npy, refine, repeats = sys.argv[1], sys.argv[2], sys.argv[3] == "1", int(sys.argv[4])
meas = read_measurement(csv)
args = (meas, 0.815, "v,x^2*v,v^3", "x,x^2,x^3,x^4,x^5")
run_identify(*args, refine=refine)  # warm-up: imports, kernels
floor, ident = [], []
for _ in range(repeats):
    c0 = time.process_time(); a = np.load(npy); np.abs(a).sum(axis=0); floor.append(time.process_time() - c0)
    c0 = time.process_time(); run_identify(*args, refine=refine); ident.append(time.process_time() - c0)
print(min(floor), min(ident), sorted(ident)[len(ident) // 2])
"""


def in_process(csv: Path, npy: Path, repeats: int, refine: bool, env: dict[str, str]) -> tuple[float, float, float]:
    """(floor, min, median) CPU seconds of the library call on arrays, in one child process."""
    env = {**env, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", IN_PROCESS, str(csv), str(npy), "1" if refine else "0", str(repeats)],
                         env=env, capture_output=True, text=True, check=True).stdout.split()
    return float(out[0]), float(out[1]), float(out[2])


def identify_whole_process(repeats: int, extra: list[str]) -> None:
    """Whole-process ``station identify`` on the 45 s record, warm and cold, vs the floor."""
    import numpy as np

    sys.path.insert(0, str(REPO))
    from simulated_rig.bench import impact_test

    rec = impact_test("duffing-smooth", 600.0, snr_db=45.0, seed=1)
    with tempfile.TemporaryDirectory() as tmp:
        csv, npy, cache = Path(tmp) / "long.csv", Path(tmp) / "long.npy", Path(tmp) / "numba-cache"
        cols = np.column_stack((rec.t, rec.force_n, rec.acc_m_s2))
        np.savetxt(csv, cols, delimiter=",", header="t,force,acc", comments="", fmt="%.9g")
        np.save(npy, cols)
        argv = ["identify", str(csv), *IDENTIFY_ARGS, *extra]
        floor_cmd = [sys.executable, "-c", f"import numpy as np; a = np.load({str(npy)!r}); np.abs(a).sum(axis=0)"]
        imports_cmd = [sys.executable, "-c", "import station.cli, station.commands.identify, station.session, "
                       "station.readers, eddi.fit_record, eddi.refine, eddi.simulate"]
        aot_dir = Path(tmp) / "aot"
        aot_dir.mkdir()
        built = subprocess.run([sys.executable, "-m", "eddi.kernels", "--output-dir", str(aot_dir)], env=ENV,
                               capture_output=True, text=True)
        if built.returncode:
            print(f"(building the ahead-of-time kernels failed, AOT lines skipped: {built.stderr.strip()[-300:]})")
        # JIT: numba compiles the kernels at first use (cold: an empty cache) and caches them; AOT:
        # the kernels built ahead of time (python -m eddi.kernels), no numba at run time
        env = {**ENV, "NUMBA_CACHE_DIR": str(cache), "EDDI_JIT": "1"}
        aot = {**ENV, "NUMBA_CACHE_DIR": str(Path(tmp) / "numba-cache-aot"), "EDDI_AOT_DIR": str(aot_dir)}
        # bytecode cached, as an installed package has it (a machine with PYTHONDONTWRITEBYTECODE
        # set, like the shared one, otherwise compiles the project's modules at every start)
        aot_pyc = {**aot, "PYTHONPYCACHEPREFIX": str(Path(tmp) / "pyc")}
        aot_pyc.pop("PYTHONDONTWRITEBYTECODE", None)
        cold = run(STATION + argv, env)
        cold_aot = run(STATION + argv, aot) if not built.returncode else None
        rows = {"floor (np.load + one pass)": [], "imports only (no work)": [], "station identify (warm JIT)": []}
        if cold_aot is not None:
            rows["station identify (AOT kernels)"] = []
            rows["station identify (AOT, .pyc cached)"] = []
            run(STATION + argv, aot_pyc)  # writes the bytecode
        for _ in range(repeats):  # interleaved, so a change of load hits all alike
            rows["floor (np.load + one pass)"].append(run(floor_cmd))
            rows["imports only (no work)"].append(run(imports_cmd, env))
            rows["station identify (warm JIT)"].append(run(STATION + argv, env))
            if cold_aot is not None:
                rows["station identify (AOT kernels)"].append(run(STATION + argv, aot))
                rows["station identify (AOT, .pyc cached)"].append(run(STATION + argv, aot_pyc))
        f_cpu = min(c for _, c in rows["floor (np.load + one pass)"])
        print(f"\nwhole process, {rec.n_samples} samples ({rec.n_samples / rec.rate_hz:.0f} s at {rec.rate_hz:.0f} Hz, "
              f"CSV {csv.stat().st_size / 1e6:.0f} MB), `station {' '.join(['identify', 'FILE', *IDENTIFY_ARGS[:2], *extra])}`; "
              f"{repeats} runs, load average {os.getloadavg()[0]:.1f}:")
        for name, xs in rows.items():
            walls, cpus = [w for w, _ in xs], [c for _, c in xs]
            target = ("  (target 0.5 s: " + ("met" if min(walls) <= 0.5 else "NOT met") + ")"
                      if "warm" in name or "AOT" in name else "")
            print(f"  {name:<32} wall min {min(walls):6.3f} s median {statistics.median(walls):6.3f} s; cpu min "
                  f"{min(cpus):6.3f} s median {statistics.median(cpus):6.3f} s = {min(cpus) / f_cpu:5.1f}x the floor's CPU{target}")
        for name, c in (("station identify (cold JIT)", cold), ("station identify (first run, AOT)", cold_aot)):
            if c is not None:
                print(f"  {name:<32} wall {c[0]:6.3f} s; cpu {c[1]:6.3f} s = {c[1] / f_cpu:5.1f}x the floor's CPU  "
                      f"(target 1.5 s: {'met' if c[0] <= 1.5 else 'NOT met'} on the wall, "
                      f"{'met' if c[1] <= 1.5 else 'NOT met'} on CPU)")
        inp_floor, inp_min, inp_med = in_process(csv, npy, max(3, repeats), "--no-refine" not in extra, aot)
        print(f"\nin process (library call on the arrays, one BLAS thread; best of {max(3, repeats)}, load average "
              f"{os.getloadavg()[0]:.1f}):")
        print(f"  floor (np.load + one pass)       cpu {inp_floor * 1e3:7.1f} ms")
        label = "run_identify on arrays" + (" (--no-refine)" if extra else "")
        print(f"  {label:<32} cpu min {inp_min * 1e3:7.1f} ms median "
              f"{inp_med * 1e3:7.1f} ms = {inp_min / inp_floor:5.1f}x the floor  (target 50 ms: "
              f"{'met' if inp_min <= 0.050 else 'NOT met'})")
        if cold_aot is not None:  # as the AOT line runs: no numba
            import_budget(argv, env=aot_pyc, how=" with the AOT kernels, .pyc cached")
        else:
            import_budget(argv, env=env, how=" with numba's JIT")


#: The libraries every `station identify FILE.csv` pays before its own work, one line adding to
#: the last (``--libraries``). Since session 17 (s17import) the identify path imports no
#: scipy.linalg / optimize / interpolate (eddi.lsq, eddi.bspline), since session 18 (s18import) no
#: scipy at all (EDDI's drift basis and normal equations: eddi.bspline.BandedRows). The chains of
#: sessions 17 (+ scipy.sparse) and 16 (+ scipy.linalg, least_squares, interpolate) are the last
#: lines, for comparison.
LIBRARY_LINES = (
    ("python -c pass", "pass"),
    ("+ numpy", "import numpy"),
    ("+ pydantic.BaseModel", "import numpy; from pydantic import BaseModel"),
    ("+ eddi.model (the schema's two models)", "import numpy; import eddi.model"),
    ("+ np.loadtxt of the 33 MB CSV", "import numpy as np; import eddi.model; np.loadtxt({csv!r}, "
                                      "delimiter=',', skiprows=1, ndmin=2, quotechar='\"', encoding='utf-8')"),
    ("+ the CSV by eddi.decimal_text instead", "import numpy as np; import eddi.model; from pathlib import Path; "
     "from eddi.decimal_text import data_start, parse_columns; raw = Path({csv!r}).read_bytes(); "
     "assert parse_columns(raw, data_start(raw, 1), ',', 3) is not None, 'no built kernels: python -m eddi.kernels'"),
    ("  (session 17's chain: + scipy.sparse)",
     "import numpy as np, scipy.sparse; import eddi.model; np.loadtxt({csv!r}, delimiter=',', skiprows=1, "
     "ndmin=2, quotechar='\"', encoding='utf-8')"),
    ("  (session 16's chain: + scipy.linalg, least_squares, interpolate)",
     "import numpy as np, scipy.sparse, scipy.linalg, scipy.interpolate; from scipy.optimize import least_squares; "
     "import eddi.model; np.loadtxt({csv!r}, delimiter=',', skiprows=1, ndmin=2, quotechar='\"', encoding='utf-8')"),
)
#: Reports what a line loaded: the scipy subpackages and the modules in all.
LOADED = ("; import sys; print(len(sys.modules), ','.join(sorted(m[6:] for m in sys.modules "
          "if m.startswith('scipy.') and m.count('.') == 1 and not m.startswith('scipy._'))))")


def library_floor(repeats: int) -> None:
    """Print what the libraries of `station identify FILE.csv` cost before its own work (CPU)."""
    import numpy as np

    sys.path.insert(0, str(REPO))
    from simulated_rig.bench import impact_test

    rec = impact_test("duffing-smooth", 600.0, snr_db=45.0, seed=1)
    with tempfile.TemporaryDirectory() as tmp:
        csv = Path(tmp) / "long.csv"
        np.savetxt(csv, np.column_stack((rec.t, rec.force_n, rec.acc_m_s2)), delimiter=",", header="t,force,acc",
                   comments="", fmt="%.9g")
        env = {**ENV, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
        cmds = [[sys.executable, "-c", code.format(csv=str(csv))] for _, code in LIBRARY_LINES]
        cpus: list[list[float]] = [[] for _ in cmds]
        loads = []
        for _ in range(repeats):  # interleaved, so a change of load hits all alike
            loads.append(os.getloadavg()[0])
            for i, cmd in enumerate(cmds):
                cpus[i].append(run(cmd, env)[1])
        print(f"\nwhat `station identify FILE.csv` pays before its own work (CPU, min / median of {repeats} "
              f"interleaved runs; load average {min(loads):.1f}-{max(loads):.1f}); each line adds to the one above:")
        for (name, _), cmd, xs in zip(LIBRARY_LINES, cmds, cpus):
            loaded = subprocess.run([cmd[0], "-c", cmd[2] + LOADED], env=env, capture_output=True, text=True)
            n, _, sub = loaded.stdout.strip().partition(" ")
            print(f"  {name:<47} cpu {min(xs):6.3f} / {statistics.median(xs):6.3f} s  {n:>4} modules  "
                  f"{'scipy: ' + sub if sub else ''}")
        today = next(i for i, (name, _) in enumerate(LIBRARY_LINES) if name.startswith("+ the CSV by eddi"))
        print(f"  the target (0.5 s) minus the CSV line leaves {0.5 - min(cpus[today]):+.3f} s for the engine's own "
              "modules, conditioning, EDDI, the refinement, validation and the checks")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=5, help="runs per command line; the best is kept")
    ap.add_argument("--importtime", default="identify --help", metavar="ARGS",
                    help="station arguments whose largest imports are listed (default: %(default)s)")
    ap.add_argument("--identify", action="store_true",
                    help="also time whole-process `station identify` on the 45 s x 19.2 kHz record (warm, cold JIT) "
                         "and print its import budget")
    ap.add_argument("--no-refine", action="store_true", help="with --identify: pass --no-refine")
    ap.add_argument("--only-identify", action="store_true", help="skip the --help lines")
    ap.add_argument("--libraries", action="store_true",
                    help="only print what the libraries of `station identify FILE.csv` cost before its own work "
                         "(numpy, scipy's pieces, pydantic, the CSV parse), each line adding to the last")
    args = ap.parse_args()
    if args.libraries:
        library_floor(args.repeats)
        return
    if args.only_identify:
        identify_whole_process(args.repeats, ["--no-refine"] if args.no_refine else [])
        return
    bare = best([sys.executable, "-c", "pass"], args.repeats)
    floor = best([sys.executable, "-c", "import numpy"], args.repeats)
    print(f"load average {os.getloadavg()[0]:.1f}; best of {args.repeats}; ratios are to `python -c \"import numpy\"`")
    print(f"{'python -c pass':<28} wall {bare[0]:6.3f} s  cpu {bare[1]:6.3f} s  ratio {bare[1] / floor[1]:5.2f}")
    numpy_line = 'python -c "import numpy"'
    print(f"{numpy_line:<28} wall {floor[0]:6.3f} s  cpu {floor[1]:6.3f} s  ratio  1.00 (floor)")
    for name, cmd in LINES:
        wall, cpu = best(cmd, args.repeats)
        flag = ""
        if name == "station --help":
            flag = "  (budget 0.3 s: " + ("ok" if wall <= 0.3 or cpu <= floor[1] else "OVER") + ")"
        print(f"{name:<28} wall {wall:6.3f} s  cpu {cpu:6.3f} s  ratio {cpu / floor[1]:5.2f}{flag}")
    print(f"\nlargest imports of `station {args.importtime}` (cumulative, python -X importtime):")
    for cum, name in importtime(args.importtime.split()):
        print(f"  {cum / 1e3:8.1f} ms  {name}")
    if args.identify:
        identify_whole_process(args.repeats, ["--no-refine"] if args.no_refine else [])


if __name__ == "__main__":
    main()
