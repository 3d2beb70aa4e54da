"""Columns of decimal numbers in text, parsed to float64 exactly as Python's ``float`` (and
``numpy.loadtxt``) parse them, in one compiled pass over the file's bytes.

``station identify`` of a 45 s x 19.2 kHz CSV spent ~0.13-0.16 s of its ~0.75 s CPU in
``numpy.loadtxt`` (2.65 M numbers, ~50-60 ns a number: a tokenizer, a UCS-4 copy of each field and
``PyOS_string_to_double``). :func:`parse_columns` reads the same text in half that CPU (the file
read and parsed in 82 ms against ``loadtxt``'s 171 ms at load 22, session 19, ``docs/speed.md``):
one pass over the bytes, each field's digits gathered into an integer mantissa ``m`` and a decimal
exponent ``e``, and the value computed as ``m * 10**e`` or ``m / 10**-e`` with one IEEE operation
when ``m <= 2**53`` and ``|e| <= 22`` (Clinger's fast path: both operands are exact doubles, so the
one rounding gives the correctly rounded value, which is what ``float`` returns: the same float64,
bit for bit). A field outside that range (more than 18 significant digits, a mantissa above 2**53,
an exponent beyond +-22) is marked and parsed by ``float`` afterwards.

The grammar is deliberately narrow, a strict subset of what ``numpy.loadtxt`` accepts: fields
``[+-]digits[.digits][(e|E)[+-]digits]`` (digits on at least one side of the point), separated
by one delimiter byte, rows ended by ``\\n`` or ``\\r\\n``, every row with the same number of
fields, nothing else (no blanks, quotes, comments, blank lines, ``nan``/``inf``, non-ASCII).
Any other text, and a file with more than :data:`MAX_HARD_SHARE` of its fields outside the
fast path, gives None: the caller reads it the general way (``station.readers.read_csv``:
``numpy.loadtxt``, whose errors name the bad line), so every file it accepts yields the same
array, and every file it refuses is refused by the same reader, with the same message, as
before.
"""

from __future__ import annotations

import numpy as np

from eddi.kernels import Kernels

#: Largest share of the fields that may need ``float`` (beyond it the general reader is faster).
MAX_HARD_SHARE = 0.01


def parse_columns(raw: bytes, start: int, delimiter: str, ncols: int, kernel: object = None) -> np.ndarray | None:
    """The numbers of ``raw[start:]`` as an array of shape ``(ncols, rows)`` (each column
    contiguous), or None when the text is outside the grammar (module notes) or the kernel is
    not built ahead of time.

    Parameters
    ----------
    raw : bytes
        The whole file.
    start : int
        Offset of the first data row.
    delimiter : str
        One ASCII character between the values of a row (``,``, ``;``, tab).
    ncols : int
        Values in every row.
    kernel : callable, optional
        The compiled pass (tests: numba's JIT); default the one built ahead of time
        (:meth:`eddi.kernels.Kernels.built`), and None (read the general way) without it: numba's
        JIT would cost a process its import and a first run its compile, more than the pass saves.

    Returns
    -------
    ndarray, shape (ncols, rows), or None
    """
    if kernel is None:
        kernel = _KERNELS.built("_parse_columns")
        if kernel is None:
            return None
    if len(delimiter) != 1 or ord(delimiter) > 127 or delimiter in "0123456789+-.eE\r\n" or ncols < 1:
        return None
    rows = raw.count(b"\n", start) + (0 if raw.endswith(b"\n") else 1)
    if start >= len(raw) or rows < 1:
        return None
    buf = np.frombuffer(raw, dtype=np.uint8)
    out = np.empty((ncols, rows))
    hard = np.empty((int(MAX_HARD_SHARE * ncols * rows) + 16, 4), dtype=np.int64)
    nh = int(kernel(buf, int(start), ord(delimiter), out, hard))
    if nh < 0:
        return None
    for col, row, a, b in hard[:nh].tolist():
        out[col, row] = float(raw[a:b])
    return out


