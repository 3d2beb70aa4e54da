"""Terms in several coordinates, written as text and parsed without ``eval``.

A term is a product of factors separated by ``*``; a factor is ``xK``, ``vK``, ``abs(xK)`` or
``abs(vK)`` (``K`` = 1, 2, ... the coordinate number), optionally raised to a non-negative
integer power with ``^``. Examples: ``x1``, ``v2``, ``x1^2*x2``, ``abs(v1)*v1``,
``x1*x2^2``. The single-coordinate names ``x``, ``v`` mean ``x1``, ``v1``.

A term is stored as four integer exponent vectors (powers of ``x``, ``v``, ``|x|``, ``|v|``,
one entry per coordinate); the compiled simulator consumes that table.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from eddi.errors import TermError

_FACTOR = re.compile(r"^(abs\()?([xv])(\d*)(\))?(?:\^(\d+))?$")


@dataclass(frozen=True)
class MultiTerm:
    """One monomial in the coordinates and rates.

    Attributes
    ----------
    text : str
        The term in canonical form (``x1^2*x2``).
    exponents : ndarray, shape (4, n), int
        Rows: powers of ``x_k``, ``v_k``, ``|x_k|``, ``|v_k|``.
    """

    text: str
    exponents: np.ndarray

    @property
    def depends_on_v(self) -> bool:
        """True when the term involves a rate."""
        return bool(self.exponents[1].any() or self.exponents[3].any())

    @property
    def coordinates(self) -> tuple[int, ...]:
        """0-based indices of the coordinates and rates the term involves."""
        return tuple(int(k) for k in np.nonzero(self.exponents.any(axis=0))[0])

    @property
    def degree(self) -> int:
        """Total power."""
        return int(self.exponents.sum())

    def __call__(self, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Value for states ``x``, ``v`` of shape (n_coords, n_samples)."""
        out = np.ones(x.shape[1])
        for row, (arr, absolute) in enumerate(((x, False), (v, False), (x, True), (v, True))):
            for k in np.nonzero(self.exponents[row])[0]:
                base = np.abs(arr[k]) if absolute else arr[k]
                out = out * base ** int(self.exponents[row, k])
        return out


def parse_multi_term(text: str, n_coords: int) -> MultiTerm:
    """Parse a term in ``n_coords`` coordinates.

    Raises
    ------
    TermError
        Unknown factor, coordinate out of range, empty term.
    """
    clean = "".join(str(text).split())
    if not clean:
        raise TermError("empty term; expected e.g. 'x1^2*x2'")
    exps = np.zeros((4, n_coords), dtype=np.int64)
    for factor in clean.split("*"):
        m = _FACTOR.match(factor)
        if m is None or bool(m.group(1)) != bool(m.group(4)):
            raise TermError(f"term {text!r}: cannot read factor {factor!r}; expected xK, vK, abs(xK), "
                            "abs(vK), optionally ^N")
        k = int(m.group(3) or "1")
        if not 1 <= k <= n_coords:
            raise TermError(f"term {text!r}: coordinate {k} out of range 1..{n_coords}")
        row = (0 if m.group(2) == "x" else 1) + (2 if m.group(1) else 0)
        exps[row, k - 1] += int(m.group(5) or "1")
    if not exps.any():
        raise TermError(f"term {text!r} is a constant; expected a power of a coordinate or rate")
    return MultiTerm(canonical_text(exps), exps)


def canonical_text(exps: np.ndarray) -> str:
    """Canonical text of an exponent table (see :class:`MultiTerm`)."""
    parts = []
    for k in range(exps.shape[1]):
        for row, fmt in ((2, "abs(x{k})"), (0, "x{k}"), (3, "abs(v{k})"), (1, "v{k}")):
            p = int(exps[row, k])
            if p:
                name = fmt.format(k=k + 1)
                parts.append(name if p == 1 else f"{name}^{p}")
    # rates after coordinates, for people
    return "*".join(sorted(parts, key=lambda s: ("v" in s.replace("abs(", "")[:1], s)))


def monomial(powers: dict[int, int], n_coords: int, rate: bool = False) -> str:
    """Text of ``prod x_k^p`` (or ``v_k^p`` with ``rate``) for 0-based ``k -> p``."""
    exps = np.zeros((4, n_coords), dtype=np.int64)
    for k, p in powers.items():
        exps[1 if rate else 0, k] += p
    return canonical_text(exps)
