"""Whole-process start-up of the station CLI, as ratios to the floor (issue 13, item 1).

    python benchmarks/bench_startup.py [--repeats 5] [--importtime COMMAND]

Times each command line in a fresh interpreter (wall and CPU, best of --repeats) beside two
floors measured in the same run: ``python -c pass`` and ``python -c "import numpy"`` (the
least any numerical command pays). Budgets: ``station --help`` <= 0.3 s and no heavier than
the numpy floor; a command's ``--help`` imports only what that command uses (no matplotlib,
pysindy or numba on the acquisition commands). Then lists, from ``python -X importtime``, the
largest imports of one command line (default: ``identify --help``), so a regression names
its module. Test-free: it only prints.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
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


def run(cmd: list[str]) -> tuple[float, float]:
    """(wall, CPU) seconds of one run of ``cmd``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def best(cmd: list[str], repeats: int) -> tuple[float, float]:
    runs = [run(cmd) for _ in range(repeats)]
    return min(r[0] for r in runs), min(r[1] for r in runs)


def importtime(argv: list[str], top: int = 12) -> list[tuple[int, str]]:
    """The ``top`` largest cumulative imports [us] of ``station ARGV``."""
    res = subprocess.run([sys.executable, "-X", "importtime", "-m", "station.cli", *argv], env=ENV,
                         capture_output=True, text=True)
    rows = []
    for line in res.stderr.splitlines():
        if line.startswith("import time:") and "|" in line:
            _, cum, name = (p.strip() for p in line[len("import time:"):].split("|"))
            if cum.isdigit() and not name.startswith(" "):
                rows.append((int(cum), name.strip()))
    return sorted(rows, reverse=True)[:top]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=5, help="runs per command line; the best is kept")
    ap.add_argument("--importtime", default="identify --help", metavar="ARGS",
                    help="station arguments whose largest imports are listed (default: %(default)s)")
    args = ap.parse_args()
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


if __name__ == "__main__":
    main()
