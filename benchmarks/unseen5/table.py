"""The Markdown scorecard: one summary line per category, a table per part, failures with commands."""

from __future__ import annotations

PASS = {"ok", "correct", "near", "abstained", "none-weak", "warned", "flagged-unstable"}
TITLES = {"diagnose": "(a/b) diagnosis", "ident": "(c) identification", "mdof": "(d) multi-DOF",
          "robust": "(e) bad inputs"}


def _f(x, fmt="{:.3g}"):
    try:
        return fmt.format(float(x))
    except (TypeError, ValueError):
        return "-"


def passed(r):
    return r["verdict"] in PASS


def _cpu(rs):
    return sum(c.get("cpu_s") or 0 for r in rs for c in r.get("commands", []))


def summary(results):
    lines = []
    diag = [r for r in results if r["kind"] == "diagnose"]
    nulls = [r for r in diag if r["id"].startswith("null")]
    cat = [r for r in diag if r["id"].startswith("cat")]
    hid = [r for r in diag if r["id"].startswith("hid")]
    count = lambda rs, v: sum(r["verdict"] == v for r in rs)  # noqa: E731
    if nulls:
        lines.append(f"- (a) nulls: {count(nulls, 'correct')}/{len(nulls)} `none` "
                     f"(false alarms: {sum(r['verdict'].startswith('FALSE') for r in nulls)}; "
                     f"CPU {_cpu(nulls):.0f} s)")
    if cat:
        lines.append(f"- (b) catalogued effects: {count(cat, 'correct')}/{len(cat)} named right, "
                     f"{count(cat, 'abstained')} abstained, {count(cat, 'none-weak')} none-weak, "
                     f"{sum(not passed(r) for r in cat)} failed (wrong name, none above the floor, "
                     f"crash or timeout)")
    if hid:
        lines.append(f"- (b) out-of-catalogue effects: {count(hid, 'correct')}/{len(hid)} `unexplained`, "
                     f"{count(hid, 'none-weak')} none-weak, {sum(not passed(r) for r in hid)} failed")
    ident = [r for r in results if r["kind"] == "ident"]
    if ident:
        cov = [c for r in ident for c in r.get("covered", [])]
        nom = [c for r in ident for c in r.get("covered_nominal", [])]
        lines.append(f"- (c) identification: {sum(passed(r) for r in ident)}/{len(ident)} passed "
                     f"({count(ident, 'ok')} ok, {count(ident, 'warned')} warned); truth inside the printed "
                     f"95 % interval for {sum(cov)}/{len(cov)} coefficients (gain-scaled truth; "
                     f"{sum(nom)}/{len(nom)} for the nominal truth)")
    md = [r for r in results if r["kind"] == "mdof"]
    if md:
        worst = [max((r.get("held_nrmse") or {"-": float("inf")}).values()) for r in md]
        lines.append(f"- (d) multi-DOF: {sum(passed(r) for r in md)}/{len(md)} passed (worst channel nrmse "
                     f"{', '.join(_f(w) for w in worst)}; diagnose CPU "
                     f"{', '.join(_f(r['commands'][0].get('cpu_s'), '{:.0f}') + ' s' for r in md)})")
    rob = [r for r in results if r["kind"] == "robust"]
    if rob:
        lines.append(f"- (e) bad inputs: {sum(passed(r) for r in rob)}/{len(rob)} passed")
    allr = [r for r in results]
    lines.append(f"- total: {sum(passed(r) for r in allr)}/{len(allr)} passed; station CPU {_cpu(allr):.0f} s")
    return lines


