"""Undeclared accelerometer AC coupling (IEPE) on one record: does ``station identify`` name it?

Rig records (``benchmarks/bench_ci_coverage_cli.py``'s systems and ``write_csv`` with ``iepe``,
plus the systems below) written to CSV and identified by ``station identify CSV --mass ...
--json`` in-process. For each record: the check's cheap symptom, the corner it found, whether it
warned, the coefficients' relative errors and z, and the CPU of the check against identify's
(same run). Summary: coupled records warned (corner within a factor 1.5), null records warned
(must be 0), the check's CPU share on nulls.

    python benchmarks/bench_sensor_highpass.py --set tune
    python benchmarks/bench_sensor_highpass.py --set held-out     # run to report, not tuned on
    python benchmarks/bench_sensor_highpass.py --set nulls --seeds 2
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import bench_ci_coverage_cli as B  # noqa: E402
import station.coupling as C  # noqa: E402

B.SYSTEMS.update({
    "own_3k2_1k": B._s("own", 500.0, 3.2, 0.01, 16.0, 1000.0, 45.0, 0.05, {"x^3": 0.3}, {"v^3": 0.8}, "rubber"),
    "own_soft_200": B._s("own", 200.0, 2.5, 0.006, 20.0, 2000.0, 50.0, 0.04, {"x^3": -0.15}, {"v*abs(v)": 0.5},
                         "rubber"),
    "own_50kg_15hz": B._s("own", 50.0, 15.0, 0.008, 8.0, 5000.0, 40.0, 0.08, {"x^3": 0.4}, {"v^3": 0.5}),
    "own_gram_40": B._s("own", 0.005, 40.0, 0.005, 4.0, 20000.0, 35.0, 0.2, {"x^3": 0.3}, {"v^3": 0.5}, "steel"),
    "own_hard_6hz_30db": B._s("own", 300.0, 6.0, 0.015, 15.0, 2000.0, 30.0, 0.05, {"x^3": 0.5}, {"x^2*v": 1.0},
                              "rubber"),
    # held out: run once to report, never tuned on
    "ho_700kg_2hz": B._s("ho", 700.0, 2.2, 0.01, 25.0, 2000.0, 50.0, 0.03, {"x^3": 0.2}, {"v^3": 0.5}, "rubber"),
    "ho_100kg_8hz_soft": B._s("ho", 100.0, 8.0, 0.008, 10.0, 5000.0, 40.0, 0.06, {"x^3": -0.2}, {"v*abs(v)": 0.6},
                              "rubber"),
    "ho_1t_4hz_x2v": B._s("ho", 1000.0, 4.0, 0.012, 15.0, 1000.0, 45.0, 0.04, {"x^2": 0.2, "x^3": 0.2},
                          {"x^2*v": 0.6}, "rubber"),
    "ho_20kg_12hz": B._s("ho", 20.0, 12.0, 0.006, 8.0, 10000.0, 50.0, 0.08, {"x^3": 0.3}, {"v^3": 0.4}),
})

#: (system, coupling corner [Hz]) per set; 0: no coupling (a null)
SETS = {
    "tune": [("tonne_v3", 0.3), ("tonne_v3", 0.5), ("tonne_v3_weak", 0.4), ("heavy_asym_x2v", 0.4),
             ("quarter_t_20k", 0.3), ("heavy_vabs_slow", 0.4), ("tonne_v3_60db", 0.3), ("heavy_x2_x2v", 0.5),
             ("own_3k2_1k", 0.3), ("own_3k2_1k", 0.5), ("own_soft_200", 0.3), ("own_50kg_15hz", 1.0),
             ("own_hard_6hz_30db", 0.4)],
    "held-out": [("ho_700kg_2hz", 0.35), ("ho_100kg_8hz_soft", 0.5), ("ho_1t_4hz_x2v", 0.3), ("ho_20kg_12hz", 0.8),
                 ("ho_700kg_2hz", 0.0), ("ho_100kg_8hz_soft", 0.0), ("ho_1t_4hz_x2v", 0.0), ("ho_20kg_12hz", 0.0)],
    "nulls": [(name, 0.0) for name in B.SYSTEMS if not name.startswith("ho_")],
}

_cpu = [0.0]
_orig = C.check_coupling


def _timed(*a, **k):  # the check's own CPU, inside identify
    t0 = time.process_time()
    try:
        return _orig(*a, **k)
    finally:
        _cpu[0] += time.process_time() - t0


C.check_coupling = _timed


def run(name: str, hp: float, seed: int, tmp: Path) -> tuple[bool, float | None, float, float]:
    """One record: (warned, corner found, identify CPU [s], check CPU [s]); prints a line."""
    spec = dict(B.SYSTEMS[name])
    if hp > 0:
        spec["iepe"] = hp
    path = tmp / f"{name}_{hp}_{seed}.csv"
    B.write_csv(spec, seed, path)
    eom = B.true_model(spec)
    _cpu[0] = 0.0
    t0 = time.process_time()
    js = B.identify_cli(spec, path)
    cpu = time.process_time() - t0
    chk = js["conditioning"].get("sensor_highpass_check", {})
    warned = any("AC-coupled" in w for w in js["warnings"])
    fc = js["conditioning"].get("sensor_highpass_estimate_hz")
    zs = []
    for g in ("damping", "stiffness"):
        for term, c in getattr(eom, g).items():
            got, half = B._coef(js, g, term)
            zs.append(f"{term}:{got / c - 1:+.3f}/z{(got - c) / (half / 1.959964):+.1f}")
    print(f"{name:18s} iepe {hp:4.2f} s{seed} symptom {chk.get('symptom_hz', math.nan):+.4f}"
          f"±{chk.get('symptom_se_hz', math.nan):.1g} corner {fc if fc is None else round(fc, 3)} "
          f"warned {warned} refinement {js['pipeline']['refinement']} cpu {cpu:.2f} check {_cpu[0]:.2f} | "
          + " ".join(zs), flush=True)
    return warned, fc, cpu, _cpu[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--set", choices=sorted(SETS), default="tune")
    ap.add_argument("--seeds", type=int, default=1, help="seeds per record (default %(default)s)")
    args = ap.parse_args()
    hit = coupled = null_warn = nulls = 0
    shares = []
    with tempfile.TemporaryDirectory() as d:
        for name, hp in SETS[args.set]:
            for seed in range(args.seeds):
                warned, fc, cpu, chk = run(name, hp, seed, Path(d))
                if hp > 0:
                    coupled += 1
                    hit += warned and fc is not None and hp / 1.5 < fc < hp * 1.5
                else:
                    nulls += 1
                    null_warn += warned
                    shares.append(chk / max(cpu - chk, 1e-9))
    print(f"coupled records warned with the corner within x1.5: {hit}/{coupled}")
    print(f"null records warned: {null_warn}/{nulls} (must be 0)")
    if shares:
        print(f"check CPU / rest of identify on nulls: median {sorted(shares)[len(shares) // 2]:.3f}, max {max(shares):.3f} "
              f"(budget 0.30)")


if __name__ == "__main__":
    main()
