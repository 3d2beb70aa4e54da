"""CPU of a whole ``station diagnose`` on three-mass chains (and two two-mass checks), with its verdict.

Session 18 (helper s18three, issues 13 / 14). The three-mass target of docs/multi-dof.md is a whole
diagnosis (three leave-one-out folds, the polish, the final model) in about 2 min CPU with the same
verdict. Each case's captures are written as CSV and ``station diagnose FILES --driving-point accK
--json --save-model M`` (CLI defaults: polish on) runs in a child process with ``STATION_SERIAL=1``
(the folds in that process), at ``nice -n 5``; its CPU is the child's user + system time
(``RUSAGE_CHILDREN``), which on a busy machine is what counts (the wall time is printed beside it).

Cases (``--cases``, default all):

- ``cA-50`` / ``cA-35``: session 13's chain (``bench_mdof_polish_cost.chain``: 1 / 0.5 / 2 kg,
  75 / 268 / 489 Hz, a 25 % cubic 2-3, struck at mass 2, three 3 s captures at 5 kHz) at 50 / 35 dB,
  noise seeds 300-302 (session 15's ``cAv_5000_50`` and ``cA`` captures, byte for byte);
- ``H1`` / ``H2``: session 15's own held-out chains (2 / 0.8 / 1.2 kg, 20 % cubic 1-2, 4 kHz, 40 dB,
  struck at 1; 0.6 / 1.5 / 3 kg, 30 % cubic 2-3, 6 kHz, 38 dB, struck at 3), seeds 500-502;
- ``H3``: drawn in session 18 and not looked at while anything was tuned: 1.5 / 0.7 / 2.5 kg,
  springs 1.2e6 / 6e5 / 2e6 N/m (52 / 172 / 336 Hz), a 25 % cubic 2-3, 8 kHz, 42 dB, struck at 2,
  seeds 710-712;
- ``S1`` / ``S2``: drawn in session 19 (helper s19three) as held-out checks of the tail pin: 0.8 / 1.6 / 1.0 kg,
  springs 1.5e6 / 2.5e6 / 8e5 N/m, a 20 % cubic 1-2, 6 kHz, 45 dB, struck at 1, seeds 900-902; 3 / 1.2 / 0.7 kg,
  springs 4e6 / 1.5e6 / 1e6 N/m, a 30 % cubic 2-3, 8 kHz, 45 dB, struck at 3, seeds 920-922;
- ``w2t1`` / ``w2h3``: two-mass chains with a weak cubic coupling (``bench_mdof_nulls.py`` kind
  ``weak2``, tuning seed 1 and held-out seed 3; expected verdict ``modal_coupling``).

Printed per case: the verdict and gain, baseline and coupled held-out folds, the coupled per-channel
held-out nrmse and the noise floors, the delivered model's coupling coefficients (value / 95 %
half-width) and natural frequencies, the CPU. ``--coarsen K`` sets
:data:`eddi.mdof.refine.JACOBIAN_COARSEN` in the child (an A/B of that constant); ``--code DIR`` runs
the child on another checkout (e.g. a ``git archive`` of main) for a before / after in one run.

    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_three_cost.py --cases cA-50,H3
    PYTHONPATH=. nice -n 5 python benchmarks/bench_mdof_three_cost.py --cases cA-50 --coarsen 4
    PYTHONPATH=. python benchmarks/bench_mdof_three_cost.py --write /tmp/three --cases H3   # captures only
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test  # noqa: E402

#: Own held-out chains: masses, springs (ground-1, 1-2, 2-3), cubic share and link (1: 1-2, 2: 2-3),
#: rate, struck mass, blows, SNR, first noise seed.
CHAINS = {
    "H1": ((2.0, 0.8, 1.2), (8e5, 5e5, 1.5e6), 0.2, 1, 4000.0, 1, (150.0, 100.0, 220.0), 40.0, 500),
    "H2": ((0.6, 1.5, 3.0), (3e5, 1.2e6, 6e5), 0.3, 2, 6000.0, 3, (120.0, 80.0, 180.0), 38.0, 500),
    "H3": ((1.5, 0.7, 2.5), (1.2e6, 6e5, 2e6), 0.25, 2, 8000.0, 2, (140.0, 90.0, 200.0), 42.0, 710),
    # session 19 (helper s19three), drawn before the tail pin was tried on them and not tuned on
    "S1": ((0.8, 1.6, 1.0), (1.5e6, 2.5e6, 8e5), 0.2, 1, 6000.0, 1, (180.0, 120.0, 250.0), 45.0, 900),
    "S2": ((3.0, 1.2, 0.7), (4e6, 1.5e6, 1e6), 0.3, 2, 8000.0, 3, (100.0, 160.0, 220.0), 45.0, 920),
}
CASES = ("cA-50", "cA-35", "H1", "H2", "H3", "S1", "S2", "w2t1", "w2h3")


def own_chain(name: str) -> tuple[MdofSystem, float, int, float]:
    """A chain of :data:`CHAINS` (1 % Rayleigh damping on the first and top mode, the cubic sized
    from the linear chain's largest stretch of its link at the largest blow); with its SNR, first
    seed and the true ``k3`` [N/m^3]."""
    masses, springs, share, link, rate, dp, blows, snr, seed = CHAINS[name]
    m = np.array(masses)
    k = np.array([[springs[0] + springs[1], -springs[1], 0], [-springs[1], springs[1] + springs[2], -springs[2]],
                  [0, -springs[2], springs[2]]])
    w = np.sort(np.sqrt(np.linalg.eigvals(k / m[:, None]).real))
    beta = 2 * 0.01 * (w[-1] - w[0]) / (w[-1] ** 2 - w[0] ** 2)
    alpha = 2 * 0.01 * w[0] - beta * w[0] ** 2
    els = [Element(between=(i, i + 1), k=s, c=beta * s) for i, s in enumerate(springs)]
    els += [Element(between=(0, i + 1), c=alpha * mi) for i, mi in enumerate(masses)]
    lin = MdofSystem(name=name, masses_kg=masses, elements=tuple(els), driving_point=dp, rate_hz=rate,
                     pretrigger_s=0.05, record_s=3.0, impacts_n=blows, tip="plastic")
    x = mdof_impact_test(lin, max(blows), snr_db=None).truth_x
    k3 = share * springs[link] / float(np.max(np.abs(x[link - 1] - x[link]))) ** 2
    e = els[link]
    els[link] = Element(between=e.between, k=e.k, c=e.c, k3=k3)
    return lin.model_copy(update={"elements": tuple(els)}), snr, seed, k3


def write_case(name: str, out: Path) -> tuple[list[str], str, dict]:
    """Write the case's captures into ``out``; the files, the driving point and the truth."""
    out.mkdir(parents=True, exist_ok=True)
    if name.startswith("cA-"):
        from bench_mdof_polish_cost import SHARE, chain

        system, snr, seed, truth = chain(), float(name[3:]), 300, {"k3 2-3 share": SHARE}
    elif name in CHAINS:
        system, snr, seed, k3 = own_chain(name)
        truth = {"k3": k3, "link": CHAINS[name][3]}
    else:
        from bench_mdof_nulls import draw

        which, s = {"w2t1": ("tuning", 1), "w2h3": ("heldout", 3)}[name]
        system, snr, row = draw("weak2", s, which)
        seed, truth = 1000 * s, {"k3": row["k3"], "share": row["share"], "masses_kg": row["masses_kg"]}
    files = []
    for k, peak in enumerate(system.impacts_n):
        files.append(str(out / f"cap{k}.csv"))
        mdof_impact_test(system, peak, snr_db=snr, seed=seed + k).write_csv(files[-1])
    return files, f"acc{system.driving_point}", truth


def diagnose(files: list[str], dp: str, model: Path, code: str, coarsen: int | None) -> tuple[dict, float, float]:
    """``station diagnose`` in a child (``STATION_SERIAL=1``, nice 5); its JSON, CPU and wall seconds."""
    pre = "" if coarsen is None else f"import eddi.mdof.refine as R; R.JACOBIAN_COARSEN = {int(coarsen)}; "
    env = dict(os.environ, PYTHONPATH=code, STATION_SERIAL="1")
    argv = ["nice", "-n", "5", sys.executable, "-c", pre + "import sys; from station.cli import run; sys.exit(run())",
            "diagnose", *files, "--driving-point", dp, "--json", "--save-model", str(model)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.time()
    done = subprocess.run(argv, env=env, capture_output=True, text=True, check=False)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if not done.stdout.strip():
        raise RuntimeError(f"diagnose exit {done.returncode}: {done.stderr.strip()[-300:]}")
    return json.loads(done.stdout), cpu, time.time() - t0


def row_of(name: str, obj: dict, truth: dict, cpu: float, wall: float) -> dict:
    r4 = lambda v: round(float(v), 4)  # noqa: E731
    return {"case": name, "cause": obj["cause"], "gain": r4(obj["gain"]), "cpu_s": round(cpu, 1),
            "wall_s": round(wall, 1), "baseline_folds": [r4(v) for v in obj["baseline"]["folds"]],
            "coupled_folds": [r4(v) for v in obj["coupled"]["folds"]],
            "coupled_channels": {c: r4(v) for c, v in obj["coupled"]["channel_nrmse"].items()},
            "floors": {c: r4(v) for c, v in obj["noise_floor"].items()},
            "coordinates": obj.get("coordinates"),
            "coupling": [{t: [float(f"{v:.4g}"), float(f"{h:.2g}")] for t, (v, h) in eq.items()}
                         for eq in obj.get("coupling_coefficients", [])],
            "frequencies_hz": [round(f, 3) for f in obj.get("natural_frequencies_hz", [])], "truth": truth}


def show(row: dict) -> None:
    print(f"{row['case']}: {row['cause']} (gain {row['gain']}), {row['cpu_s']} s CPU ({row['wall_s']} s wall); "
          f"folds baseline {row['baseline_folds']} coupled {row['coupled_folds']}; coupled channels "
          f"{row['coupled_channels']} floors {row['floors']}; {row['coordinates']} model, f {row['frequencies_hz']} Hz",
          flush=True)
    for i, eq in enumerate(row["coupling"]):
        nl = {t: vh for t, vh in eq.items() if "^" in t or "*" in t}
        if nl:
            print(f"    eq {i + 1} nonlinear coupling (value, ci95): {nl}")
    print(f"    truth {row['truth']}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", default=",".join(CASES), help=f"comma-separated of {','.join(CASES)}")
    ap.add_argument("--coarsen", type=int, default=None, help="JACOBIAN_COARSEN in the child (default: the code's)")
    ap.add_argument("--code", default=str(Path(__file__).resolve().parent.parent), help="PYTHONPATH of the child")
    ap.add_argument("--write", help="only write the captures into DIR/<case>/ (no diagnosis)")
    ap.add_argument("--json", help="write the rows to this JSON file")
    args = ap.parse_args(argv)
    names = [c for c in args.cases.split(",") if c]
    bad = [c for c in names if c not in CASES]
    if bad:
        ap.error(f"unknown case(s) {', '.join(bad)}; expected some of {', '.join(CASES)}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            where = Path(args.write or tmp) / name
            files, dp, truth = write_case(name, where)
            if args.write:
                print(f"{name}: {len(files)} captures in {where}, driving point {dp}, truth {truth}")
                continue
            obj, cpu, wall = diagnose(files, dp, where / "model.json", args.code, args.coarsen)
            rows.append(row_of(name, obj, truth, cpu, wall))
            show(rows[-1])
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
