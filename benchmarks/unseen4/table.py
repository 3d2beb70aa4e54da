"""The Markdown scorecard: summary lines, one table per part, the failures with their commands."""

from __future__ import annotations

PASS = {"ok", "correct", "near", "abstained", "none-weak", "poor-warned", "flagged-unstable"}
TITLES = {"diagnose": "(a) diagnosis", "ident": "(b) identification", "mdof": "(c) multi-DOF",
          "robust": "(d) bad inputs"}


def _f(x, fmt="{:.3g}"):
    try:
        return fmt.format(float(x))
    except (TypeError, ValueError):
        return "-"


def _passed(r):
    return r["verdict"] in PASS


def summary(results):
    lines = []
    for kind, title in TITLES.items():
        rs = [r for r in results if r["kind"] == kind]
        if not rs:
            continue
        extra = ""
        if kind == "diagnose":
            nulls = [r for r in rs if r["id"].startswith("null")]
            eff = [r for r in rs if not r["id"].startswith("null")]
            extra = (f" (nulls `none` {sum(r['verdict'] == 'correct' for r in nulls)}/{len(nulls)}; effects "
                     f"correct {sum(r['verdict'] == 'correct' for r in eff)}, near "
                     f"{sum(r['verdict'] == 'near' for r in eff)}, failed {sum(not _passed(r) for r in eff)} "
                     f"of {len(eff)})")
        if kind == "ident":
            cov = [c for r in rs for c in r.get("covered", [])]
            extra = f" (truth inside the printed 95 % interval: {sum(cov)}/{len(cov)} coefficients)"
        lines.append(f"- {title}: {sum(_passed(r) for r in rs)}/{len(rs)} passed{extra}")
    return lines


def scorecard(results, meta):
    out = ["# Blind scorecard unseen4" + (" (quick)" if meta["quick"] else ""), "",
           f"seed {meta['seed']}, {meta['date_utc']}, wall {meta['wall_s']} s with --jobs {meta['jobs']}, "
           f"load average {', '.join(f'{x:.1f}' for x in meta['load'])} at the end",
           f"station: `{meta['station']}`, PYTHONPATH `{meta['pythonpath']}`, commit `{meta['git']}`", "",
           "## Summary", ""] + summary(results) + [""]
    by = {k: [r for r in results if r["kind"] == k] for k in TITLES}
    if by["diagnose"]:
        out += ["## (a) diagnosis", "", "| case | verdict | cause | baseline nrmse (judged) | noise floor | extended | impulse mass vs given | verdict text |",
                "|---|---|---|---|---|---|---|---|"]
        out += [f"| {r['id']} | {r['verdict']} | {r.get('cause', '-')} | {_f(r.get('baseline_nrmse'))} ({_f(r.get('judged_baseline_nrmse'))}) | "
                f"{_f(r.get('noise_floor'))} | {_f(r.get('extended_nrmse'))} | {_f(r.get('impulse_mass_pct'), '{:+.1f} %')} | "
                f"{r.get('verdict_text', '')[:160].replace('|', '/')} |"
                for r in by["diagnose"]] + [""]
    if by["ident"]:
        out += ["## (b) identification (true library)", "",
                "| case | verdict | coefficient errors | inside ci95 | fit nrmse | held-out nrmse | warned |",
                "|---|---|---|---|---|---|---|"]
        for r in by["ident"]:
            ce = ", ".join(f"{k} {100 * e:+.2f} %" for k, e in (r.get("coef_err") or {}).items())
            cov = r.get("covered", [])
            out.append(f"| {r['id']} | {r['verdict']} | {ce or '-'} | {sum(cov)}/{len(cov)} | "
                       f"{_f(r.get('fit_nrmse'))} | {_f(r.get('held_nrmse'))} | {r.get('warned', '-')} |")
        out.append("")
    if by["mdof"]:
        out += ["## (c) multi-DOF (acc only, no mass)", "",
                "| case | verdict | cause | coordinates | frequency errors | held-out nrmse per channel |",
                "|---|---|---|---|---|---|"]
        for r in by["mdof"]:
            fe = ", ".join(f"{100 * e:.2f} %" for e in r.get("freq_err", []))
            ch = ", ".join(f"{k} {_f(v)}" for k, v in (r.get("held_nrmse") or {}).items())
            out.append(f"| {r['id']} | {r['verdict']} | {r.get('cause', '-')} | {r.get('coordinates', '-')} | "
                       f"{fe or '-'} | {ch or '-'} |")
        out.append("")
    if by["robust"]:
        out += ["## (d) bad inputs", "", "| case | verdict | stderr |", "|---|---|---|"]
        out += [f"| {r['id']} | {r['verdict']} | {(r.get('stderr') or [''])[0][:110].replace('|', '/')} |"
                for r in by["robust"]] + [""]
    fails = [r for r in results if not _passed(r)]
    out += ["## Failures and their commands", ""]
    if not fails:
        out.append("none")
    for r in fails:
        out.append(f"- **{r['id']}** {r['verdict']}:")
        for c in r.get("commands", []):
            out.append(f"  - `{c['cmd']}` -> exit {c['rc']} ({c['wall_s']} s)"
                       + (f": {c['stderr_tail'][-1][:200]}" if c.get("stderr_tail") else ""))
    return "\n".join(out) + "\n"
