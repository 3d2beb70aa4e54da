"""The drift fit's anchors as block means on a densely sampled record (session 15, issue 13).

The conditioner anchors its drift spline where ``a = 0`` (``x ~ -c_a a - c_v v``) and in the
noise tail. On a record sampled far faster than its period each group of anchor samples is
fitted as :data:`ANCHOR_BLOCKS` block means (``eddi.conditioning.conditioner._anchor_means``):
the same samples in ``1 / run`` of the rows. Before, every sample was a row (76,814 on the 45 s,
19.2 kHz rig record).
"""

from __future__ import annotations

import numpy as np
import pytest

import eddi.conditioning.conditioner as C
import eddi.conditioning.kinematics as K
from eddi.conditioning import condition
from tests.eddi.impact_cases import SYSTEMS, impact_record


@pytest.mark.parametrize("half_w, run", [(110, 13), (4, 1), (8, 1), (17, 1), (25, 3), (1024, 119)])
def test_anchor_run_is_odd_and_one_on_coarse_records(half_w: int, run: int) -> None:
    assert C._anchor_run(half_w) == run


def _rows_of_drift_fit(monkeypatch, rec) -> tuple[int, np.ndarray]:
    rows = []
    real = K._drift_spline

    def spy(t, y, t_pts, *a, **k):
        rows.append(y.size)
        return real(t, y, t_pts, *a, **k)

    monkeypatch.setattr(C, "_drift_spline", spy)
    cond = condition(rec.t, acc=rec.acc, force=rec.force)
    return rows[0], cond.x


def test_a_dense_record_is_anchored_on_block_means_as_accurately(monkeypatch) -> None:
    """50 kHz, 6 Hz (~8,000 samples a period): 357 rows instead of 10,857, ``x`` as close to the truth.

    Fails on the per-sample fit (it passes every anchor sample: > 10,000 rows here)."""
    rec = impact_record(SYSTEMS["paper_do"], rate_hz=50000.0, duration_s=3.0, pretrigger_s=0.2, snr_db=45.0,
                        seed=21)
    rows, x_new = _rows_of_drift_fit(monkeypatch, rec)
    monkeypatch.setattr(C, "ANCHOR_BLOCKS", 10**9)  # every sample its own anchor (before session 15)
    rows_old, x_old = _rows_of_drift_fit(monkeypatch, rec)
    assert rows_old > 10000
    assert rows < rows_old / 20
    w = slice(int(0.25 * rec.t.size), int(0.75 * rec.t.size))
    err_old = np.linalg.norm(x_old[w] - rec.x[w]) / np.linalg.norm(rec.x[w])
    err_new = np.linalg.norm(x_new[w] - rec.x[w]) / np.linalg.norm(rec.x[w])
    assert err_old < 0.01
    assert err_new < 1.25 * err_old
    assert np.linalg.norm(x_new[w] - x_old[w]) / np.linalg.norm(rec.x[w]) < 0.002


def test_block_means_of_a_linear_signal_are_its_values_at_the_centres() -> None:
    """A run's mean is its centre's value for a linear signal (the rows' model to first order)."""
    n, rate = 40001, 10000.0
    t = np.arange(n) / rate
    w = C._Work(t, rate, None, None, None, None, "acc", np.zeros(n), [], start=100)
    x_int, v_int, acc = 2.0 + 3.0 * t, -1.0 + 0.5 * t, 4.0 * t - 7.0
    anc = np.array([5000.3, 12000.7, 20000.0])
    ta, xa, local = C._anchor_means(w, x_int, v_int, acc, anc, half_w=40, step=7, run=9, first=200, stop=30000)
    assert np.all(np.diff(ta) > 0)
    np.testing.assert_allclose(xa, 2.0 + 3.0 * ta, rtol=0, atol=1e-12)
    np.testing.assert_allclose(-local[:, 0], 4.0 * ta - 7.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(-local[:, 1], -1.0 + 0.5 * ta, rtol=0, atol=1e-12)
    near = ta < 30000 / rate
    assert near.sum() == 3 * (2 * (40 // 9) + 1)  # 9 runs a crossing
    assert (~near).sum() == len(range(30000 + 4, n - 4, 9 * 7))  # the tail: a run every run * step samples


def test_drift_subtracted_in_place_equals_the_subtraction_bit_for_bit() -> None:
    """``_drift_spline_eval(..., minus=(x, v))``: ``x - d``, ``v - d'`` in the given arrays, the
    same bits as subtracting the evaluated drift (no two record-length arrays; session 15)."""
    from scipy.interpolate import BSpline

    t = np.arange(200_003) / 19200.0
    start = 1234
    inner = np.linspace(t[start], t[-1], 38)
    knots = np.concatenate(([t[start]] * 3, inner, [t[-1]] * 3))
    spl = BSpline(knots, np.random.default_rng(3).normal(size=knots.size - 4), 3, extrapolate=False)
    rng = np.random.default_rng(4)
    x, v = rng.normal(size=t.size), rng.normal(size=t.size)
    d, dd = K._drift_spline_eval(spl, t, start)
    want_x, want_v = x - d, v - dd
    got_x, got_v = K._drift_spline_eval(spl, t, start, minus=(x, v))
    assert got_x is x and got_v is v
    assert np.array_equal(got_x, want_x) and np.array_equal(got_v, want_v)
