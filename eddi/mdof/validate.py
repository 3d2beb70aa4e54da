"""Prediction of every channel by an :class:`~eddi.mdof.model.MdofModel`, scored per channel.

With a force: simulated from rest at the start of the impact, driven by the measured impact
force (zero after it). Without: from the state projected on the model's coordinates at the
start of the free window. The measured displacement of each channel (quasi-static response
restored, :func:`eddi.mdof.identify.restore_quasi_static`) is compared over the free window:
``nrmse_c = ||y_sim - y|| / ||y||`` per channel (as the single-DOF ``eddi.validate``), and
``nrmse`` is their mean.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eddi.mdof.identify import ChannelRecord, restore_quasi_static, static_flexibility
from eddi.mdof.model import MdofModel
from eddi.mdof.signals import HIGHPASS_HZ
from eddi.mdof.simulate import simulate_mdof


@dataclass(frozen=True)
class MdofValidation:
    """Per-channel errors of one record.

    Attributes
    ----------
    label : str
    nrmse : float
        Mean of ``channel_nrmse``.
    channel_nrmse : dict of str to float
    mode_nrmse : ndarray, shape (n_coords,)
        Same error on each coordinate (measured projected vs simulated).
    driven_by : str
        ``"force"`` or ``"initial state"``.
    diverged : bool
    t : ndarray, shape (k,)
    measured, simulated : ndarray, shape (n_channels, k)
        Displacement [m] over the free window.
    """

    label: str
    nrmse: float
    channel_nrmse: dict[str, float]
    mode_nrmse: np.ndarray
    driven_by: str
    diverged: bool
    t: np.ndarray
    measured: np.ndarray
    simulated: np.ndarray


def validate_mdof(model: MdofModel, record: ChannelRecord, highpass_hz: float | None = HIGHPASS_HZ) -> MdofValidation:
    """Simulate ``model`` for ``record`` and score each channel (module docstring)."""
    if record.x.shape[0] != len(model.channels):
        raise ValueError(f"{record.label}: {record.x.shape[0]} response channels, the model predicts "
                         f"{len(model.channels)} ({', '.join(model.channels)})")
    phi = model.phi
    proj = np.linalg.pinv(phi)
    w0, w1 = record.window
    if record.force is not None and record.impact[1] > record.impact[0]:
        if highpass_hz is not None:
            g = static_flexibility(model)
            if g is not None:
                record = restore_quasi_static(record, g, highpass_hz)
        s = record.impact[0]
        scale = np.max(np.abs(proj @ record.x[:, s:w1]), axis=1)
        sim = simulate_mdof(model, record.t[s:w1], record.force[s:w1], x_scale=scale)
        q_sim = sim.x[:, w0 - s:]
        how = "force"
    else:
        s = w0
        scale = np.max(np.abs(proj @ record.x[:, s:w1]), axis=1)
        sim = simulate_mdof(model, record.t[s:w1], None, x0=proj @ record.x[:, s], v0=proj @ record.v[:, s],
                            x_scale=scale)
        q_sim = sim.x
        how = "initial state"
    y = record.x[:, w0:w1]
    y_sim = phi @ q_sim
    ok = not sim.diverged and np.all(np.isfinite(y_sim))
    per = {c: (float(np.linalg.norm(y_sim[k] - y[k]) / (np.linalg.norm(y[k]) or 1.0)) if ok else float("inf"))
           for k, c in enumerate(model.channels)}
    q_meas = proj @ y
    modes = np.array([float(np.linalg.norm(q_sim[i] - q_meas[i]) / (np.linalg.norm(q_meas[i]) or 1.0)) if ok
                      else float("inf") for i in range(model.n_coords)])
    return MdofValidation(record.label, float(np.mean(list(per.values()))), per, modes, how, not ok,
                          record.t[w0:w1], y, y_sim)
