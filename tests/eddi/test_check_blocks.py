"""Session 19 (s19ident): the time-base checks in blocks (``_steps``, ``_time_on_grid``).

The compiled checks exited at the first bad sample and kept a running float ``min``/``max``:
a loop with exits and float extremes does not vectorise (~3.3 ns a sample, 3 ms on the 45 s
record's 883k times). They now take blocks of :data:`~eddi.conditioning.checks._BLOCK` samples
without exits and read the extremes as integers (a non-negative double orders as its bits).
Here: the verdicts and the (min, max) step against numpy's passes, bit for bit, on time bases
whose flaw (NaN, infinity, a repeat, a step back, off the grid) sits at every place relative to
the block edges, and on steps of NaN, infinity and zero.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.conditioning import checks
from eddi.conditioning.checks import _BLOCK, time_steps


def _numpy_steps(t: np.ndarray):
    if not np.isfinite(t).all():
        return None
    d = np.diff(t)
    if not (d > 0).all():
        return None
    return (float(d.min()), float(d.max()))


def _numpy_on_grid(t: np.ndarray, step: float) -> bool:
    if not np.isfinite(t).all() or not (np.diff(t) > 0).all():
        return False
    with np.errstate(invalid="ignore"):
        dev = np.abs((np.arange(t.size, dtype=float) * step + t[0]) - t)
        worst = max(0.0, float(np.max(dev[~np.isnan(dev)], initial=0.0)))
    return not worst > 0.01 * step


def _cases(seed: int):
    rng = np.random.default_rng(seed)
    sizes = [2, 3, _BLOCK - 1, _BLOCK, _BLOCK + 1, _BLOCK + 2, 3 * _BLOCK + 5]
    for n in sizes + [int(v) for v in rng.integers(16, 5 * _BLOCK, 6)]:
        rate = float(10 ** rng.uniform(2, 5))
        t = np.arange(n) / rate + float(rng.uniform(-5, 5))
        yield t
        yield t + rng.normal(0, 0.003 / rate, n)  # jitter within 1 % of a step
        for k in {0, 1, n - 1, min(n - 1, _BLOCK - 1), min(n - 1, _BLOCK), min(n - 1, _BLOCK + 1),
                  int(rng.integers(0, n))}:
            for kind in range(5):
                bad = t.copy()
                if kind == 0:
                    bad[k] = np.nan
                elif kind == 1:
                    bad[k] = -np.inf if k % 2 else np.inf
                elif kind == 2 and k > 0:
                    bad[k] = bad[k - 1]  # a repeated time
                elif kind == 3 and k > 0:
                    bad[k] = bad[k - 1] - 1e-3 / rate  # a step back
                else:
                    bad[k] += 0.02 / rate  # 2 % off the grid
                yield bad


@pytest.mark.parametrize("seed", [3, 4])
def test_steps_bit_for_bit(seed):
    for t in _cases(seed):
        got = time_steps(t)
        want = _numpy_steps(t)
        assert (got is None) == (want is None)
        if got is not None:
            assert np.array([got]).tobytes() == np.array([want]).tobytes()


@pytest.mark.parametrize("seed", [3, 4])
def test_on_grid_verdicts(seed):
    for t in _cases(seed):
        step = (t[-1] - t[0]) / (t.size - 1)
        for s in (step, np.nan, np.inf, 0.0):
            if not np.isfinite(step) and s == step:
                continue
            assert bool(checks._KERNELS._time_on_grid(t, float(s))) == _numpy_on_grid(t, float(s)), (t.size, s)
