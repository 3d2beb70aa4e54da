"""eddi.decimal_text: the compiled pass over a CSV's bytes gives numpy.loadtxt's float64 bit for
bit, and leaves every text outside its narrow grammar to the general reader (session 19)."""

from __future__ import annotations

import io

import numpy as np
import pytest

from eddi import decimal_text
from eddi.decimal_text import data_start, parse_columns


@pytest.fixture(scope="module")
def kernel():
    """The pass compiled by numba's JIT (the built module holds the same source: test_kernels)."""
    return decimal_text._KERNELS.jit_functions()["_parse_columns"]


def _loadtxt(text: str, delimiter: str = ",") -> np.ndarray:
    return np.loadtxt(io.StringIO(text), delimiter=delimiter, ndmin=2, skiprows=1, quotechar='"').T


def _parse(text: str, kernel, delimiter: str = ",", ncols: int = 3) -> np.ndarray | None:
    raw = text.encode()
    start = data_start(raw, 1)
    assert start is not None
    return parse_columns(raw, start, delimiter, ncols, kernel)


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


def _values(rng: np.random.Generator, n: int) -> np.ndarray:
    """Values of every size a record holds in SI (1e-6 m to 1e6 m/s^2), both signs, exact zeros."""
    v = rng.normal(size=n) * 10.0 ** rng.integers(-6, 7, size=n)
    v[rng.random(n) < 0.02] = 0.0
    return v


@pytest.mark.parametrize("fmt", ["%.9g", "%.6g", "%.12g", "%.15g", "%.6e", "%.10e", "%.3f", "%.8f", "%g", "%.1f"])
def test_the_pass_gives_loadtxts_float64_bit_for_bit(fmt: str, kernel) -> None:
    rng = np.random.default_rng(sum(map(ord, fmt)))
    n = 20_000
    t = np.arange(n) / 19200.0 - 1.0
    rows = np.column_stack([t, _values(rng, n), _values(rng, n)])
    text = "t,force,acc\n" + "".join(",".join(fmt % x for x in r) + "\n" for r in rows)
    got, want = _parse(text, kernel), _loadtxt(text)
    assert got is not None and _same_bits(got, want)
    assert all(c.flags.c_contiguous for c in got)


def test_a_product_by_the_reciprocal_would_be_caught() -> None:
    # the fast path divides m by 10**k; m * 10**-k is not the correctly rounded value for some
    # printed numbers, so bit-for-bit comparison with loadtxt tells the two apart
    texts = [f"{x:.9g}" for x in np.random.default_rng(3).normal(size=5000) * 1e-3]
    off = 0
    for s in texts:
        mant, _, exp = s.partition("e")
        whole, _, frac = mant.lstrip("-").partition(".")
        m, k = int(whole + frac), len(frac) - int(exp or 0)
        if 0 < k <= 22 and m <= 2**53:
            off += (m * 10.0 ** -k) != abs(float(s))
            assert m / 10.0 ** k == abs(float(s))
    assert off > 50


def test_edge_forms_of_numbers_are_parsed_as_loadtxt_parses_them(kernel) -> None:
    cells = ["-0", "+0.5", ".5", "5.", "-.25e-3", "1E+05", "1e5", "7e-0", "-0.0e0", "123456789012345678",
             "1234567890123456789", "0.30000000000000004", "1e-300", "4.9e-324", "1.7976931348623157e308",
             "2.2250738585072014e-308", "9007199254740993", "9007199254740992", "1e22", "1e23", "1e-22",
             "1e-23", "000000000000000000001.5", "0.000000000000000000000000001", "1e0000000000000000005"]
    rows = [(str(i), c, "1") for i, c in enumerate(cells)] + [(str(len(cells) + i), "0.1", "1") for i in range(3000)]
    text = "t,force,acc\n" + "".join(",".join(r) + "\n" for r in rows)
    got = _parse(text, kernel)
    assert got is not None and _same_bits(got, _loadtxt(text))
    assert np.signbit(got[1, 0]) and got[1, 0] == 0.0


