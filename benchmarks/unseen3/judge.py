"""Judgement of each command's output against the manifest's truth (pure functions, no I/O).

Verdicts in capitals are failures; lower case are passes or honest abstentions.
"""

from __future__ import annotations

import math

POOR = 0.10            # held-out nrmse above which a 1-DOF fit is poor
MDOF_OK = 0.05         # issue 14's per-channel held-out target
FREQ_TOL = 0.03        # modal frequencies and coupling within 3 %
STIFF_TOL, LIN_TOL, DAMP_TOL = 0.05, 0.02, 0.15
SAME = 1e-6            # "the same model" across commands (relative)
NONE_ABOVE = 0.15      # a `none` above this held-out error is not silence earned


def rel(a, b):
    if a is None or b is None:
        return math.inf
    try:
        a, b = float(a), float(b)
    except (TypeError, ValueError):
        return math.inf
    if not (math.isfinite(a) and math.isfinite(b)):
        return math.inf
    return abs(a - b) / max(abs(b), 1e-300)


def coeffs_of(obj):
    """damping + stiffness dicts of an identify / replay / report / diagnose / model JSON."""
    if not isinstance(obj, dict):
        return None
    for key in ("identified", "model"):
        if isinstance(obj.get(key), dict) and "stiffness" in obj[key] and "stiffness" not in obj:
            obj = obj[key]
    d, s = obj.get("damping"), obj.get("stiffness")
    if not isinstance(d, dict) or not isinstance(s, dict):
        return None
    return {**{"d:" + k: v for k, v in d.items()}, **{"s:" + k: v for k, v in s.items()}}


def model_diff(a, b):
    """Largest relative difference over the union of terms (a missing term counts as inf)."""
    if a is None or b is None:
        return math.inf
    return max((rel(a.get(k), b.get(k)) for k in set(a) | set(b)), default=0.0)


def warned(out):
    """Any warning, flag or divergence in an identify JSON."""
    if not isinstance(out, dict):
        return False
    v = out.get("validation") or {}
    return bool(out.get("warnings") or v.get("warnings") or v.get("diverged")
                or any(r.get("warnings") or r.get("diverged") for r in (out.get("held_out") or {}).get("records", [])))


def coefficient_table(case, out):
    """Per true term: identified value, relative error, ci95 holds the truth, and whether it is scored
    (its force at the blow's amplitude is >= 5 % of k A for stiffness, >= 20 % of c V for damping)."""
    truth, a, v = case["truth"], case["amp_m"], case["vel_ms"]
    k, c = truth["stiffness"].get("x", 0.0), truth["damping"].get("v", 0.0)
    rows = []
    for kind, key in (("damping", "damping"), ("stiffness", "stiffness")):
        got, ci = out.get(key) or {}, (out.get("ci95") or {}).get(key) or {}
        for term, true in truth[key].items():
            if term not in case["library"][key]:
                continue
            x = v if kind == "damping" else a
            power = _degree(term)
            force = abs(true) * x ** power
            ref = abs(c) * v if kind == "damping" else abs(k) * a
            scored = force >= (0.2 if kind == "damping" else 0.05) * ref
            val = got.get(term)
            err = rel(val, true)
            half = ci.get(term)
            covers = None if half is None or val is None else abs(float(val) - true) <= float(half)
            tol = DAMP_TOL if kind == "damping" else (LIN_TOL if term == "x" else STIFF_TOL)
            rows.append({"term": term, "true": true, "got": val, "err": err, "ci95": half, "covers": covers,
                         "scored": scored, "tol": tol, "ok": err <= tol or not scored})
    return rows


def _degree(term):
    deg = 0
    for f in term.replace("abs(", "").replace(")", "").split("*"):
        deg += int(f.split("^")[1]) if "^" in f else 1
    return deg


def quirk_verdict(rows, heldout, out):
    bad = [r for r in rows if not r["ok"]]
    poor = heldout is None or heldout > POOR
    if not bad and not poor:
        return "ok"
    return "poor-warned" if warned(out) else "POOR-SILENT"


