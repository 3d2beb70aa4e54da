"""Does a change move identify's numbers? Two trees, the same records, every figure compared.

The protocol for a change that is not bit for bit (issue 13 item 1; sessions 16-18 used one
whose scripts were lost): ``--records`` impact records (default 64) built here from the rig
(:func:`simulated_rig.bench.impact_test`: ``duffing-smooth`` at three blows, ``duffing-struts``,
``paper-duffing``) and from the benches' generator (``tests/eddi/impact_cases.py``: linear,
hardening, quadratic spring, ``x^2*v`` / ``abs(v)*v`` damping, Coulomb friction, masses
0.05-50 kg), at 2-20 kHz and 30-60 dB, each identified by ``station identify``'s library call
(:func:`station.commands.identify.run_identify`, default refinement, a library wider than the
system's own terms so term selection has something to decide) in a child process per tree
(``--before REV`` as ``git archive``, ``--after`` this working tree by default; each tree with
its own ahead-of-time kernels). Compared per record:

* every coefficient's change in units of its ci95 half width (the larger of the two trees');
* the term-selection decisions (kept and dropped terms and why, route, refinement kept) and
  every warning, as text: identical or not;
* the printed validation nrmse: relative change.

Prints one line per record that moved more than ``--show`` of its ci95, then the largest
changes and the counts; exit 0. Test-free (``tests/eddi/test_identify_protocol.py`` runs the
comparison on a few records).

    python benchmarks/bench_identify_protocol.py --before HEAD [--after REV] [--records 64] [--jobs 2]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
ONE_BLAS = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}

#: Generator systems beyond ``impact_cases.SYSTEMS``: (mass, damping, stiffness, peak [N]).
EXTRA = {
    "linear": dict(mass=1.0, damping={"v": 2.0}, stiffness={"x": 4.0e4}, peak_n=300.0),
    "quad_damping": dict(mass=0.5, damping={"v": 0.3, "abs(v)*v": 2.0}, stiffness={"x": 2.0e4, "x^3": 3.0e9},
                         peak_n=400.0),
    "coulomb": dict(mass=1.0, damping={"v": 1.5, "sign(v)": 0.05}, stiffness={"x": 3.0e4}, peak_n=300.0),
    "heavy_linear": dict(mass=50.0, damping={"v": 60.0}, stiffness={"x": 2.0e6, "x^3": 1.0e11}, peak_n=5000.0),
}
#: Candidate libraries (damping, stiffness) by system kind: the true terms and a few more.
LIBRARY = {
    "linear": ("v,x^2*v", "x,x^3"),
    "quad_damping": ("v,abs(v)*v,x^2*v", "x,x^3"),
    "coulomb": ("v,sign(v)", "x,x^3"),
    "heavy_linear": ("v,x^2*v", "x,x^3"),
    "paper_do": ("v,x^2*v", "x,x^2,x^3"),
    "light_stiff": ("v,x^2*v", "x,x^3"),
    "heavy_asym": ("v", "x,x^2,x^3"),
    "nl_damping": ("v,x^2*v", "x,x^3"),
    "rig": ("v,x^2*v,v^3", "x,x^2,x^3,x^4,x^5"),
}
RATES = (2000.0, 4000.0, 5000.0, 10000.0, 20000.0)
SNRS = (30.0, 40.0, 45.0, 50.0, 60.0)


def record_specs(n: int) -> list[dict]:
    """``n`` record specifications cycling over systems, rates, noise and seeds."""
    gen = ["paper_do", "light_stiff", "heavy_asym", "nl_damping", *EXTRA]
    rig = [("duffing-smooth", 300.0), ("duffing-smooth", 600.0), ("duffing-smooth", 900.0),
           ("duffing-struts", None), ("paper-duffing", 600.0)]
    specs = []
    i = 0
    while len(specs) < n:
        if i % 4 == 3:  # one in four from the rig
            name, peak = rig[(i // 4) % len(rig)]
            specs.append(dict(kind="rig", system=name, peak=peak, rate=(4800.0, 9600.0, 19200.0)[i % 3],
                              snr=SNRS[(i // 2) % len(SNRS)], seed=100 + i))
        else:
            specs.append(dict(kind="gen", system=gen[i % len(gen)], rate=RATES[(i // 3) % len(RATES)],
                              snr=SNRS[(i // 5) % len(SNRS)], seed=200 + i))
        i += 1
    return specs


def make_record(spec: dict) -> dict:
    """Arrays and settings of one spec (t, force, acc, rate, pretrigger, mass, damping, stiffness)."""
    sys.path.insert(0, str(REPO))
    if spec["kind"] == "rig":
        from simulated_rig.bench import impact_test, system_info

        info = system_info(spec["system"])
        peak = spec["peak"] or info.demo_forces_n[len(info.demo_forces_n) // 2]
        rec = impact_test(spec["system"], peak, rate_hz=spec["rate"], record_s=min(8.0, info.record_s),
                          snr_db=spec["snr"], seed=spec["seed"])
        damping, stiffness = LIBRARY["rig"]
        return dict(t=rec.t, force=rec.force_n, acc=rec.acc_m_s2, rate=rec.rate_hz, pre=rec.pretrigger_samples,
                    mass=rec.eom.mass, damping=damping, stiffness=stiffness)
    from tests.eddi.impact_cases import SYSTEMS, impact_record

    system = EXTRA.get(spec["system"]) or SYSTEMS[spec["system"]]
    rec = impact_record(system, rate_hz=spec["rate"], duration_s=6.0, snr_db=spec["snr"], seed=spec["seed"])
    damping, stiffness = LIBRARY[spec["system"]]
    return dict(t=rec.t, force=rec.force, acc=rec.acc, rate=spec["rate"], pre=rec.pretrigger_samples,
                mass=rec.eom.mass, damping=damping, stiffness=stiffness)


#: Child: identify each ``.npz`` record named on stdin lines, print one JSON object a line.
CHILD = """
import json, sys
import numpy as np
from station.commands.identify import result_object, run_identify
from station.readers import Measurement
for path in sys.stdin.read().split():
    z = np.load(path)
    meas = Measurement(t=z["t"], channels={"force": z["force"], "acc": z["acc"]}, rate_hz=float(z["rate"]),
                       pretrigger_samples=int(z["pre"]), mass=float(z["mass"]), source=path)
    try:
        res = run_identify(meas, float(z["mass"]), str(z["damping"]), str(z["stiffness"]))
        obj = result_object(meas, res)
    except Exception as exc:  # a refusal is a result to compare too
        obj = {"error": f"{type(exc).__name__}: {exc}"}
    print(json.dumps(obj, sort_keys=True), flush=True)
