"""The linear part of an identified model: receptance, growth rate, the slow response restored.

No I/O.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from eddi.mdof.model import MdofModel
from eddi.mdof.records import ChannelRecord
from eddi.mdof.signals import quasi_static


def receptance(model: MdofModel):
    """``freqs_hz -> Phi (K - w^2 M + i w C)^-1 u``, shape (n_channels, n_freqs), of the linear terms."""
    m, c, k = model.linear_matrices()
    u = np.asarray(model.input, float)
    phi = model.phi

    def h(freqs_hz: np.ndarray) -> np.ndarray:
        out = np.empty((phi.shape[0], len(freqs_hz)), complex)
        for j, f in enumerate(freqs_hz):
            w = 2 * math.pi * f
            try:
                out[:, j] = phi @ np.linalg.solve(k - w**2 * m + 1j * w * c, u)
            except np.linalg.LinAlgError:
                out[:, j] = 0.0
        return np.nan_to_num(out)

    return h


def restore_quasi_static(r: ChannelRecord, model: MdofModel) -> ChannelRecord:
    """The record with the slow response the drift high-pass removed added back (``model``'s linear part)."""
    if r.force is None:
        return r
    rate = 1.0 / float(r.t[1] - r.t[0])
    xl, vl = quasi_static(r.force, rate, receptance(model), r.highpass_hz)
    return replace(r, x=r.x + xl, v=r.v + vl)


def linear_growth_rate(model: MdofModel) -> float:
    """Largest real part of the eigenvalues of the model's linear part [1/s] (> 0: unstable)."""
    m, c, k = model.linear_matrices()
    n = model.n_coords
    try:
        a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(m, k), -np.linalg.solve(m, c)]])
        return float(np.max(np.linalg.eigvals(a).real))
    except np.linalg.LinAlgError:
        return math.nan


