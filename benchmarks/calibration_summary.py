"""The ``--summary`` of benchmarks/bench_diagnose_calibration.py: rates per set, null family,
mechanism and rung from the JSON lines of earlier runs (split from the runner so each file has
one job)."""

from __future__ import annotations

import json
import math
from collections import defaultdict

import numpy as np

from bench_diagnose_calibration import CHAIN_FAULTS, SETS


def _key_order(k: str) -> tuple[float, float]:
    f, strong = k.split("|")
    return float(f), (math.inf if strong == "None" else float(strong))


def rejudge(row: dict) -> dict:
    """The row's verdicts under the current :func:`eddi.diagnosis.earn.earn`, from the verdicts
    ``decide`` gave (``decided``), the ratio and the stored symptoms (rows of an earlier rule)."""
    from eddi.diagnosis.earn import earn
    from eddi.diagnosis.name import Decision
    from eddi.diagnosis.results import Symptom

    if "decided" not in row:
        return row
    sy = [Symptom(k, "", {n: float(v) for n, v in vals.items()}) for k, vals, _n in row["symptoms"]]

    def one(cause: str) -> str:
        return earn(Decision(cause, None, None, cause == "none", ""), row["ratio"], sy).cause

    out = dict(row)
    out["causes"] = {k: one(c) for k, c in row["decided"].items()}
    # the named-factor verdicts are stored after the rule of their run; the rule only adds
    # reasons for `unexplained`, so applying the current one to them again is the same
    out["named_causes"] = {k: one(c) for k, c in row.get("named_causes", {}).items()}
    return out


def summary(path: str, factor: float, strong: float | None, again: bool = False, nochain: bool = False) -> None:
    """Print the rates of the rows in ``path`` (``nochain``: the session-8 floor's verdicts;
    ``again``: :func:`rejudge` every row)."""
    rows = [json.loads(s) for s in open(path) if s.strip()]
    if nochain:  # the session-8 floor's verdicts of the same diagnoses
        rows = [{**r, "causes": r["causes_nochain"], "named_causes": r["named_causes_nochain"],
                 "ratio": r["ratio_nochain"]} if "causes_nochain" in r else r for r in rows]
    if again:
        rows = [rejudge(r) for r in rows if "error" not in r] + [r for r in rows if "error" in r]
    key = f"{factor:g}|{strong}"
    for set_name in SETS:
        failed = [r for r in rows if r.get("kind") == "null" and r["set"] == set_name and "error" in r]
        if failed:
            print(f"[{set_name}] nulls refused: {len(failed)} (" + "; ".join(f"seed {r['seed']}: {r['error']}"
                                                                          for r in failed) + ")")
        nulls = [r for r in rows if r.get("kind") == "null" and r["set"] == set_name and "error" not in r]
        for fam in ("", "chain", "chain-stiff"):
            _family_line(set_name, [r for r in nulls if r.get("family", "") == fam], key, fam)
        if nulls:
            ratios = sorted(r["ratio"] for r in nulls)
            multi = sum(r["captures"] >= 6 for r in nulls)
            print(f"[{set_name}] nulls: {len(nulls)} ({multi} six-capture sets from two rig runs); "
                  f"baseline/floor ratio median {ratios[len(ratios) // 2]:.2f}, 95th pct "
                  f"{ratios[int(0.95 * (len(ratios) - 1))]:.2f}, max {ratios[-1]:.2f}")
            _null_ranges(nulls)
            for f in sorted({k for r in nulls for k in r["causes"]}, key=_key_order):
                bad = [r for r in nulls if r["causes"][f] != "none"]
                named = [r for r in bad if r["causes"][f] != "unexplained"]
                fac, st = f.split("|")
                print(f"   none factor {fac:>4}, strong cut {st:>4}: false alarms {len(bad)}/{len(nulls)} "
                      f"(named {len(named)}"
                      + (": " + ", ".join(f"seed {r['seed']} {r['causes'][f]}" for r in named) if named else "")
                      + ")")
        lad = [r for r in rows if r.get("kind") == "ladder" and r["set"] == set_name]
        if not lad:
            continue
        print(f"[{set_name}] ladders at none factor {factor:g}, strong cut {strong} (rates over seeds; "
              "ratio = baseline/floor median)")
        groups = defaultdict(list)
        for r in lad:
            groups[(r["mechanism"], r["magnitude"])].append(r)
        for (name, mag), g in sorted(groups.items()):
            ok = [r for r in g if "error" not in r]
            n = len(g)
            c = [r["causes"].get(key, "?") for r in ok]
            if name in CHAIN_FAULTS:  # found: unexplained with the fault's own symptom; a fault that
                # is reported without overturning the verdict (double hits since session 10,
                # eddi.diagnosis.earn.REPORTED_KINDS): its symptom with `none` or `unexplained`
                from eddi.diagnosis.earn import REPORTED_KINDS

                verdicts = ("none", "unexplained") if CHAIN_FAULTS[name] in REPORTED_KINDS else ("unexplained",)
                c = [name if (x in verdicts and any(sy[0] == CHAIN_FAULTS[name] for sy in r["symptoms"]))
                     else x for x, r in zip(c, ok)]
            found, unex, none = c.count(name), c.count("unexplained"), c.count("none")
            wrong = [x for x in c if x not in (name, "unexplained", "none")]
            ratio = np.median([r["ratio"] for r in ok]) if ok else float("nan")
            print(f"   {name:<21} {mag:<6g} found {found}/{n}  unexplained {unex}/{n}  none {none}/{n}  "
                  f"wrong {len(wrong)}/{n}{' ' + ','.join(wrong) if wrong else ''}  refused {n - len(ok)}/{n}  "
                  f"ratio {ratio:.2f}")
        _named_table(nulls, lad)
        cpu = [r["cpu_s"] for r in rows if r.get("set") == set_name and "cpu_s" in r]
        if cpu:
            print(f"[{set_name}] CPU per case median {np.median(cpu):.1f} s, max {max(cpu):.1f} s")


