"""Judgement of the station's answers against the truth of ``manifest.json`` (pure functions).

identify
    Coefficient error ``|est - true| / |true|`` per term of the true library; *covered* when
    the printed 95 % interval holds the *apparent* truth, i.e. the truth as the records can
    show it: the DAQ's clock error ``e`` (stamps ``k / fs`` while sampling at ``fs (1 + e)``)
    turns a term ``x^a v^b`` coefficient ``c`` into ``c (1 + e)^(b - 2)`` for a given mass,
    and the accelerometer's gain ``g`` into ``c g^(1 - a - b)`` (1 on the fit records:
    their sensor does not drift); both are below 0.03 % here. The verdict of a run:

    * ``ok``: every true term within TOL (5 %; 20 % for the smooth friction's ``sign(v)``,
      which only approximates ``fc tanh(v / vs)``) and held-out nrmse <= POOR (0.1);
    * ``poor-warned``: not ok, and the station said so (``warnings`` non-empty or
      ``validation.diverged``);
    * ``POOR-SILENT``: not ok and no warning (the failure that matters);
    * for a van der Pol-like record (negative linear damping, a growing response):
      ``flagged`` or ``UNSTABLE-SILENT``.

diagnose
    ``correct`` (the cause is one of ``expect``), ``near`` (a look-alike that is physically
    defensible), ``abstained`` (``unexplained`` where a catalogued cause was hidden),
    ``NONE-ABOVE-FLOOR`` (``none`` while the baseline's held-out nrmse exceeds POOR_FIT =
    0.15: the station calls a poor fit silence, so its stated floor is too high), else
    ``none-weak`` (``none`` for a weak effect the baseline absorbed) or ``NONE-MISSED``
    (``none`` for a strong one), ``WRONG`` (a confident mechanism name that is not the hidden one),
    ``FALSE-ALARM`` / ``FALSE-ALARM-NAMED`` on nulls, ``refused`` (exit 2, one line; correct
    where the case expects it), ``CRASH`` (traceback or another exit code), ``TIMEOUT``.
"""

from __future__ import annotations

import math

TOL = 0.05
TOL_FRICTION = 0.20
POOR = 0.10
POOR_FIT = 0.15


def basis(term, x, v):
    """Value of a term at ``(x, v)``."""
    table = {"v": v, "x": x, "x^2": x * x, "x^3": x ** 3, "x^4": x ** 4, "x^5": x ** 5, "x^2*v": x * x * v,
             "v^3": v ** 3, "abs(v)*v": abs(v) * v, "abs(x)*x": abs(x) * x, "sign(v)": 1.0 if v > 0 else -1.0,
             "sign(x)": 1.0 if x > 0 else -1.0, "x*v": x * v, "v^2": v * v}
    return table.get(term)


def _powers(term):
    """Total powers ``(a, b)`` of ``x`` and ``v`` in a term (``abs`` counts, ``sign`` does not)."""
    a = b = 0
    for factor in term.split("*"):
        base, _, p = factor.partition("^")
        p = int(p) if p else 1
        if base in ("x", "abs(x)"):
            a += p
        elif base in ("v", "abs(v)"):
            b += p
    return a, b


def apparent_truth(case):
    """Truth as the training record shows it (clock error and mean accelerometer gain)."""
    ch = case["records"][0]["chain"]
    e = ch.get("ppm", 0.0) * 1e-6
    g = ch.get("acc_gain", 1.0) * (1.0 + ch.get("drift", 0.0) / 2.0)
    out = {}
    for group in ("damping", "stiffness"):
        for term, c in case["truth"][group].items():
            a, b = _powers(term)
            out[term] = c * (1.0 + e) ** (b - 2) * g ** (1 - a - b)
    return out


def coefficient_table(case, out):
    """Per true term: estimate, relative error, interval, covered (apparent truth)."""
    app = apparent_truth(case)
    rows = {}
    for group in ("damping", "stiffness"):
        for term, true in case["truth"][group].items():
            est = (out.get(group) or {}).get(term)
            ci = ((out.get("ci95") or {}).get(group) or {}).get(term)
            if est is None:
                rows[term] = {"true": true, "est": None, "err": math.inf, "ci95": ci, "covered": False}
                continue
            covered = None if ci is None else abs(est - app[term]) <= ci
            rows[term] = {"true": true, "est": est, "err": abs(est - true) / abs(true), "ci95": ci,
                          "covered": covered}
    return rows


def spurious(case, out):
    """Terms the station kept that the truth lacks: force at the typical amplitude over k1 A."""
    k1 = case["truth"]["stiffness"]["x"]
    amp = case["amplitude_m"]
    vel = amp * 2 * math.pi * case["f1_hz"]
    res = {}
    for group in ("damping", "stiffness"):
        for term, c in (out.get(group) or {}).items():
            if term in case["truth"][group] or (term == "sign(v)" and "friction" in case["system"]):
                continue
            val = basis(term, amp, vel if group == "damping" else 0.0)
            if val is None and group == "damping":
                val = basis(term, amp, vel)
            if val is not None:
                res[term] = abs(c * val) / (k1 * amp)
    return res


def warned(out):
    """True when the station flagged its model (warnings or a diverged validation)."""
    if not out:
        return False
    val = out.get("validation") or {}
    return bool(out.get("warnings")) or bool(val.get("diverged")) or bool(val.get("warnings"))


def identify_verdict(case, coeffs, heldout_nrmse, out):
    """Verdict of one identification run (see the module docstring)."""
    if out is None:
        return "CRASH"
    if case.get("unstable"):
        return "flagged" if warned(out) else "UNSTABLE-SILENT"
    worst = 0.0
    for term, row in coeffs.items():
        tol = TOL_FRICTION if term == "sign(v)" else TOL
        worst = max(worst, row["err"] / tol)
    good = worst <= 1.0 and heldout_nrmse is not None and heldout_nrmse <= POOR
    if good:
        return "ok"
    return "poor-warned" if warned(out) else "POOR-SILENT"


def diagnose_verdict(case, rc, out, stderr):
    """Class of one diagnosis run (see the module docstring)."""
    if rc is None:
        return "TIMEOUT"
    if rc == 2 and "Traceback" not in stderr:
        return "refused-ok" if "refused" in case["expect"] else "refused"
    if rc != 0 or out is None:
        return "CRASH"
    cause = out.get("cause")
    if case["hidden"] is None:
        if cause == "none":
            return "correct"
        return "FALSE-ALARM" if cause == "unexplained" else "FALSE-ALARM-NAMED"
    if cause in case["expect"]:
        return "correct"
    if cause in case["near"]:
        return "near"
    if cause == "unexplained":
        return "abstained"
    if cause == "none":
        base = (out.get("baseline") or {}).get("nrmse")
        if base is not None and base > POOR_FIT:
            return "NONE-ABOVE-FLOOR"
        return "NONE-MISSED" if case["strength_tag"] == "strong" else "none-weak"
    return "WRONG"


def symptom_found(case, out, stderr):
    """Whether the symptom the case needs was reported (None when it needs none)."""
    need = case.get("symptom")
    if not need:
        return None
    if out is None:
        return need.split("_")[0] in (stderr or "").lower() or ("clip" in (stderr or "").lower() and need == "clipping")
    return any(s.get("kind") == need for s in out.get("symptoms") or [])