@pytest.mark.parametrize("ending, last", [("\r\n", True), ("\n", False), ("\r\n", False)])
def test_line_ends_and_a_last_line_without_one(ending: str, last: bool, kernel) -> None:
    rows = [f"{i / 100:.9g},{np.sin(i):.9g},{np.cos(i):.9g}" for i in range(500)]
    text = "t,force,acc" + ending + ending.join(rows) + (ending if last else "")
    got = _parse(text, kernel)
    assert got is not None and _same_bits(got, _loadtxt(text))


@pytest.mark.parametrize("delimiter", [";", "\t"])
def test_other_delimiters(delimiter: str, kernel) -> None:
    text = "t;force;acc\n".replace(";", delimiter) + "".join(
        delimiter.join(f"{v:.9g}" for v in (i / 1000, np.sin(i), -np.cos(i))) + "\n" for i in range(800))
    got = _parse(text, kernel, delimiter)
    assert got is not None and _same_bits(got, _loadtxt(text, delimiter))


GOOD_ROWS = "".join(f"{i / 100:.9g},{np.sin(i):.9g},{np.cos(i):.9g}\n" for i in range(100))


@pytest.mark.parametrize("body", [
    "0,1,2\n1,nan,2\n", "0,1,2\n1,inf,2\n", "0,1,2\n1,-inf,2\n", "0, 1,2\n", "0,1 ,2\n", '0,"1",2\n',
    "0,1,2 # note\n", "# note\n0,1,2\n", "0,1,2\n\n1,2,3\n", "0,1,2\n1,2\n", "0,1,2\n1,2,3,4\n", "0,1,2,\n",
    "0,,2\n", "0,1,2\r1,2,3\n", "0,1e,2\n", "0,1e+,2\n", "0,-,2\n", "0,.,2\n", "0,1.2.3,2\n", "0,0x10,2\n",
    "0,1_0,2\n", "0,\u00b5,2\n", "0,1,2\n\n", "0,1,2\x00\n", "0,abc,2\n", "0,1;2,3\n", "0,1,2\n1,2,3\n1,2",
    "\n",
])
def test_text_outside_the_grammar_is_left_to_the_general_reader(body: str, kernel) -> None:
    assert _parse("t,force,acc\n" + GOOD_ROWS + body, kernel) is None


def test_many_long_numbers_are_left_to_the_general_reader_and_a_few_parsed_by_float(kernel) -> None:
    rng = np.random.default_rng(5)
    rows = np.column_stack([np.arange(5000) / 1e3, rng.normal(size=5000), rng.normal(size=5000)])
    long = "t,force,acc\n" + "".join(",".join(repr(float(x)) for x in r) + "\n" for r in rows)
    assert _parse(long, kernel) is None  # 17-digit reprs: loadtxt is faster than float for each
    few = "t,force,acc\n" + "".join(
        ",".join(repr(float(x)) if i % 200 == 0 else f"{x:.9g}" for x in r) + "\n" for i, r in enumerate(rows))
    got = _parse(few, kernel)
    assert got is not None and _same_bits(got, _loadtxt(few))


def test_the_header_lines_are_counted_as_a_text_reader_counts_them() -> None:
    assert data_start(b"# a\n# b\nt,acc\n1,2\n", 3) == 14
    assert data_start(b"# a\r\nt,acc\r\n1,2\r\n", 2) == 12
    assert data_start(b"# a\rt,acc\n1,2\n", 2) is None  # a lone CR ends a line for the text reader
    assert data_start(b"t,acc", 1) is None


def test_without_the_built_module_the_general_reader_reads(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("EDDI_JIT", "1")  # numba's JIT would cost more than the pass saves
    k = decimal_text.Kernels(decimal_text.__dict__, decimal_text._KERNELS._signatures)
    monkeypatch.setattr(decimal_text, "_KERNELS", k)
    assert parse_columns(b"t,acc\n0,1\n", 6, ",", 2) is None
    assert k.source == "not loaded"  # and numba was not asked for it