def _family_line(set_name: str, nulls: list, key: str, family: str) -> None:
    """One line per null family: false alarms at the table's factor, the baseline/floor ratio
    and (chain family) the chain's share of the floor and what the sets spanned."""
    if not nulls:
        return
    bad = [r for r in nulls if r["causes"].get(key, "none") != "none"]
    ratios = sorted(r["ratio"] for r in nulls)
    line = (f"[{set_name}] {family or 'rig-seed'} nulls: {len(nulls)}, false alarms {len(bad)} at {key}"
            + (" (" + ", ".join(f"seed {r['seed']} {r['causes'][key]} {r['ratio']:.2f}x" for r in bad) + ")" if bad else "")
            + f"; baseline/floor median {ratios[len(ratios) // 2]:.2f}, max {ratios[-1]:.2f}")
    if family.startswith("chain"):
        ch = [max(r.get("chain_nrmse") or [0.0]) for r in nulls]
        gains = [100 * abs(c[0]) for r in nulls for c in r["chains"]]
        clocks = [abs(c[2]) for r in nulls for c in r["chains"]]
        m = [r["mass_kg"] for r in nulls]
        kinds = {k: sum(r["spring"] == k for r in nulls) for k in ("soft", "hard", "asymmetric")}
        line += (f"; chain share of the floor max per set median {np.median(ch):.3f}, max {max(ch):.3f}; "
                 f"{kinds}, strong {sum(r['strong'] for r in nulls)}; masses {min(m):.3g}-{max(m):.3g} kg; "
                 f"gains up to {max(gains):.2f} %, clocks up to {max(clocks):.0f} ppm; "
                 f"captures {min(r['captures'] for r in nulls)}-{max(r['captures'] for r in nulls)}; "
                 f"cycles {min(r['record_s'] * r['f1_hz'] for r in nulls):.0f}-"
                 f"{max(r['record_s'] * r['f1_hz'] for r in nulls):.0f}")
    print(line)


def _null_ranges(nulls: list) -> None:
    """What the nulls span (masses, springs, rates, SNR), the impulse/momentum ratio's bias
    (the impulse-mass check's tolerance is set against it) and the chain findings on them."""
    from eddi.diagnosis.chain import IMPULSE_MASS_TOLERANCE
    from eddi.diagnosis.earn import CHAIN_KINDS

    m = [r["mass_kg"] for r in nulls]
    snr = [r["snr_db"] for r in nulls]
    rates = sorted({int(r["rate_hz"]) for r in nulls})
    soft = sum(r["spring"] == "soft" for r in nulls)
    print(f"   masses {min(m):.3f}-{max(m):.3f} kg; {soft} soft, {len(nulls) - soft} hard springs; "
          f"rates {', '.join(str(x) for x in rates)} Hz; SNR {min(snr):.1f}-{max(snr):.1f} dB")
    imp = [abs(r["impulse_mass"][0] - 1.0) for r in nulls if r.get("impulse_mass")]
    if imp:
        print(f"   impulse/momentum |ratio - 1|: median {100 * float(np.median(imp)):.2f} %, max "
              f"{100 * max(imp):.2f} % (tolerance {100 * IMPULSE_MASS_TOLERANCE:g} %)")
    chain = [(r["seed"], sy[0]) for r in nulls for sy in r.get("symptoms", []) if sy[0] in CHAIN_KINDS]
    print(f"   chain findings on the nulls: {len(chain)}" + (f" ({chain})" if chain else ""))


def _named_table(nulls: list, lad: list) -> None:
    """Per named factor: nulls named, ladder rungs found / unexplained / wrong, and the largest
    extended/floor ratio of a correctly named case."""
    have = [r for r in lad if "named_causes" in r and r["mechanism"] not in CHAIN_FAULTS]
    if not have:
        return
    print("   named factor (extended model within F x floor): rungs found / unexplained / none / wrong; "
          "nulls named")
    for nf in sorted({k for r in have for k in r["named_causes"]}, key=float):
        c = [(r["named_causes"][nf], r["mechanism"]) for r in have]
        found = sum(x == m for x, m in c)
        wrong = [f"{m}->{x}" for x, m in c if x not in (m, "unexplained", "none")]
        named_nulls = sum(r.get("named_causes", {}).get(nf, "none") not in ("none", "unexplained") for r in nulls)
        print(f"     F {nf:>4}: {found} / {sum(x == 'unexplained' for x, _ in c)} / {sum(x == 'none' for x, _ in c)}"
              f" / {len(wrong)}{' (' + ', '.join(wrong) + ')' if wrong else ''} of {len(c)}; "
              f"nulls named {named_nulls}/{len(nulls)}")
    ok = []
    for r in have:
        cand = {c[0]: c[1] for c in r["candidates"]}
        if r["named_causes"].get("inf") == r["mechanism"] and r["mechanism"] in cand:
            ok.append(cand[r["mechanism"]] / r["floor"])
    if ok:
        print(f"     right cause named with no factor: extended/floor median {np.median(ok):.2f}, "
              f"max {max(ok):.2f} ({len(ok)} cases)")


if __name__ == "__main__":  # the runner's command line (use it with --summary FILE)
    from bench_diagnose_calibration import main

    main()
