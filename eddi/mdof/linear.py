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
        w = 2 * math.pi * np.asarray(freqs_hz, float)
        # every bin in one batched solve (session 12: a bin at a time was 217 000 calls and 17 of the
        # 26 s CPU of one identification of six 10 s captures); a singular bin (0 there) one at a time
        mats = k[None] - (w**2)[:, None, None] * m[None] + (1j * w)[:, None, None] * c[None]
        try:
            q = np.linalg.solve(mats, np.broadcast_to(u.astype(complex), (w.size, u.size))[..., None])[..., 0]
        except np.linalg.LinAlgError:
            q = np.zeros((w.size, u.size), complex)
            for j in range(w.size):
                try:
                    q[j] = np.linalg.solve(mats[j], u)
                except np.linalg.LinAlgError:
                    q[j] = 0.0
        return np.nan_to_num((phi @ q.T).astype(complex))

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


