"""The linear receptance in one batched solve equals the solve per frequency bin (session 12: cost)."""

from __future__ import annotations

import math

import numpy as np

from eddi.mdof.linear import receptance
from simulated_rig.mdof_systems import load_mdof_system


def test_the_batched_receptance_is_the_per_bin_solve():
    model = load_mdof_system("two-mass-cubic").model()
    m, c, k = model.linear_matrices()
    u = np.asarray(model.input, float)
    freqs = np.linspace(0.0, 200.0, 4001)
    want = np.array([model.phi @ np.linalg.solve(k - (2 * math.pi * f) ** 2 * m + 2j * math.pi * f * c, u)
                     for f in freqs]).T
    got = receptance(model)(freqs)
    assert got.shape == (len(model.channels), freqs.size)
    assert np.allclose(got, want, rtol=1e-12, atol=1e-300)