"""


def run_tree(tree: Path, aot: Path, paths: list[Path]) -> list[dict]:
    """The child's objects for ``paths`` with ``tree``'s code and kernels."""
    env = {**os.environ, **ONE_BLAS, "PYTHONPATH": str(tree), "EDDI_AOT_DIR": str(aot)}
    env.pop("EDDI_JIT", None)
    out = subprocess.run([sys.executable, "-c", CHILD], input="\n".join(map(str, paths)), env=env, cwd=tree,
                         capture_output=True, text=True, check=True).stdout
    return [json.loads(line) for line in out.splitlines()]


def decisions(obj: dict, masked: bool = True) -> str:
    """What the protocol requires identical: terms kept and dropped, route, refinement, warnings."""
    if "error" in obj:
        return obj["error"]
    p = obj.get("pipeline") or {}
    keep = {k: p.get(k) for k in ("route", "refinement", "damping_terms", "stiffness_terms", "dropped")}
    text = json.dumps([keep, sorted(obj["damping"]), sorted(obj["stiffness"]), obj["warnings"],
                       obj["validation"]["warnings"], obj["validation"]["diverged"], obj.get("refinement", {}).get("kept")],
                      sort_keys=True)
    # the reasons and warnings quote figures (a dropped term's estimate, a ratio): the decision
    # is the text with its numbers masked; a figure that moved is counted apart (``numbers``)
    if not masked:
        return text
    terms = [keep["route"], keep["refinement"], keep["damping_terms"], keep["stiffness_terms"],
             sorted(keep["dropped"] or {}), sorted(obj["damping"]), sorted(obj["stiffness"])]
    return json.dumps(terms) + _NUMBER.sub("#", text)


_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def compare(a: dict, b: dict) -> dict:
    """Largest coefficient change / ci95 (and which), decisions equal, nrmse relative change."""
    out = {"same_decisions": decisions(a) == decisions(b), "same_text": decisions(a, False) == decisions(b, False),
           "max_z": 0.0, "term": None, "nrmse_rel": 0.0}
    if "error" in a or "error" in b or not out["same_decisions"]:
        return out
    for kind in ("damping", "stiffness"):
        for term, ca in a[kind].items():
            cb = b[kind][term]
            half = max(a["ci95"].get(kind, {}).get(term) or 0.0, b["ci95"].get(kind, {}).get(term) or 0.0)
            z = abs(cb - ca) / half if half > 0 else (0.0 if cb == ca else float("inf"))
            if z > out["max_z"]:
                out["max_z"], out["term"] = z, f"{kind}:{term}"
    na, nb = a["validation"]["nrmse"], b["validation"]["nrmse"]
    out["nrmse_rel"] = abs(nb - na) / abs(na) if na else (0.0 if nb == na else float("inf"))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", required=True, metavar="REV", help="git revision measured as 'before'")
    ap.add_argument("--after", default=None, metavar="REV", help="git revision as 'after' (default: this working tree)")
    ap.add_argument("--records", type=int, default=64, help="number of records (default 64)")
    ap.add_argument("--jobs", type=int, default=2, help="child processes per tree at once (default 2)")
    ap.add_argument("--show", type=float, default=0.01, help="print records whose change exceeds this fraction of ci95")
    ap.add_argument("--keep", default=None, metavar="DIR", help="keep the records and outputs in DIR")
    args = ap.parse_args()
    from concurrent.futures import ThreadPoolExecutor

    tmp_ctx = tempfile.TemporaryDirectory()
    tmp = Path(args.keep) if args.keep else Path(tmp_ctx.name)
    tmp.mkdir(parents=True, exist_ok=True)
    specs = record_specs(args.records)
    paths = []
    for i, spec in enumerate(specs):
        p = tmp / f"rec{i:03d}.npz"
        if not p.exists():
            r = make_record(spec)
            np.savez(p, **r)
        paths.append(p)
    trees = {}
    for name, rev in (("before", args.before), ("after", args.after)):
        if rev is None:
            trees[name] = REPO
            continue
        into = tmp / f"tree-{name}"
        if not into.exists():
            into.mkdir()
            archive = subprocess.run(["git", "-C", str(REPO), "archive", rev], capture_output=True, check=True).stdout
            subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
        trees[name] = into
    aots = {}
    for name, tree in trees.items():
        aot = tmp / f"aot-{name}"
        aot.mkdir(exist_ok=True)
        env = {**os.environ, **ONE_BLAS, "PYTHONPATH": str(tree)}
        subprocess.run([sys.executable, "-m", "eddi.kernels", "--output-dir", str(aot)], env=env, cwd=tree,
                       capture_output=True, check=False)
        aots[name] = aot
    chunks = [paths[i::args.jobs] for i in range(args.jobs)]
    results: dict[str, dict[Path, dict]] = {}
    with ThreadPoolExecutor(2 * args.jobs) as pool:
        futs = {(name, k): pool.submit(run_tree, trees[name], aots[name], chunk)
                for name in trees for k, chunk in enumerate(chunks)}
        for (name, k), f in futs.items():
            results.setdefault(name, {}).update(zip(chunks[k], f.result()))
    worst_z, worst_n, differ, errors, figures, same = (0.0, None), (0.0, None), [], 0, 0, 0
    for i, p in enumerate(paths):
        a, b = results["before"][p], results["after"][p]
        errors += "error" in a
        same += json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)
        c = compare(a, b)
        label = f"rec{i:03d} {specs[i]['system']} {specs[i]['rate']:.0f} Hz {specs[i]['snr']:.0f} dB"
        if not c["same_decisions"]:
            differ.append(label)
            print(f"  {label}: decisions or warnings DIFFER")
            continue
        figures += not c["same_text"]
        if c["max_z"] > worst_z[0]:
            worst_z = (c["max_z"], f"{label} {c['term']}")
        if c["nrmse_rel"] > worst_n[0]:
            worst_n = (c["nrmse_rel"], label)
        if c["max_z"] > args.show or c["nrmse_rel"] > 0.01:
            print(f"  {label}: max |change| / ci95 {c['max_z']:.3g} ({c['term']}), nrmse {c['nrmse_rel']:+.2%}")
    print(f"{len(paths)} records ({errors} refused alike or not), before = {args.before}, after = "
          f"{args.after or 'this working tree'}; load average {os.getloadavg()[0]:.1f}")
    print(f"  outputs identical in every field: {same}/{len(paths)}")
    print(f"  largest coefficient change: {worst_z[0]:.3g} of its ci95 ({worst_z[1]})")
    print(f"  largest nrmse change: {worst_n[0]:.3%} relative ({worst_n[1]})")
    print(f"  decisions and warnings identical: {len(paths) - len(differ)}/{len(paths)} (of them {figures} with a "
          "figure quoted in a reason or warning changed)")
    if args.keep:
        with open(tmp / "outputs.json", "w") as fh:
            json.dump({n: {str(p): o for p, o in r.items()} for n, r in results.items()}, fh)
    tmp_ctx.cleanup()


if __name__ == "__main__":
    main()
