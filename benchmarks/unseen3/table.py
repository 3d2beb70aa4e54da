"""The Markdown scorecard of the third blind set."""

from __future__ import annotations

import math


def _f(x, fmt="{:.3g}"):
    if x is None:
        return "-"
    if isinstance(x, float) and not math.isfinite(x):
        return "inf"
    try:
        return fmt.format(x)
    except (TypeError, ValueError):
        return str(x)


def _pct(x):
    return "-" if x is None else ("inf" if not math.isfinite(x) else f"{100 * x:.2g} %")


def failed(v):
    return any(c.isupper() for c in str(v))


def _section(title, header, rows):
    if not rows:
        return []
    out = [f"### {title}", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return out + [""]


def scorecard(results, meta):
    lines = [f"# Third blind scorecard (`benchmarks/unseen3`), seed {meta['seed']}{' quick' if meta['quick'] else ''}",
             "", f"{meta['date_utc']}; checkout `{meta['git']}`; {meta['wall_s']} s wall with --jobs {meta['jobs']}; "
             f"load average at the end {', '.join(f'{x:.1f}' for x in meta['load'])}.", ""]
    kinds = {}
    for r in results:
        kinds.setdefault(r["kind"], []).append(r)
    summary = []
    for kind, rs in kinds.items():
        verdicts = [r["verdict"] for r in rs] + [r["default_verdict"] for r in rs if "default_verdict" in r]
        summary.append((kind, len(rs), sum(not failed(v) for v in verdicts), sum(failed(v) for v in verdicts)))
    lines += _section("Summary", ["part", "rows", "verdicts passed", "verdicts failed"], summary)
    lines += _section("(a) one capture, every command (#9)", ["row", "verdict", "model diff", "held-out nrmse",
                                                             "nrmse diff", "s"],
                      [(r["id"], r["verdict"], _f(r.get("model_diff")), _f(r.get("heldout_nrmse")),
                        _f(r.get("nrmse_diff")), _wall(r))
                       for r in kinds.get("consistency", [])])
    lines += _section("(b) several sensors (#14)", ["case", "system", "verdict", "cause", "coords", "freq err",
                                                    "worst coupling err", "held-out nrmse per channel", "s"],
                      [(r["id"], r.get("system", ""), r["verdict"], r.get("cause", "-"), r.get("coordinates", "-"),
                        ", ".join(_pct(e) for e in r.get("freq_err") or []) or "-",
                        (lambda ce: f"{ce[0]} {_pct(ce[1])}" if ce else "-")(
                            max(r.get("coupling_err") or [], key=lambda t: t[1], default=None)),
                        ", ".join(f"{k} {_f(v)}" for k, v in (r.get("channel_nrmse") or {}).items()) or "-",
                        _wall(r)) for r in kinds.get("mdof", [])])
    lines += _section("(c) record quirks (true library; default library)",
                      ["case", "what", "samples/cycle", "verdict", "worst scored coefficient", "ci95 covers",
                       "held-out nrmse", "default lib", "default nrmse", "s"],
                      [(r["id"], r["what"], r["samples_per_cycle"], r["verdict"], _worst(r.get("coeffs")),
                        _covers(r.get("coeffs")), _f(r.get("heldout_nrmse")), r.get("default_verdict", "-"),
                        _f(r.get("default_nrmse")), _wall(r))
                       for r in kinds.get("quirk", [])])
    lines += _section("(d) diagnosis: nulls and hidden effects",
                      ["case", "hidden", "in catalogue", "verdict", "cause", "baseline (pipeline / per fold)", "floor", "extended",
                       "symptoms", "s"],
                      [(r["id"], r.get("hidden") or "null", "yes" if r.get("catalogued") else "no", r["verdict"],
                        r.get("cause", "-"), f"{_f(r.get('baseline'))} / {_f(r.get('judged_baseline'))}", _f(r.get("floor")), _f(r.get("extended")),
                        _symptoms(r), _wall(r)) for r in kinds.get("diagnose", [])])
    lines += _section("(e) bad inputs", ["case", "verdict", "exit", "stderr lines", "first line"],
                      [(r["id"], r["verdict"], r["cmds"][0]["rc"], r["stderr_lines"],
                        (r["cmds"][0].get("stderr") or "").splitlines()[0][:110].replace("|", "/")
                        if r["cmds"][0].get("stderr") else "") for r in kinds.get("robust", [])])
    fails = [r for r in results if failed(r["verdict"]) or failed(r.get("default_verdict", ""))]
    lines += ["## Failures, with the commands (run in the data folder)", ""]
    if not fails:
        lines.append("None.")
    for r in fails:
        lines.append(f"- **{r['id']}**: {r['verdict']}" + (f" (default library: {r['default_verdict']})"
                                                         if failed(r.get("default_verdict", "")) else ""))
        for c in r["cmds"]:
            err = (c.get("stderr") or "").strip().splitlines()
            lines.append(f"  - `cd {meta['data']} && {c['cmd']}` -> exit {c['rc']}"
                         + (f": {err[-1][:200]}" if err else ""))
    return "\n".join(lines) + "\n"


def _worst(rows):
    scored = [r for r in rows or [] if r["scored"]]
    if not scored:
        return "-"
    w = max(scored, key=lambda r: r["err"] / r["tol"])
    return f"{w['term']} {_pct(w['err'])}"


def _covers(rows):
    c = [r["covers"] for r in rows or [] if r["scored"] and r["covers"] is not None]
    return f"{sum(c)}/{len(c)}" if c else "-"


def _symptoms(r):
    s = ", ".join(x for x in r.get("symptoms") or [] if x)
    if r.get("symptom_needed"):
        s += f" (needed {r['symptom_needed']}: {'found' if r.get('symptom_found') else 'MISSING'})"
    return s or "-"


def _wall(r):
    return f"{sum(c.get('wall_s') or 0 for c in r['cmds']):.0f}"