def run_failure(res):
    """Verdict of a command that did not give JSON."""
    if res["rc"] is None:
        return "TIMEOUT"
    if "Traceback" in (res.get("stderr") or ""):
        return "CRASH"
    return "REFUSED" if res["rc"] == 2 else "CRASH"


def diagnose_verdict(case, out, baseline):
    cause = (out or {}).get("cause")
    hidden = case["hidden"]
    if hidden is None:
        if cause == "none":
            return "correct"
        return "FALSE-ALARM-UNEXPLAINED" if cause == "unexplained" else "FALSE-ALARM-NAMED"
    if cause in case["expect"]:
        return "correct"
    if cause in case.get("near", []):
        return "near"
    if cause == "none":
        return "NONE-ABOVE-FLOOR" if (baseline or 0) > NONE_ABOVE else "none-weak"
    if cause == "unexplained":
        return "abstained"
    return "WRONG-NAMED" if not case["catalogued"] else "WRONG"


def symptom_found(case, out):
    want = case.get("symptom")
    if not want:
        return None
    kinds = [str(s.get("kind", "")) for s in (out or {}).get("symptoms") or [] if isinstance(s, dict)]
    return any(want in k for k in kinds)


def mdof_scores(case, out, model, validation):
    """Frequencies, coupling coefficients and per-channel held-out nrmse of a multi-channel diagnosis."""
    res = {"cause": (out or {}).get("cause"), "coordinates": (out or {}).get("coordinates")}
    got = sorted((out or {}).get("natural_frequencies_hz") or (out or {}).get("linear_modes_hz") or [])
    errs = []
    for f in case["freqs_hz"]:
        near = min(got, key=lambda g: abs(g - f)) if got else None
        errs.append(rel(near, f))
    res["freqs_hz"], res["freq_err"] = got, errs
    res["coupling_err"] = _coupling_errors(case, model) if res["coordinates"] == "physical" else None
    ch = (validation or {}).get("channel_nrmse") or {}
    res["channel_nrmse"] = ch
    flags = []
    if res["cause"] not in case["expect"]:
        flags.append("WRONG-CAUSE")
    if not errs or max(errs) > FREQ_TOL:
        flags.append("FREQ-OFF")
    if res["coupling_err"] and max(e for _, e in res["coupling_err"]) > FREQ_TOL:
        flags.append("COUPLING-OFF")
    if not ch or max(v if v is not None else math.inf for v in ch.values()) > MDOF_OK:
        flags.append("CHANNEL-NRMSE>0.05")
    res["verdict"] = "+".join(flags) if flags else "ok"
    return res


def _coupling_errors(case, model):
    """Relative errors of the true cubic monomials (>= 10 % of the equation's largest) in physical
    coordinates; the model's names canonicalised (factors sorted by coordinate)."""
    truth = case.get("coupling")
    if not truth or not isinstance(model, dict) or not isinstance(model.get("stiffness"), list):
        return None
    out = []
    for i, eq in enumerate(truth):
        if not eq or i >= len(model["stiffness"]):
            continue
        got = {_canon(k): v for k, v in (model["stiffness"][i] or {}).items()}
        top = max(abs(v) for v in eq.values())
        for term, true in eq.items():
            if abs(true) >= 0.1 * top:
                out.append((f"eq{i + 1}:{term}", rel(got.get(term), true)))
    return out


def _canon(term):
    return "*".join(sorted(term.split("*"), key=lambda f: f.split("^")[0]))


def robust_verdict(res, changed):
    lines = [ln for ln in (res.get("stderr") or "").splitlines() if ln.strip()]
    if changed:
        return "CLOBBERED"
    if res["rc"] is None:
        return "TIMEOUT"
    if "Traceback" in (res.get("stderr") or ""):
        return "CRASH"
    if res["rc"] == 0:
        return "ACCEPTED-BAD-INPUT"
    if res["rc"] != 2:
        return f"EXIT-{res['rc']}"
    return "ok" if len(lines) == 1 else f"STDERR-{len(lines)}-LINES"
