"""Session 16 (s16ident): the input checks of the time base and channels as one compiled pass.

:func:`eddi.conditioning.checks.check_time`, :func:`~eddi.conditioning.checks.check_channel` and
:func:`eddi.energy.check_series` (the conditioning's and every validation's) ran 5-8 numpy passes
over the record's length each. A compiled pass now says whether every check passes; only when one
fails do the numpy passes run, so every message is as before. Here: the same verdicts and messages
as the numpy passes (a strided input still takes them), on good and broken time bases and channels,
and no numpy pass over a good record.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.conditioning import checks
from eddi.conditioning.checks import check_channel, check_time
from eddi.energy import check_series
from eddi.errors import SignalError


def _strided(y: np.ndarray) -> np.ndarray:
    out = np.repeat(y, 2)[::2]
    assert not out.flags.c_contiguous
    return out


def _outcome(fn, *args):
    try:
        out = fn(*args)
    except SignalError as exc:
        return ("error", str(exc))
    return ("ok", out if not isinstance(out, tuple) else out[0].tobytes())


def _time_bases(seed: int):
    rng = np.random.default_rng(seed)
    for _ in range(40):
        n = int(rng.integers(16, 5000))
        rate = float(10 ** rng.uniform(2, 5))
        t = np.arange(n) / rate + float(rng.uniform(-5, 5))
        yield t
        yield np.round(t, int(rng.integers(3, 9)))  # times printed with few digits
        bad = t.copy()
        k = int(rng.integers(1, n))
        kind = int(rng.integers(0, 5))
        if kind == 0:
            bad[k] = np.nan
        elif kind == 1:
            bad[k] = np.inf
        elif kind == 2:
            bad[k] = bad[k - 1]  # a repeated time
        elif kind == 3:
            bad[k:] += 0.3 / rate  # a jump of 30 % of a step
        else:
            bad[k] += 0.02 / rate  # 2 % off the grid: check_time refuses, check_series (1e-6) too
        yield bad


@pytest.mark.parametrize("seed", [1, 2])
def test_time_checks_as_the_numpy_passes(seed):
    for t in _time_bases(seed):
        assert _outcome(check_time, t) == _outcome(check_time, _strided(t))
        sig = {"x": np.sin(np.arange(t.size) / 7.0)}
        assert _outcome(check_series, t, sig) == _outcome(check_series, _strided(t), sig)


def test_channel_checks_as_the_numpy_passes():
    rng = np.random.default_rng(5)
    for _ in range(60):
        y = rng.normal(size=int(rng.integers(16, 3000)))
        if rng.random() < 0.6:
            y[int(rng.integers(0, y.size))] = rng.choice([np.nan, np.inf, -np.inf])
        assert _outcome(check_channel, "acc", y, y.size)[0] == _outcome(check_channel, "acc", _strided(y), y.size)[0]
        if not np.isfinite(y).all():
            with pytest.raises(SignalError, match=f"at sample {int(np.flatnonzero(~np.isfinite(y))[0])}$"):
                check_channel("acc", y, y.size)
        t = np.arange(y.size) * 1e-3
        assert _outcome(check_series, t, {"x": y}) == _outcome(check_series, t, {"x": _strided(y)})


def test_a_good_record_is_checked_without_numpy_passes(monkeypatch):
    t = np.arange(200_000) / 19_200.0
    y = np.sin(t * 30.0)
    calls = []
    real_isfinite, real_diff = np.isfinite, np.diff
    monkeypatch.setattr(np, "isfinite", lambda *a, **k: calls.append("isfinite") or real_isfinite(*a, **k))
    monkeypatch.setattr(np, "diff", lambda *a, **k: calls.append("diff") or real_diff(*a, **k))
    assert check_time(t) == pytest.approx(19_200.0, rel=1e-12)
    assert check_channel("acc", y, t.size) is y
    check_series(t, {"x": y, "v": y, "f": None})
    assert calls == [] and checks._KERNELS is not None