def data_start(raw: bytes, skiprows: int) -> int | None:
    """Offset of the line after the first ``skiprows`` lines, counted as a text-mode reader counts
    them; None when those lines end in a lone ``\\r`` (counted by ``\\n`` they would be others)."""
    pos = 0
    for _ in range(skiprows):
        nl = raw.find(b"\n", pos)
        if nl < 0:
            return None
        pos = nl + 1
    head = raw[:pos]
    if head.count(b"\r") != head.count(b"\r\n"):
        return None
    return pos


def _parse_columns(buf, start, delim, out, hard):  # pragma: no cover - compiled
    """Parse ``buf[start:]`` into ``out[col, row]``; fields outside the fast path are listed in
    ``hard`` (col, row, first byte, end byte) and left 0. Returns how many were listed, or
    ``-1 - offset`` at the first byte outside the grammar (or a row count other than
    ``out.shape[1]``, or more fields to list than ``hard`` holds)."""
    ncols = out.shape[0]
    nrows = out.shape[1]
    p10 = np.empty(23)
    p10[0] = 1.0
    for k in range(1, 23):
        p10[k] = p10[k - 1] * 10.0  # exact: 10**22 < 2**53 * 2**22
    n = buf.shape[0]
    i = start
    row = 0
    col = 0
    nh = 0
    while i < n:
        f0 = i
        c = buf[i]
        neg = c == 45
        if neg or c == 43:
            i += 1
        m = 0
        nd = 0  # digits
        sig = 0  # digits from the first non-zero one (m < 10**18 while sig <= 18: no overflow)
        while i < n:
            d = np.int64(buf[i]) - 48
            if d < 0 or d > 9:
                break
            m = m * 10 + d
            sig += m != 0
            nd += 1
            i += 1
        e = 0
        if i < n and buf[i] == 46:
            i += 1
            i0 = i
            while i < n:
                d = np.int64(buf[i]) - 48
                if d < 0 or d > 9:
                    break
                m = m * 10 + d
                sig += m != 0
                nd += 1
                i += 1
            e = i0 - i
        if nd == 0:
            return -1 - f0
        if i < n and (buf[i] == 101 or buf[i] == 69):
            i += 1
            eneg = False
            if i < n and (buf[i] == 45 or buf[i] == 43):
                eneg = buf[i] == 45
                i += 1
            x = 0
            nx = 0
            while i < n:
                d = np.int64(buf[i]) - 48
                if d < 0 or d > 9:
                    break
                if x < 100000:
                    x = x * 10 + d
                nx += 1
                i += 1
            if nx == 0:
                return -1 - f0
            e = e - x if eneg else e + x
        if row >= nrows:
            return -1 - f0
        if sig > 18 or m > 9007199254740992 or e < -22 or e > 22:
            if nh >= hard.shape[0]:
                return -1 - f0
            hard[nh, 0] = col
            hard[nh, 1] = row
            hard[nh, 2] = f0
            hard[nh, 3] = i
            nh += 1
            v = 0.0
        elif e < 0:
            v = m / p10[-e]
        else:
            v = m * p10[e]
        out[col, row] = -v if neg else v
        col += 1
        if i >= n:
            break
        c = buf[i]
        if c == delim:
            if col >= ncols:
                return -1 - i
            i += 1
            if i >= n:
                return -1 - i
            continue
        if c == 13:
            if i + 1 >= n or buf[i + 1] != 10:
                return -1 - i
            i += 1
        elif c != 10:
            return -1 - i
        if col != ncols:
            return -1 - i
        col = 0
        row += 1
        i += 1
    if col == ncols:  # the last row, with no line end
        col = 0
        row += 1
    if col != 0 or row != nrows:
        return -1 - i
    return nh


#: The compiled pass (:mod:`eddi.kernels`; used only when built ahead of time, see :func:`parse_columns`).
_KERNELS = Kernels(globals(), {"_parse_columns": ["i8(u1[::1], i8, i8, f8[:, ::1], i8[:, ::1])"]})
