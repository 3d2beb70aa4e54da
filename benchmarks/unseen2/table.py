"""Markdown scorecard of the second blind scorecard's results (see score.py, judge.py)."""

from __future__ import annotations

import math
from collections import Counter

BAD = {"NONE-ABOVE-FLOOR", "POOR-SILENT", "UNSTABLE-SILENT", "WRONG", "FALSE-ALARM", "FALSE-ALARM-NAMED", "NONE-MISSED", "CRASH",
       "TIMEOUT", "ACCEPTED", "BAD-EXIT"}


def _f(v, fmt="{:.3g}"):
    if v is None:
        return "-"
    if isinstance(v, float) and not math.isfinite(v):
        return "inf"
    return fmt.format(v)


def _pct(v):
    return "-" if v is None else ("inf" if not math.isfinite(v) else f"{100 * v:.2g} %")


def _identify_rows(res):
    rows = ["| case | m kg | f Hz | true lib | worst coef err | in ci95 | fit / held-out nrmse | warn | "
            "default lib | held-out nrmse | largest spurious (% k1 A) |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in res:
        t = r.get("true_lib") or {}
        co = t.get("coeffs") or {}
        worst = max(co.items(), key=lambda kv: kv[1]["err"], default=None)
        cov = [c["covered"] for c in co.values() if c["covered"] is not None]
        d = r.get("default_lib") or {}
        sp = d.get("spurious") or {}
        big = max(sp.items(), key=lambda kv: kv[1], default=None)
        rows.append(
            f"| {r['id']} | {_f(r['mass'])} | {_f(r['f1_hz'])} | **{r['verdict']}** | "
            f"{(worst[0] + ' ' + _pct(worst[1]['err'])) if worst else '-'} | {sum(cov)}/{len(cov)} | "
            f"{_f(t.get('fit_nrmse'))} / {_f(t.get('heldout_nrmse'))} | {len(t.get('warnings') or [])}"
            f"{' div' if t.get('diverged') else ''} | **{r.get('default_verdict', '-')}** | "
            f"{_f(d.get('heldout_nrmse'))} | {(big[0] + ' ' + _f(100 * big[1], '{:.2g}')) if big else '-'} |")
    return rows


def _diagnose_rows(res):
    rows = ["| case | hidden | cat. | effect (disp nrmse) | cause | class | baseline / floor | extended | "
            "best candidates (nrmse) | symptom needed: found | s |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in res:
        best = ", ".join(f"{n} {_f(x, '{:.2g}')}" for n, x, _ in (r.get("best") or [])[:2]) or "-"
        sym = "-" if not r.get("symptom_needed") else f"{r['symptom_needed']}: {'yes' if r['symptom_found'] else 'NO'}"
        cat = {True: "yes", False: "no", None: "-"}[r.get("catalogued")]
        rows.append(
            f"| {r['id']} | {r.get('hidden') or 'null'}{(' ' + r['strength']) if r.get('strength') else ''} | {cat} | "
            f"{_f(r.get('effect_disp_nrmse'), '{:.2g}')} | {r.get('cause', '-')} | **{r['verdict']}** | "
            f"{_f(r.get('baseline'))} / {_f(r.get('floor'))} | {_f(r.get('extended'))} | {best} | {sym} | "
            f"{_f(r.get('wall_s'), '{:.0f}')} |")
    return rows


def worst_failures(results):
    """One line per failure that matters, the worst kinds first."""
    order = ["WRONG", "FALSE-ALARM-NAMED", "POOR-SILENT", "UNSTABLE-SILENT", "NONE-ABOVE-FLOOR", "NONE-MISSED", "FALSE-ALARM", "CRASH",
             "TIMEOUT", "ACCEPTED", "BAD-EXIT"]
    lines = []
    for kind in order:
        for r in results:
            for tag, v in (("", r.get("verdict")), ("default lib: ", r.get("default_verdict"))):
                if v != kind:
                    continue
                lines.append(f"- **{kind}** {tag}{r['id']}: " + (_detail_default(r) if tag else _detail(r)))
    for r in results:
        if r.get("symptom_needed") and r.get("symptom_found") is False:
            lines.append(f"- **SYMPTOM-MISSING** {r['id']}: `{r['symptom_needed']}` not reported "
                         f"(reported: {', '.join(r.get('symptoms') or []) or 'none'})")
    return lines


def _detail(r):
    if r["kind"] == "diagnose":
        return (f"cause `{r.get('cause')}`, baseline {_f(r.get('baseline'))} vs floor {_f(r.get('floor'))}, "
                f"extended {_f(r.get('extended'))}; `{r['cmd']}`" + (f" — {r.get('stderr', '')[-200:]}"
                                                                    if r.get("stderr") else ""))
    if r["kind"] == "robust":
        return f"rc {r['rc']}, {r['stderr_lines']} stderr lines: `{r['cmd']}` — {r['stderr'][-160:]!r}"
    t = r.get("true_lib") or {}
    co = t.get("coeffs") or {}
    errs = ", ".join(f"{k} {_pct(v['err'])}" for k, v in co.items())
    return (f"{errs}; held-out nrmse {_f(t.get('heldout_nrmse'))} (default lib "
            f"{_f((r.get('default_lib') or {}).get('heldout_nrmse'))}), warnings {t.get('warnings')}; "
            f"`{t.get('cmd')}`")


def _detail_default(r):
    d = r.get("default_lib") or {}
    sp = ", ".join(f"{k} {_f(100 * v, '{:.2g}')} %" for k, v in (d.get("spurious") or {}).items())
    return (f"held-out nrmse {_f(d.get('heldout_nrmse'))}, warnings {d.get('warnings')}, spurious terms "
            f"(% of k1 A) {sp or '-'}; `{d.get('equation') or d.get('stderr', '')[-200:]}`; `{d.get('cmd')}`")


def scorecard(results, meta):
    ids = [r for r in results if r["kind"] == "identify"]
    dgs = [r for r in results if r["kind"] == "diagnose"]
    rbs = [r for r in results if r["kind"] == "robust"]
    out = [f"# Blind scorecard 2 (benchmarks/unseen2) — seed {meta['seed']}{' quick' if meta['quick'] else ''}", "",
           f"station: `{meta['station']}` PYTHONPATH `{meta['pythonpath']}` commit `{meta['git']}`; "
           f"{meta['date_utc']}; load average at the end {', '.join(f'{x:.1f}' for x in meta['load'])}; "
           f"wall {meta['wall_s']} s", ""]
    cov = [c["covered"] for r in ids for c in ((r.get("true_lib") or {}).get("coeffs") or {}).values()
           if c["covered"] is not None]
    nulls = [r for r in dgs if r.get("hidden") is None]
    eff = [r for r in dgs if r.get("hidden") is not None]
    out += ["## Summary", "",
            f"- identify (true library): {dict(Counter(r['verdict'] for r in ids))}; 95 % intervals hold the "
            f"truth for {sum(cov)}/{len(cov)} coefficients",
            f"- identify (default library): {dict(Counter(r.get('default_verdict') for r in ids))}",
            f"- diagnose nulls: {dict(Counter(r['verdict'] for r in nulls))}",
            f"- diagnose hidden effects: {dict(Counter(r['verdict'] for r in eff))} "
            f"(catalogued: {dict(Counter(r['verdict'] for r in eff if r.get('catalogued')))}; "
            f"out of catalogue: {dict(Counter(r['verdict'] for r in eff if not r.get('catalogued')))})",
            f"- bad inputs: {sum(r['verdict'] == 'ok' for r in rbs)}/{len(rbs)} one line + exit 2", ""]
    fails = worst_failures(results)
    out += ["## Failures that matter", ""] + (fails or ["- none"]) + [""]
    out += ["## Identification", ""] + _identify_rows(ids) + [""]
    out += ["## Diagnosis", ""] + _diagnose_rows(dgs) + [""]
    bad = [r for r in rbs if r["verdict"] != "ok"]
    out += ["## Bad inputs", "", f"{len(rbs) - len(bad)}/{len(rbs)} ok (exit 2, one line, no traceback)."]
    out += [f"- {r['id']}: {r['verdict']} — {_detail(r)}" for r in bad]
    return "\n".join(out) + "\n"
