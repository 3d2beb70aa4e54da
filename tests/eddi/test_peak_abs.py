"""Session 19 (s19ident): ``max |y|`` and ``argmax |y - c|`` in one compiled pass.

:func:`eddi.peaks.peak_abs` replaces ``float(np.max(np.abs(y)))`` and
:func:`eddi.peaks.peak_abs_at` ``np.argmax(np.abs(y - c))`` (with the value) on the identify
path: numpy forms one or two temporaries of the record's length first (7 MB on the 45 s
record, which this session's machine's caches did not hold). Here: the same doubles and indices
as numpy, ties (numpy's first index), NaN and infinities, signed zeros, every length around the
blocks, offsets that overflow; a strided or short array takes numpy's passes.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.peaks import _PEAK_BLOCK, PEAK_ABS_MIN, peak_abs, peak_abs_at


def _same(a: float, b: float) -> bool:
    return (np.isnan(a) and np.isnan(b)) or np.array([a]).tobytes() == np.array([b]).tobytes()


def _arrays(seed: int):
    rng = np.random.default_rng(seed)
    sizes = [PEAK_ABS_MIN - 1, PEAK_ABS_MIN, _PEAK_BLOCK * 3, _PEAK_BLOCK * 3 + 1, 20011]
    for n in sizes:
        for k in range(40):
            y = np.round(rng.standard_normal(n) * 10.0 ** rng.uniform(-30, 30), int(k % 3) - 1 + 30) \
                if k % 2 else rng.standard_normal(n) * 10.0 ** rng.uniform(-300, 300)
            if k % 5 == 1:
                y[rng.integers(n)] = rng.choice([np.nan, np.inf, -np.inf])
            if k % 9 == 2:
                y[:] = -0.0
            if k % 11 == 3:
                y[rng.integers(n)] = -y[int(np.argmax(np.abs(y)))]  # a tie of opposite sign later or earlier
            yield y


@pytest.mark.parametrize("seed", [1, 2])
def test_peak_abs_as_numpy(seed):
    for y in _arrays(seed):
        assert _same(peak_abs(y), float(np.max(np.abs(y))))
        assert _same(peak_abs(y[::2]), float(np.max(np.abs(y[::2]))))


@pytest.mark.parametrize("seed", [1, 2])
def test_peak_abs_at_as_numpy(seed):
    rng = np.random.default_rng(seed)
    for y in _arrays(seed):
        for c in (0.0, float(rng.standard_normal()), float(np.median(y[:100])), -1e308, np.inf):
            with np.errstate(invalid="ignore", over="ignore"):
                r = np.abs(y - c)
                i = int(np.argmax(r))
                got = peak_abs_at(y, c)
            assert got[0] == i and _same(got[1], float(r[i])), (y.size, c)


@pytest.mark.parametrize("seed", [1, 2])
def test_chunked_scans_as_numpy(seed):
    from eddi.peaks import SCAN_CHUNK, first_abs_above, last_nonzero

    rng = np.random.default_rng(seed)
    for n in (0, 1, SCAN_CHUNK - 1, SCAN_CHUNK, SCAN_CHUNK + 1, 3 * SCAN_CHUNK + 7):
        for k in range(12):
            y = np.zeros(n)
            for _ in range(int(rng.integers(0, 4))):
                if n:
                    y[rng.integers(n)] = rng.choice([1.0, -2.0, 0.5, -0.0, np.nan])
            level = float(rng.choice([0.0, 0.5, 1.0, 2.0]))
            for strict in (True, False):
                with np.errstate(invalid="ignore"):
                    hits = np.flatnonzero(np.abs(y) > level if strict else np.abs(y) >= level)
                assert first_abs_above(y, level, strict) == (int(hits[0]) if hits.size else -1)
            nz = np.flatnonzero(y != 0.0)
            assert last_nonzero(y) == (int(nz[-1]) if nz.size else -1)


@pytest.mark.parametrize("seed", [1, 2])
def test_block_peaks_as_numpy(seed):
    from eddi.peaks import block_peaks

    rng = np.random.default_rng(seed)
    for y in _arrays(seed):
        for block in (4, 7, int(rng.integers(8, 3000))):
            nb = y.size // block
            want = np.abs(y[: nb * block]).reshape(nb, block).max(axis=1)
            got = block_peaks(y, block)
            assert got.shape == want.shape
            assert all(_same(a, b) for a, b in zip(got, want))
