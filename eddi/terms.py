"""Candidate terms written as text, parsed without ``eval``.

A term is a product of factors separated by ``*``. A factor is one of ``x``, ``v``,
``abs(x)``, ``abs(v)``, ``sign(x)``, ``sign(v)``, optionally raised to a non-negative
integer power with ``^`` (``x^3``, ``abs(v)^2``). ``x`` is the generalized coordinate and
``v`` its rate, whatever their physical nature (metres, radians...).

Examples: ``x``, ``x^3``, ``v``, ``x^2*v``, ``v^3``, ``sign(v)``, ``abs(v)*v``.

A term is stored as six integer exponents ``(px, pv, pax, pav, sx, sv)`` so that its
value is ``x**px * v**pv * |x|**pax * |v|**pav * sign(x)**sx * sign(v)**sv``; the
exponent form is what the compiled simulator consumes.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass

import numpy as np

from eddi.errors import TermError
from eddi.term_defaults import DEFAULT_DAMPING, DEFAULT_STIFFNESS  # noqa: F401 (re-export; numpy-free for --help)

_FACTOR = re.compile(r"^(x|v|abs\(x\)|abs\(v\)|sign\(x\)|sign\(v\))(?:\^(\d+))?$")
_SLOT = {"x": 0, "v": 1, "abs(x)": 2, "abs(v)": 3, "sign(x)": 4, "sign(v)": 5}
_NAMES = ("x", "v", "abs(x)", "abs(v)", "sign(x)", "sign(v)")



@dataclass(frozen=True)
class Term:
    """One candidate term.

    Attributes
    ----------
    text : str
        The term as the user wrote it, with white space removed.
    exponents : tuple of int, length 6
        Powers of ``x, v, |x|, |v|, sign(x), sign(v)``.
    """

    text: str
    exponents: tuple[int, int, int, int, int, int]

    @property
    def depends_on_v(self) -> bool:
        """True when the term involves the rate ``v``."""
        px, pv, pax, pav, sx, sv = self.exponents
        return bool(pv or pav or sv)

    @property
    def x_degree(self) -> int:
        """Total power of the coordinate (``x`` and ``abs(x)``)."""
        return self.exponents[0] + self.exponents[2]

    @property
    def v_degree(self) -> int:
        """Total power of the rate (``v`` and ``abs(v)``)."""
        return self.exponents[1] + self.exponents[3]

    def canonical(self) -> str:
        """A canonical spelling (``x^2*v``), independent of how the term was written."""
        parts = []
        for name, p in zip(_NAMES, self.exponents):
            if name.startswith("sign"):
                p = p % 2
            if p == 1:
                parts.append(name)
            elif p > 1:
                parts.append(f"{name}^{p}")
        return "*".join(parts) if parts else "1"

    def __call__(self, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Evaluate the term.

        Parameters
        ----------
        x : ndarray, shape (n,)
            Generalized coordinate.
        v : ndarray, shape (n,)
            Its rate.

        Returns
        -------
        ndarray, shape (n,)
        """
        x = np.asarray(x, dtype=float)
        v = np.asarray(v, dtype=float)
        shape = np.broadcast(x, v).shape
        out = _factor_product(self.exponents, x, v, shape)
        return np.ones(shape) if out is None else out

    def evaluate_unchecked(self, x: np.ndarray, v: np.ndarray) -> np.ndarray:
        """:meth:`__call__` on two float arrays of one shape, without its conversion and
        broadcasting (the hot loops of :mod:`eddi.simulate`); the same numbers bit for bit."""
        out = _factor_product(self.exponents, x, v, x.shape)
        return np.ones(x.shape) if out is None else out


def _factor_product(exponents: tuple[int, ...], x: np.ndarray, v: np.ndarray,
                    shape: tuple[int, ...]) -> np.ndarray | None:
    """The product of a term's factors (None for the constant term).

    The factors in the order they always had, multiplied in place into the first (the product
    with a leading array of ones, ``1.0 * y == y`` exactly, is skipped: the same numbers bit for
    bit, one temporary and one pass fewer per factor).
    """
    px, pv, pax, pav, sx, sv = exponents
    out: np.ndarray | None = None
    for on, factor in ((px, lambda: _power(x, px)), (pv, lambda: _power(v, pv)),
                       (pax, lambda: _power(np.abs(x), pax)),
                       (pav, lambda: _power(np.abs(v), pav)), (sx % 2, lambda: np.sign(x)),
                       (sv % 2, lambda: np.sign(v))):
        if not on:
            continue
        f = factor()
        if out is None:
            out = f if f.shape == shape else np.broadcast_to(f, shape).copy()
        else:
            out *= f
    return out


