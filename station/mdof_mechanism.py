"""The mechanisms of a multi-channel diagnosis: which nonlinear elements the lumped model holds.

``station diagnose`` on multi-channel captures names ``modal_coupling`` when a coupled model
earns its place held out; when that model is the lumped-element fit (:mod:`eddi.mdof.lumped`)
its nonlinear elements say what the coupling is - a cubic spring, a quadratic (asymmetric)
spring or a cubic damper between two given masses. This module writes them into the diagnosis
object (``mechanisms``: every nonlinear element with value, unit, 95 % half-width and whether
it is determined; ``mechanism``: the determined couplings in words, or None) and prints them.

The values are those of the identification on every capture (before the polish, which moves
the model's constants by a few 0.1 %: the polished ones are in the saved model's notes).
"""

from __future__ import annotations

from typing import Any

from eddi.mdof.mechanisms import mechanisms, named_coupling


def add_mechanisms(obj: dict[str, Any], final: Any) -> None:
    """``mechanisms`` and ``mechanism`` of the identification ``final`` into ``obj`` (in place)."""
    fit = getattr(final, "lumped", None)
    found = mechanisms(fit.constants, fit.ci95) if fit is not None else ()
    obj["mechanisms"] = [m.as_dict() for m in found]
    obj["mechanism"] = (named_coupling(found) or None) if obj.get("cause") == "modal_coupling" else None


def mechanism_lines(obj: dict[str, Any]) -> list[str]:
    """Lines for the printout (none when the model holds no lumped nonlinear element)."""
    found = obj.get("mechanisms") or []
    if not found:
        return []
    lines = [f"Mechanism: {obj['mechanism']}"] if obj.get("mechanism") else []
    for m in found:
        ci = "" if m["ci95"] is None else f" +- {m['ci95']:.2g}"
        lines.append(f"  {m['name']}: {m['kind']} = {m['value']:.4g}{ci} {m['unit']}"
                     + ("" if m["determined"] else " (not determined: its 95 % interval holds zero)"))
    return lines
