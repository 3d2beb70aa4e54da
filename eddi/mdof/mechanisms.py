"""The nonlinear elements of a lumped fit named as mechanisms, for the verdict and the model.

A lumped fit (:mod:`eddi.mdof.lumped`) keeps element constants between the masses and the
ground: ``k3`` cubic spring, ``k2`` quadratic (asymmetric) spring, ``c3`` cubic damper. This
module turns each nonlinear one into a frozen :class:`Mechanism` with its words ("quadratic
spring between masses 1-2"), unit, value and 95 % half-width, and says which of them are
determined by the records (the value outside its interval). ``station diagnose`` prints them
beside ``modal_coupling`` and writes them in the JSON (``mechanisms``); the model's notes carry
the same words (:func:`mechanism_note`).

No I/O.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from eddi.mdof.lumped import NONLINEAR_KINDS, Element

#: Words and SI unit of each nonlinear kind.
KIND_WORDS = {"k3": ("cubic spring", "N/m^3"), "k2": ("quadratic spring", "N/m^2"),
              "c3": ("cubic damper", "N s^3/m^3")}


@dataclass(frozen=True)
class Mechanism:
    """One nonlinear element of a lumped fit.

    Attributes
    ----------
    element : str
        The fit's label (``k2(1-2)``).
    kind : str
        ``k3``, ``k2`` or ``c3``.
    between : tuple of int
        Nodes (0 = ground, 1.. the masses in channel order).
    name : str
        In words: "quadratic spring between masses 1-2", "cubic spring from mass 1 to the ground".
    value, ci95 : float
        Constant and 95 % half-width [``unit``]; ci95 NaN when not estimated.
    unit : str
    coupling : bool
        Between two masses (not to the ground).
    determined : bool
        The value lies outside its 95 % interval.
    """

    element: str
    kind: str
    between: tuple[int, int]
    name: str
    value: float
    ci95: float
    unit: str
    coupling: bool
    determined: bool

    def as_dict(self) -> dict:
        return {"element": self.element, "kind": self.kind, "between": list(self.between), "name": self.name,
                "value": self.value, "ci95": None if math.isnan(self.ci95) else self.ci95, "unit": self.unit,
                "coupling": self.coupling, "determined": self.determined}

    def text(self) -> str:
        ci = "" if math.isnan(self.ci95) else f" +- {self.ci95:.2g}"
        return (f"{self.name} ({self.kind} = {self.value:.4g}{ci} {self.unit}"
                f"{'' if self.determined else '; not determined: its 95 % interval holds zero'})")


def mechanism_name(e: Element) -> str:
    """``e`` in words ("cubic damper between masses 1-2", "cubic spring from mass 2 to the ground")."""
    words = KIND_WORDS.get(e.kind, (e.kind, ""))[0]
    return f"{words} between masses {e.a}-{e.b}" if e.a else f"{words} from mass {e.b} to the ground"


def mechanisms(constants: Mapping[Element, float], ci95: Mapping[Element, float]) -> tuple[Mechanism, ...]:
    """The nonlinear elements of a fit (couplings between masses first, then to the ground)."""
    out = []
    for e, c in constants.items():
        if e.kind not in NONLINEAR_KINDS:
            continue
        h = float(ci95.get(e, math.nan))
        out.append(Mechanism(e.label, e.kind, (e.a, e.b), mechanism_name(e), float(c), h, KIND_WORDS[e.kind][1],
                             e.a > 0, bool(abs(float(c)) > h) if not math.isnan(h) else False))
    return tuple(sorted(out, key=lambda m: (not m.coupling, m.between, m.kind)))


def named_coupling(found: tuple[Mechanism, ...]) -> str:
    """The determined couplings between masses in words, joined ("" when none)."""
    return "; ".join(m.name for m in found if m.coupling and m.determined)


def mechanism_note(constants: Mapping[Element, float], ci95: Mapping[Element, float]) -> str:
    """One line for the model's notes: every nonlinear element with its value and interval."""
    found = mechanisms(constants, ci95)
    return "; ".join(m.text() for m in found) if found else "no nonlinear element"
