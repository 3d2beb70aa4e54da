"""Where the CPU of a whole ``station identify`` process goes, stage by stage (issue 13, item 1).

    python benchmarks/bench_identify_budget.py [--repeats 3] [--no-h5]

The 45 s x 19.2 kHz record of ``bench_startup.py --identify`` (the rig's ``duffing-smooth``,
600 N, 45 dB, seed 1) is written as CSV (what the other benchmarks time), as ``.npy`` (the
floor) and, unless ``--no-h5``, as an HDF5 capture (``station import``). The kernels are built
ahead of time (``python -m eddi.kernels``), as an installed station runs them.

1. **Stages of one process.** A fresh interpreter does what ``station identify FILE --json``
   does, in order, and reads its own CPU (``getrusage``: user + sys since the process
   started) after each step: interpreter start, ``import numpy``, the CLI, pydantic, the
   lightest scipy the engine needs (``scipy.linalg`` + ``scipy.sparse``), ``scipy.interpolate``
   (which imports ``scipy.optimize`` at module level), the rest of the engine (eddi, station),
   reading the record, the library call (:func:`station.commands.identify.run_identify`:
   conditioning, EDDI, refinement, validations), the hammer-impulse and AC-coupling checks the
   command adds (:func:`station.commands.identify.coupling_check`; ~60-70 ms, not part of the
   library call: counted here since session 12), the JSON. Each stage is the minimum over
   ``--repeats`` processes; the sum is compared with the whole-process target (0.5 s) and with
   the floor process (``np.load`` of the ``.npy`` + one pass). Run twice: without and with
   cached bytecode (this machine sets ``PYTHONDONTWRITEBYTECODE``, so the project's own
   modules are compiled at every start; an installed package has them compiled).
2. **What each import costs.** Fresh processes ``import numpy; import X`` (best of
   ``--repeats``) minus ``import numpy``: the price of each library on the identify path,
   and of ``from numpy import *`` (scipy's array-API layer clones numpy's namespace, which in
   numpy 2.x imports numpy.f2py, numpy.testing, numpy.ma, numpy.random, numpy.polynomial).
3. **What a target would need.** The stages that no import change removes (interpreter,
   numpy, reading the record, the library call) summed, beside the target.

Prints CPU seconds and ratios to the floor, with the load average. Test-free: it only prints.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
ONE_BLAS = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
DAMPING, STIFFNESS, MASS = "v,x^2*v,v^3", "x,x^2,x^3,x^4,x^5", 0.815
TARGET_S = 0.5

#: The stage child: prints ``name cpu`` lines (CPU seconds since the process started).
STAGES = """
import resource, sys
def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime
out = [("interpreter start", cpu())]
import numpy
out.append(("import numpy", cpu()))
import station.cli, station.commands.identify
out.append(("CLI (argparse, station.cli)", cpu()))
import pydantic
out.append(("pydantic", cpu()))
import scipy.linalg, scipy.sparse
out.append(("scipy.linalg + scipy.sparse", cpu()))
import scipy.interpolate
out.append(("scipy.interpolate (+ optimize)", cpu()))
import station.session, station.readers, eddi.fit_record, eddi.refine, station.coupling, eddi.diagnosis.chain
out.append(("eddi + station modules", cpu()))
from station.readers import read_measurement
meas = read_measurement(sys.argv[1])
out.append(("read " + sys.argv[1].rsplit(".", 1)[-1].split(":")[0].upper(), cpu()))
from station.commands.identify import coupling_check, result_object, run_identify
res = run_identify(meas, float(sys.argv[2]), sys.argv[3], sys.argv[4])
out.append(("library call (run_identify)", cpu()))
import argparse
obj = result_object(meas, res)
coupling_check(meas, res, argparse.Namespace(damping=sys.argv[3], stiffness=sys.argv[4], route="auto",
                                             sensor_highpass=None), obj)
out.append(("impulse + AC-coupling checks", cpu()))
import json
json.dumps(obj)
out.append(("JSON", cpu()))
prev = 0.0
for name, c in out:
    print(f"{name}\\t{c - prev}")
    prev = c
"""


def child_cpu(cmd: list[str], env: dict[str, str]) -> float:
    """CPU seconds (user + sys) of one child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def best(cmd: list[str], env: dict[str, str], repeats: int) -> float:
    return min(child_cpu(cmd, env) for _ in range(repeats))


def stages(spec: str, env: dict[str, str], repeats: int) -> dict[str, float]:
    """Minimum CPU of each stage over ``repeats`` fresh processes."""
    mins: dict[str, float] = {}
    for _ in range(repeats):
        out = subprocess.run([sys.executable, "-c", STAGES, spec, str(MASS), DAMPING, STIFFNESS], env=env,
                             capture_output=True, text=True, check=True).stdout
        for line in out.splitlines():
            name, value = line.split("\t")
            mins[name] = min(mins.get(name, float("inf")), float(value))
    return mins