def scorecard(results, meta):
    out = ["# Blind scorecard unseen5" + (" (quick)" if meta["quick"] else ""), "",
           f"seed {meta['seed']}, {meta['date_utc']}, wall {meta['wall_s']} s with --jobs {meta['jobs']}, "
           f"load average {', '.join(f'{x:.1f}' for x in meta['load'])} at the end",
           f"station: `{meta['station']}`, PYTHONPATH `{meta['pythonpath']}`, commit `{meta['git']}`",
           f"time limits judged on each command's CPU time (x{meta.get('timeout_scale', 1)}); wall-clock kill at "
           f"{meta.get('wall_factor', '-')}x the limit; station CPU in all: {meta.get('cpu_children_s', '-')} s"]
    out += [f"re-scored in a later run (replacing the cases above): {m}" for m in meta.get("merged", [])]
    out += ["",
           "## Summary", ""] + summary(results) + [""]
    by = {k: [r for r in results if r["kind"] == k] for k in TITLES}
    if by["diagnose"]:
        out += ["## (a/b) diagnosis", "",
                "| case | verdict | cause | baseline nrmse (judged) | noise floor | extended | candidates | wall / CPU s |",
                "|---|---|---|---|---|---|---|---|"]
        for r in by["diagnose"]:
            c0 = (r.get("commands") or [{}])[0]
            cands = ", ".join(f"{n} {_f(x)}" for n, x in r.get("candidates") or [])
            out.append(f"| {r['id']} | {r['verdict']} | {r.get('cause', '-')} | {_f(r.get('baseline_nrmse'))} "
                       f"({_f(r.get('judged_baseline_nrmse'))}) | {_f(r.get('noise_floor'))} | "
                       f"{_f(r.get('extended_nrmse'))} | {cands[:90]} | {c0.get('wall_s')} / {c0.get('cpu_s')} |")
        out.append("")
    if by["ident"]:
        out += ["## (c) identification (true library)", "",
                "| case | verdict | coefficient errors | inside ci95 | outside | fit nrmse | held-out nrmse | warned |",
                "|---|---|---|---|---|---|---|---|"]
        for r in by["ident"]:
            ce = ", ".join(f"{k} {100 * e:+.3f} %" for k, e in (r.get("coef_err") or {}).items())
            cov = r.get("covered", [])
            out.append(f"| {r['id']} | {r['verdict']} | {ce or '-'} | {sum(cov)}/{len(cov)} | "
                       f"{'; '.join(r.get('outside', [])) or '-'} | {_f(r.get('fit_nrmse'))} | "
                       f"{_f(r.get('held_nrmse'))} | {r.get('warned', '-')} |")
        out.append("")
    if by["mdof"]:
        out += ["## (d) multi-DOF (acc only, no mass)", "",
                "| case | verdict | cause | frequency errors | held-out nrmse per channel | diagnose wall / CPU s |",
                "|---|---|---|---|---|---|"]
        for r in by["mdof"]:
            fe = ", ".join(f"{100 * e:.2f} %" for e in r.get("freq_err", []))
            ch = ", ".join(f"{k} {_f(v)}" for k, v in (r.get("held_nrmse") or {}).items())
            c0 = (r.get("commands") or [{}])[0]
            out.append(f"| {r['id']} | {r['verdict']} | {r.get('cause', '-')} | {fe or '-'} | {ch or '-'} | "
                       f"{c0.get('wall_s')} / {c0.get('cpu_s')} |")
        out.append("")
    if by["robust"]:
        out += ["## (e) bad inputs", "", "| case | verdict | stderr |", "|---|---|---|"]
        out += [f"| {r['id']} | {r['verdict']} | {(r.get('stderr') or [''])[0][:110].replace('|', '/')} |"
                for r in by["robust"]] + [""]
    fails = [r for r in results if not passed(r)]
    out += ["## Failures and their commands", ""]
    if not fails:
        out.append("none")
    for r in fails:
        out.append(f"- **{r['id']}** {r['verdict']}:")
        for c in r.get("commands", []):
            out.append(f"  - `{c['cmd']}` -> exit {c['rc']} ({c['wall_s']} s wall, {c.get('cpu_s')} s CPU)"
                       + (f": {c['stderr_tail'][-1][:200]}" if c.get("stderr_tail") else ""))
    return "\n".join(out) + "\n"