def _power(y: np.ndarray, p: int) -> np.ndarray:
    """``y**p`` for an integer ``p >= 1``: numpy's own for ``p <= 2`` (a copy, a square), repeated
    products above (numpy's ``y**3`` calls ``pow``: ~40 ns a sample, 19 ms on 460k samples,
    against ~0.3 ms; within a few ulps of it)."""
    if p <= 2:
        return y**p
    out = y * y
    for _ in range(p - 2):
        out *= y
    return out


def parse_term(text: str) -> Term:
    """Parse one term.

    Parameters
    ----------
    text : str
        For example ``"x^2*v"`` or ``"abs(v)*v"``.

    Returns
    -------
    Term

    Raises
    ------
    TermError
        If the text is not a product of known factors.
    """
    if not isinstance(text, str):
        raise TermError(f"term must be text, got {type(text).__name__}")
    return _parse_term(text)


@functools.lru_cache(maxsize=1024)
def _parse_term(text: str) -> Term:
    """:func:`parse_term` of a string, remembered (a frozen :class:`Term`; one identification
    parsed the same few terms ~500 times, ~1.5 ms of CPU; errors are not cached)."""
    compact = "".join(text.split())
    if not compact:
        raise TermError("empty term")
    exps = [0] * 6
    for factor in compact.split("*"):
        m = _FACTOR.match(factor)
        if m is None:
            raise TermError(
                f"unknown term {text!r}: factor {factor!r} is not one of "
                "x, v, abs(x), abs(v), sign(x), sign(v) with an optional ^N"
            )
        power = int(m.group(2)) if m.group(2) else 1
        if power > 12:
            raise TermError(f"unknown term {text!r}: power {power} is above 12")
        exps[_SLOT[m.group(1)]] += power
    return Term(text=compact, exponents=tuple(exps))  # type: ignore[arg-type]


def parse_terms(texts: str | list[str] | tuple[str, ...]) -> tuple[Term, ...]:
    """Parse a comma-separated string or a sequence of terms.

    Raises
    ------
    TermError
        If any term is bad, or a term is given twice.
    """
    if isinstance(texts, str):
        items = [s for s in texts.split(",") if s.strip()]
        if not items:
            raise TermError("empty list of terms")
    else:
        items = list(texts)
    terms = tuple(parse_term(t) for t in items)
    seen: dict[str, str] = {}
    for t in terms:
        key = t.canonical()
        if key in seen:
            raise TermError(f"term {t.text!r} is given twice (same as {seen[key]!r})")
        seen[key] = t.text
    return terms


def exponent_table(terms: tuple[Term, ...]) -> np.ndarray:
    """Exponents of several terms as an int64 array of shape (n_terms, 6)."""
    if not terms:
        return np.zeros((0, 6), dtype=np.int64)
    return np.array([t.exponents for t in terms], dtype=np.int64)


def evaluate(terms: tuple[Term, ...], x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Evaluate several terms.

    Returns
    -------
    ndarray, shape (n, n_terms)
    """
    x = np.asarray(x, dtype=float)
    return np.column_stack([t(x, v) for t in terms]) if terms else np.zeros((x.size, 0))


def coefficient_unit(term: str | Term, coordinate_unit: str = "m", force_unit: str = "N") -> str:
    """SI unit of the coefficient of ``term`` in a force balance.

    ``c * x^a * v^b`` is a force, so ``c`` is in ``N s^b / m^(a+b)`` (``N/m``, ``N/m^3``,
    ``N s/m``, ``N s^3/m^3``, ``N`` for ``sign(v)``); for an angle give ``coordinate_unit="rad"``
    and ``force_unit="N m"``.

    Parameters
    ----------
    term : str or Term
    coordinate_unit, force_unit : str

    Returns
    -------
    str
    """
    tm = parse_term(term) if isinstance(term, str) else term
    a = tm.x_degree
    b = tm.v_degree
    num = force_unit + ("" if b == 0 else " s" if b == 1 else f" s^{b}")
    den_pow = a + b
    if den_pow == 0:
        return num
    den = coordinate_unit if den_pow == 1 else f"{coordinate_unit}^{den_pow}"
    return f"{num}/{den}"
