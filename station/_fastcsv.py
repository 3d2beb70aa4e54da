"""Compiled parser of plain-decimal CSV rows (see :func:`station.readers._parse_fast`).

Kept in its own module so that numba is imported only when a CSV is read.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def parse_csv(buf: np.ndarray, n_cols: int, pow10: np.ndarray, out: np.ndarray,
              slow: np.ndarray) -> tuple[int, int, int]:  # pragma: no cover - compiled
    """Parse ``buf`` (uint8 bytes of CSV rows) into ``out`` (rows, n_cols).

    Returns ``(rows, status, n_slow)``: status 0 ok, 1 ragged or empty field, 2 not a plain
    decimal, 3 more rows than ``out`` holds. Blank lines are skipped. A plain decimal outside
    the exact fast path (more than 15 significant digits, or a decimal exponent beyond +-22,
    e.g. ``8.57e-16``) is listed in ``slow`` as ``(row, col, start, end)`` byte offsets for the
    caller to convert exactly (``float``); more than ``len(slow)`` of them gives status 2.
    """
    n = buf.size
    n_slow = 0
    row = 0
    col = 0
    i = 0
    max_rows = out.shape[0]
    while i < n:
        c = buf[i]
        # blank line or line end
        if c == 10 or c == 13:
            if col != 0:
                return row, 1, n_slow
            i += 1
            continue
        # one token
        while i < n and (buf[i] == 32 or buf[i] == 9):
            i += 1
        start = i
        neg = False
        if i < n and (buf[i] == 45 or buf[i] == 43):
            neg = buf[i] == 45
            i += 1
        mant = 0
        digits = 0
        seen = 0
        exp10 = 0
        while i < n and 48 <= buf[i] <= 57:
            if digits > 0 or buf[i] != 48:
                digits += 1
                if digits <= 15:
                    mant = mant * 10 + (buf[i] - 48)
                else:
                    exp10 += 1
            seen += 1
            i += 1
        if i < n and buf[i] == 46:
            i += 1
            while i < n and 48 <= buf[i] <= 57:
                if digits > 0 or buf[i] != 48:
                    digits += 1
                    if digits <= 15:
                        mant = mant * 10 + (buf[i] - 48)
                        exp10 -= 1
                else:
                    exp10 -= 1
                seen += 1
                i += 1
        if seen == 0:
            return row, 2, n_slow  # not a plain decimal number
        if i < n and (buf[i] == 101 or buf[i] == 69):
            i += 1
            eneg = False
            if i < n and (buf[i] == 45 or buf[i] == 43):
                eneg = buf[i] == 45
                i += 1
            e = 0
            eseen = 0
            while i < n and 48 <= buf[i] <= 57:
                if e < 10000:
                    e = e * 10 + (buf[i] - 48)
                eseen += 1
                i += 1
            if eseen == 0:
                return row, 2, n_slow
            exp10 += -e if eneg else e
        end = i
        while i < n and (buf[i] == 32 or buf[i] == 9 or buf[i] == 13):
            i += 1
        if row >= max_rows:
            return row, 3, n_slow
        if mant != 0 and (digits > 15 or exp10 > 22 or exp10 < -22):
            if n_slow >= slow.shape[0]:
                return row, 2, n_slow  # too many for the exact slow path: the caller's loadtxt
            slow[n_slow, 0] = row
            slow[n_slow, 1] = col
            slow[n_slow, 2] = start
            slow[n_slow, 3] = end
            n_slow += 1
            val = 0.0
        elif mant == 0:
            val = 0.0
        elif exp10 >= 0:
            val = mant * pow10[exp10]
        else:
            val = mant / pow10[-exp10]
        if neg:
            val = -val
        out[row, col] = val
        col += 1
        if i >= n or buf[i] == 10:
            if col != n_cols:
                return row, 1, n_slow
            row += 1
            col = 0
            i += 1
        elif buf[i] == 44:
            if col >= n_cols:
                return row, 1, n_slow
            i += 1
            if i >= n or buf[i] == 10 or buf[i] == 13:
                return row, 1, n_slow  # empty field
        else:
            return row, 2, n_slow
    if col != 0:
        return row, 1, n_slow
    return row, 0, n_slow
