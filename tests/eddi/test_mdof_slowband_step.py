"""The slow-band Levenberg-Marquardt step by the Schur complement on ``theta`` (banded beta
blocks) equals the dense solve of the whole normal matrix it replaced (session 12: a cost
change; the dense solve is kept here as the reference)."""

from __future__ import annotations

import numpy as np
import pytest

from eddi.mdof import slowband
from eddi.mdof.lumped import Element, element_column


def _dense_step(blocks, grads, n, lam):
    """The session-11 step: the whole normal matrix assembled dense, scaled, solved."""
    tt, tb, bb = blocks
    gt, gb = grads
    nt = gt.size
    total = nt + sum(g.size for g in gb)
    mat, grad = np.zeros((total, total)), np.zeros(total)
    mat[:nt, :nt], grad[:nt] = tt, gt
    off = nt
    for tb_r, bb_r, g_r in zip(tb, bb, gb):
        sl = slice(off, off + g_r.size)
        mat[:nt, sl], mat[sl, :nt], mat[sl, sl], grad[sl] = tb_r, tb_r.T, bb_r.toarray(), g_r
        off += g_r.size
    diag = np.sqrt(np.maximum(np.diag(mat), 1e-300))
    scaled = mat / diag[:, None] / diag[None, :]
    return -np.linalg.solve(scaled + lam * np.eye(diag.size), grad / diag) / diag


def _problem(seed: int, n: int):
    """A chain ground - 1 - ... - n with a cubic spring 1-2, records with a slow band removed."""
    g = np.random.default_rng(seed)
    rate, fc = 1000.0, 8.0
    elements = [Element("k", 0, 1), Element("c", 0, 1), Element("k3", 0, 1)]
    elements += [e for j in range(1, n) for e in (Element("k", j, j + 1), Element("c", j, j + 1))]
    elements += [Element("k3", 1, 2)]
    masses = g.uniform(0.5, 2.0, n)
    consts = {e: {"k": 4e4, "c": 3.0, "k3": 2e9}[e.kind] * g.uniform(0.5, 1.5) for e in elements}
    records = []
    for rec in range(2):
        t = np.arange(int(g.integers(900, 1300))) / rate
        x = np.array([sum(g.uniform(0.2, 1) * 1e-3 * np.sin(2 * np.pi * g.uniform(50, 150) * t + g.uniform(0, 6))
                          for _ in range(3)) for _ in range(n)])
        v = np.gradient(x, 1 / rate, axis=1)
        force = np.zeros_like(x)
        for e in elements:
            col = element_column(e, x, v)
            force[e.b - 1] -= consts[e] * col
            if e.a:
                force[e.a - 1] += consts[e] * col
        a = -force / masses[:, None]
        slow = 2e-4 * np.sin(2 * np.pi * 6.0 * t + g.uniform(0, 6)) * g.uniform(0.5, 1.5, (n, 1))
        xc, vc = x - slow, v - np.gradient(slow, 1 / rate, axis=1)
        records.append((xc, vc, a, None, (10, t.size - 10), rate, fc))
    start = masses * g.uniform(0.9, 1.1, n)
    start_c = {e: c * g.uniform(0.9, 1.1) for e, c in consts.items()}
    return records, elements, start, start_c


@pytest.mark.parametrize("seed, n", [(1, 2), (2, 3)])
def test_the_banded_schur_step_is_the_dense_step(seed, n):
    records, elements, masses, consts = _problem(seed, n)
    data = []
    for x, v, a, f, (s0, s1), rate, fc in records:
        b, bd = slowband._sparse_basis(s1 - s0, rate, fc)
        data.append((x[:, s0:s1], v[:, s0:s1], a[:, s0:s1], None, b, bd))
    scales = np.array([float(np.sqrt(np.mean(np.concatenate([dt[2][i] for dt in data]) ** 2))) for i in range(n)])
    free = [k for k in range(n) if k != 0]
    theta = np.concatenate([masses[free] / masses[0], [consts[e] / masses[0] for e in elements]])
    betas = [np.random.default_rng(seed).normal(0, 1e-5, (n, dt[4].shape[1])) for dt in data]
    blocks, grads, _cost = slowband._normal(data, betas, theta, elements, n, 0, scales, False)
    assert sum(g.size for g in grads[1]) > 10 * theta.size  # the beta blocks dominate
    for lam in (1e-9, 1e-3, 1.0, 1e3):
        want = _dense_step(blocks, grads, n, lam)
        got = slowband._lm_step(blocks, grads, n, lam)
        assert np.allclose(got, want, rtol=1e-9, atol=1e-12 * np.max(np.abs(want)))


@pytest.mark.parametrize("seed, n", [(3, 2), (4, 3)])
def test_restore_slow_band_equals_the_dense_solve(seed, n, monkeypatch):
    records, elements, masses, consts = _problem(seed, n)
    got = slowband.restore_slow_band(records, elements, masses, consts, n, 0)
    monkeypatch.setattr(slowband, "_lm_step", _dense_step)
    want = slowband.restore_slow_band(records, elements, masses, consts, n, 0)
    assert want[3] < 0.1 * want[2]  # the fit moved: the restored band closes the force balance
    assert np.allclose(got[1], want[1], rtol=1e-9)
    assert got[2] == pytest.approx(want[2], rel=1e-9) and got[3] == pytest.approx(want[3], rel=1e-7)
    for (xg, vg, *_), (xw, vw, *_) in zip(got[0], want[0]):
        assert np.allclose(xg, xw, rtol=0, atol=1e-9 * np.max(np.abs(xw)))
        assert np.allclose(vg, vw, rtol=0, atol=1e-9 * np.max(np.abs(vw)))


def test_a_tie_in_the_cubic_intervals_goes_to_the_restored_slow_band_not_to_the_last_bit():
    """The slow-band fit's intervals are floored at its start's (``_slow_fit``): equal to rounding,
    the tie went to whichever sum was an ulp smaller (fails without the tolerance in ``_pick``)."""
    from eddi.mdof.lumped import LumpedFit
    from eddi.mdof.physical import _informative, _pick

    e = Element("k3", 1, 2)
    pre = LumpedFit(np.array([1.0, 2.0]), {e: 4.0e10}, {e: 0.37 * 4.0e10}, np.zeros(2))
    half = 0.37 * 4.7e10
    while _informative(LumpedFit(pre.masses, {e: 4.7e10}, {e: half}, pre.residual)) <= _informative(pre):
        half = np.nextafter(half, np.inf)
    slow = LumpedFit(pre.masses, {e: 4.7e10}, {e: half}, pre.residual)
    assert 0 < _informative(slow) - _informative(pre) < 1e-12 * _informative(pre)
    tried = [(0.0039, pre, "prefiltered"), (0.0040, slow, "restored")]
    assert _pick(tried, 0.003, frozenset({"restored"}))[2] == "restored"
    assert _pick(tried, 0.003)[2] == "prefiltered"  # no preference: the lower training nrmse
    wider = LumpedFit(pre.masses, {e: 4.7e10}, {e: 0.5 * 4.7e10}, pre.residual)
    assert _pick([(0.0039, pre, "prefiltered"), (0.0040, wider, "restored")], 0.003,
                 frozenset({"restored"}))[2] == "prefiltered"  # a real difference still decides