def print_stages(title: str, mins: dict[str, float], floor: float) -> None:
    total = sum(mins.values())
    print(f"\n{title}: sum of stage minima {total:.3f} s = {total / floor:.1f}x the floor "
          f"(target {TARGET_S} s: {'met' if total <= TARGET_S else 'NOT met'})")
    for name, c in mins.items():
        print(f"  {name:<34} {c:6.3f} s  {100 * c / total:5.1f} %  {c / floor:5.2f}x floor")
    fixed = sum(c for name, c in mins.items()
                if name in ("interpreter start", "import numpy", "library call (run_identify)",
                            "impulse + AC-coupling checks") or name.startswith("read"))
    print(f"  no import change removes interpreter + numpy + read + library call + checks: {fixed:.3f} s "
          f"({fixed / TARGET_S:.1f}x the {TARGET_S} s target)")


def write_record(tmp: Path, h5: bool) -> dict[str, Path]:
    """The record as CSV, .npy and (h5) an HDF5 capture."""
    import numpy as np

    from simulated_rig.bench import impact_test
    from station.readers import read_measurement

    rec = impact_test("duffing-smooth", 600.0, snr_db=45.0, seed=1)
    paths = {"csv": tmp / "long.csv", "npy": tmp / "long.npy"}
    cols = np.column_stack((rec.t, rec.force_n, rec.acc_m_s2))
    np.savetxt(paths["csv"], cols, delimiter=",", header="t,force,acc", comments="", fmt="%.9g")
    np.save(paths["npy"], cols)
    if h5:
        from station.session_writer import CaptureWriter, import_measurement

        paths["h5"] = tmp / "long.h5"
        writer = CaptureWriter(paths["h5"])
        try:
            import_measurement(writer, read_measurement(str(paths["csv"])))
        finally:
            writer.close()
    return paths


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=3, help="fresh processes per measurement; minima kept (default 3)")
    ap.add_argument("--no-h5", action="store_true", help="skip the HDF5 capture")
    args = ap.parse_args()
    sys.path.insert(0, str(REPO))
    base = {**os.environ, **ONE_BLAS,
            "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)}
    base.pop("EDDI_JIT", None)
    with tempfile.TemporaryDirectory() as tmp_s:
        tmp = Path(tmp_s)
        paths = write_record(tmp, not args.no_h5)
        aot = tmp / "aot"
        aot.mkdir()
        built = subprocess.run([sys.executable, "-m", "eddi.kernels", "--output-dir", str(aot)], env=base,
                               capture_output=True, text=True)
        env = {**base, "EDDI_AOT_DIR": str(aot)} if not built.returncode else base
        if built.returncode:
            print("(building the kernels ahead of time failed: numba's JIT is used, warm cache)")
        cached = {**env, "PYTHONPYCACHEPREFIX": str(tmp / "pyc")}
        cached.pop("PYTHONDONTWRITEBYTECODE", None)
        subprocess.run([sys.executable, "-c", STAGES, str(paths["csv"]), str(MASS), DAMPING, STIFFNESS],
                       env=cached, capture_output=True, check=True)  # writes the bytecode; warms the kernels
        floor = best([sys.executable, "-c", f"import numpy as np; a = np.load({str(paths['npy'])!r}); "
                      "np.abs(a).sum(axis=0)"], base, args.repeats)
        bare = best([sys.executable, "-c", "pass"], base, args.repeats)
        print(f"`station identify FILE --json` on the 45 s x 19.2 kHz record, CPU (user + sys), minima of "
              f"{args.repeats} fresh processes; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
        print(f"  floor process (np.load of the .npy + one pass) {floor:.3f} s; `python -c pass` {bare:.3f} s")
        bytecode = os.environ.get("PYTHONDONTWRITEBYTECODE")
        print_stages("stages, CSV" + (" (PYTHONDONTWRITEBYTECODE set: project modules compiled at start)"
                                      if bytecode else ""), stages(str(paths["csv"]), env, args.repeats), floor)
        print_stages("stages, CSV, bytecode cached (as an installed package)",
                     stages(str(paths["csv"]), cached, args.repeats), floor)
        if "h5" in paths:
            print_stages("stages, HDF5 capture (h5py import in the read), bytecode cached",
                         stages(f"{paths['h5']}:0", cached, args.repeats), floor)
        numpy_cpu = best([sys.executable, "-c", "import numpy"], base, args.repeats)
        print(f"\nimport cost over `import numpy` ({numpy_cpu:.3f} s), fresh processes, best of {args.repeats}:")
        for what in ("from numpy import *", "import pydantic", "import scipy", "import scipy.linalg",
                     "import scipy.sparse", "import scipy.linalg, scipy.sparse", "import scipy.special",
                     "import scipy.fft", "import scipy.optimize", "import scipy.interpolate", "import h5py"):
            c = best([sys.executable, "-c", f"import numpy; {what}"], base, args.repeats) - numpy_cpu
            print(f"  {what:<36} +{c:6.3f} s  ({c / floor:5.2f}x the floor)")


if __name__ == "__main__":
    main()
