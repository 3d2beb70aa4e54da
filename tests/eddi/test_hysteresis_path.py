"""The Bouc-Wen operator: the exact one against closed forms and a fine-step integration, and
the earlier RK2 operator's fast paths against its plain form.

``eddi.hysteresis.bouc_wen_z`` solves each monotone stretch of the path exactly (tabulated
``G(z) = int dz / (1 - z^n)``), so ``z`` at the training samples does not depend on the samples
in between; the hysteresis candidate computes it only there. ``bouc_wen_z_rk2`` (the earlier
operator, RK2 steps of 0.02 in ``x / d_y``) skips the power in elastic unloading steps and stops
a sample's steps once a step leaves ``z`` unchanged: equal to the plain computation bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.diagnosis.catalogue.base import Signal
from eddi.diagnosis.catalogue.hysteresis import EXPONENTS, Hysteresis
from eddi.hysteresis import bouc_wen_z, bouc_wen_z_rk2


def _plain_path(x: np.ndarray, dy: float, n_exp: float, step: float = 0.02, cap: int = 400) -> np.ndarray:
    """The RK2 operator as written before the fast paths (plain Python, every step taken)."""
    def rate(z: float, sg: float) -> float:
        s = 1.0 if sg * z > 0.0 else (-1.0 if sg * z < 0.0 else 0.0)
        return 1.0 - abs(z) ** n_exp * (0.5 * s + 0.5)

    z, out = 0.0, np.zeros(x.size)
    for i in range(1, x.size):
        du = (x[i] - x[i - 1]) / dy
        steps = min(int(abs(du) / step) + 1, cap)
        h = du / steps
        sg = 1.0 if h > 0 else -1.0
        for _ in range(steps):
            k1 = rate(z, sg)
            z = min(1.0, max(-1.0, z + h * rate(z + 0.5 * h * k1, sg)))
        out[i] = z
    return out


@pytest.mark.parametrize("dy,n_exp", [(0.03, 1.0), (0.2, 2.0), (0.5, 4.0), (0.07, 1.37), (0.01, 8.0)])
def test_fast_paths_equal_the_plain_operator_bit_for_bit(dy: float, n_exp: float) -> None:
    # a decaying ring-down with noise (many small reversals) and a large first swing that
    # saturates z (|du| up to ~40 per sample at dy = 0.01: the 400-step cap too)
    rng = np.random.default_rng(3)
    t = np.arange(3000) / 2000.0
    x = np.sin(2 * np.pi * 7 * t) * np.exp(-t) + 1e-3 * rng.standard_normal(t.size)
    x[5:9] += 0.8
    assert np.array_equal(bouc_wen_z_rk2(x, dy, n_exp), _plain_path(x, dy, n_exp))


def _ring_down(n: int = 3000) -> np.ndarray:
    rng = np.random.default_rng(3)
    t = np.arange(n) / 2000.0
    x = np.sin(2 * np.pi * 7 * t) * np.exp(-t) + 1e-3 * rng.standard_normal(t.size)
    x[5:9] += 0.8
    return x


def test_exact_operator_closed_forms_on_a_loading_path() -> None:
    # loading from z = 0: n = 1 gives 1 - exp(-u), n = 2 tanh(u) (u = x / d_y)
    u = np.linspace(0.0, 30.0, 4001)
    assert np.max(np.abs(bouc_wen_z(2e-3 * u, 2e-3, 1.0) + np.expm1(-u))) < 1e-12
    assert np.max(np.abs(bouc_wen_z(2e-3 * u, 2e-3, 2.0) - np.tanh(u))) < 1e-8
    # then unloading is elastic down to z = 0 (z falls by the displacement over d_y), and
    # loading the other way beyond: -tanh
    d = np.linspace(0.0, 2.5, 501)[1:]
    z = bouc_wen_z(np.concatenate([u, 30.0 - d]), 1.0, 2.0)[u.size:]
    z1 = np.tanh(30.0)
    want = np.where(d <= z1, z1 - d, -np.tanh(d - z1))
    assert np.max(np.abs(z - want)) < 1e-8 and np.min(z) < -0.9


@pytest.mark.parametrize("dy,n_exp", [(0.03, 1.0), (0.5, 4.0), (0.07, 1.37), (0.4, 20.0)])
def test_exact_operator_is_the_limit_of_fine_steps(dy: float, n_exp: float) -> None:
    # the RK2 operator with 40x finer steps (error ~1e-4 / 40^2) converges to the exact path;
    # the 0.02 steps were ~1e-4 off
    x = _ring_down(400)
    fine = _plain_path(x, dy, n_exp, step=5e-4, cap=10**6)
    exact = bouc_wen_z(x, dy, n_exp)
    assert np.max(np.abs(exact - fine)) < 2e-7
    assert np.max(np.abs(bouc_wen_z_rk2(x, dy, n_exp) - fine)) > 1e-6  # the old steps were coarser


def test_exact_operator_needs_no_samples_between() -> None:
    # z at the kept samples is the same whether or not the path is sampled 4x finer between
    # them (linearly: no new reversal), and 'at' returns the same as the full path indexed
    x = _ring_down(800)
    fine = np.interp(np.arange(4 * (x.size - 1) + 1) / 4.0, np.arange(x.size), x)
    z = bouc_wen_z(x, 0.07, 2.6)
    assert np.max(np.abs(bouc_wen_z(fine, 0.07, 2.6)[::4] - z)) < 1e-12
    idx = np.arange(3, x.size, 7)
    assert np.array_equal(bouc_wen_z(x, 0.07, 2.6, at=idx), z[idx])


def test_masked_columns_equal_the_full_columns_masked() -> None:
    # computed only up to the last training sample and only there: the same numbers
    rng = np.random.default_rng(4)
    t = np.arange(6000) / 1000.0
    x = 1e-3 * np.sin(2 * np.pi * 5 * t) * np.exp(-t / 3) + 1e-6 * rng.standard_normal(t.size)
    sig = Signal(t, x, np.gradient(x, t), np.zeros_like(x), np.zeros_like(x))
    mech = Hysteresis()
    early = np.zeros(t.size, bool)
    early[200:2500:7] = True  # training ends early: z only up to sample 2500
    late = np.zeros(t.size, bool)
    late[100::5] = True
    for shape in ({"yield_displacement_m": 2e-4, "exponent": EXPONENTS[1]},  # a grid shape: kept
                  {"yield_displacement_m": 3.1e-4, "exponent": 2.37}):  # a polish shape: not kept
        for mask in (early, late, early):  # the shorter path kept first, then a longer one asked
            got = mech.masked_columns(sig, shape, (), mask)
            assert got.shape == (int(mask.sum()), 1)
            assert np.array_equal(got, mech.columns(sig, shape, ())[mask])
    assert mech.masked_columns(sig, shape, (), np.zeros(t.size, bool)).shape == (0, 1)
    with pytest.raises(ValueError):
        bouc_wen_z(x, 2e-4, 2.0, at=np.array([5, 3]))
