"""The Bouc-Wen operator's fast paths and the diagnosis' column cache give the same numbers.

``eddi.hysteresis._bw_path`` skips the power in elastic unloading steps (both rates exactly 1)
and stops a sample's steps once a step leaves ``z`` unchanged (saturated); the hysteresis
candidate computes ``z`` only up to the last training sample and keeps the grid's paths for
the other folds. Each must equal the plain computation bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.diagnosis.catalogue.base import Signal
from eddi.diagnosis.catalogue.hysteresis import EXPONENTS, Hysteresis
from eddi.hysteresis import bouc_wen_z


def _plain_path(x: np.ndarray, dy: float, n_exp: float) -> np.ndarray:
    """The operator as written before the fast paths (plain Python, every step taken)."""
    def rate(z: float, sg: float) -> float:
        s = 1.0 if sg * z > 0.0 else (-1.0 if sg * z < 0.0 else 0.0)
        return 1.0 - abs(z) ** n_exp * (0.5 * s + 0.5)

    z, out = 0.0, np.zeros(x.size)
    for i in range(1, x.size):
        du = (x[i] - x[i - 1]) / dy
        steps = min(int(abs(du) / 0.02) + 1, 400)
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
    assert np.array_equal(bouc_wen_z(x, dy, n_exp), _plain_path(x, dy, n_exp))


def test_masked_columns_equal_the_full_columns_masked() -> None:
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
