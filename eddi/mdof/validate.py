"""Prediction of every channel by an :class:`~eddi.mdof.model.MdofModel`, scored per channel.

With a force: simulated from rest at the start of the impact, driven by the measured impact
force (zero after it). Without: from the state projected on the model's coordinates at the
start of the free window. The simulated displacement goes through the drift high-pass the
measurement went through; each channel is compared over the free window:
``nrmse_c = ||y_sim - y|| / ||y||`` per channel (as the single-DOF ``eddi.validate``), and
``nrmse`` is their mean.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from eddi.calculus import trapezoid
from eddi.mdof.identify import ChannelRecord
from eddi.mdof.model import MdofModel
from eddi.mdof.signals import highpass
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


@dataclass(frozen=True)
class SimulationStart:
    """Where and how a record's held-out simulation starts (:func:`simulation_start`).

    Attributes
    ----------
    sample : int
        First simulated sample (the impact's start, or the free window's).
    force : ndarray or None
        The measured force from ``sample`` on [N], or None (free response from a state).
    x0, v0 : ndarray or None
        Modal initial state (None when driven by the force from rest).
    x_scale : ndarray
        Largest modal displacement over the simulated part (the divergence scale).
    driven_by : str
        ``"force"`` or ``"initial state"``.
    states : ndarray, shape (n_coords, k)
        The record's coordinates over the simulated part (up to the free window's end): the
        states the simulation meets, which set its sub-steps
        (:func:`eddi.mdof.simulate.trajectory_substeps`).
    """

    sample: int
    force: np.ndarray | None
    x0: np.ndarray | None
    v0: np.ndarray | None
    x_scale: np.ndarray
    driven_by: str
    states: np.ndarray


def simulation_start(model: MdofModel, record: ChannelRecord) -> SimulationStart:
    """From rest driven by the measured force when the record holds the impact, else from the
    free window's first state projected on the model's coordinates (the one rule that
    :func:`predict_channels` and :func:`eddi.mdof.sensitivity.predict_sensitivities` share)."""
    proj = np.linalg.pinv(model.phi)
    w0, w1 = record.window
    if record.force is not None and record.impact[1] > record.impact[0]:
        s = record.impact[0]
        q = proj @ record.x[:, s:w1]
        return SimulationStart(s, record.force[s:], None, None, np.max(np.abs(q), axis=1), "force", q)
    q = proj @ record.x[:, w0:w1]
    return SimulationStart(w0, None, q[:, 0], proj @ record.v[:, w0], np.max(np.abs(q), axis=1), "initial state", q)


def predict_channels(model: MdofModel, record: ChannelRecord
                     ) -> tuple[np.ndarray, np.ndarray, str, bool]:
    """Simulated displacement of every channel and coordinate over the record's free window.

    The simulation is put through the same zero-phase drift high-pass the measurement went
    through (:func:`eddi.mdof.signals.highpass` at ``record.highpass_hz``), so both sides
    lack the same slow part.

    Returns
    -------
    y_sim : ndarray, shape (n_channels, k)
    q_sim : ndarray, shape (n_coords, k)
    driven_by : str
    diverged : bool
    """
    phi = model.phi
    w0, w1 = record.window
    n = record.t.size
    rate = 1.0 / float(record.t[1] - record.t[0])
    st = simulation_start(model, record)
    s, how = st.sample, st.driven_by
    sim = simulate_mdof(model, record.t[s:], st.force, x0=st.x0, v0=st.v0, states=st.states)
    if sim.diverged or not np.all(np.isfinite(sim.x)):
        return np.full((phi.shape[0], w1 - w0), np.nan), np.full((model.n_coords, w1 - w0), np.nan), how, True
    q = np.zeros((model.n_coords, n))
    q[:, s:] = sim.x
    q = highpass(q, rate, record.highpass_hz, times=2)[:, w0:w1]  # as the measured x (integrated filtered v)
    return phi @ q, q, how, False


def validate_mdof(model: MdofModel, record: ChannelRecord) -> MdofValidation:
    """Simulate ``model`` for ``record`` and score each channel (module docstring)."""
    if record.x.shape[0] != len(model.channels):
        raise ValueError(f"{record.label}: {record.x.shape[0]} response channels, the model predicts "
                         f"{len(model.channels)} ({', '.join(model.channels)})")
    w0, w1 = record.window
    y = record.x[:, w0:w1]
    y_sim, q_sim, how, div = predict_channels(model, record)
    ok = not div
    per = {c: (float(np.linalg.norm(y_sim[k] - y[k]) / (np.linalg.norm(y[k]) or 1.0)) if ok else float("inf"))
           for k, c in enumerate(model.channels)}
    q_meas = np.linalg.pinv(model.phi) @ y
    modes = np.array([float(np.linalg.norm(q_sim[i] - q_meas[i]) / (np.linalg.norm(q_meas[i]) or 1.0)) if ok
                      else float("inf") for i in range(model.n_coords)])
    return MdofValidation(record.label, float(np.mean(list(per.values()))), per, modes, how, not ok,
                          record.t[w0:w1], y, y_sim)


def impulse_floor(record: ChannelRecord) -> float:
    """The relative error of the blow's impulse that the force channel's noise leaves: the
    nrmse it sets on every channel of a simulation driven by the measured force.

    The simulation is driven by the force measured during the impact (zero outside it), so the
    force noise of those ``n`` samples (``record.force_noise`` per sample, the pre-trigger's RMS)
    is an impulse error ``sigma_F sqrt(n) dt`` against the blow's ``|sum F| dt``. A blow much
    shorter than the modes' periods is felt through its impulse alone: that relative error
    scales the whole response, an error at the modes' frequencies (not a drift), as large on
    every channel and held out as in training. Measured (two-mass chain chain-6-0 of
    ``bench_mdof_target.py``, 0.01 N force noise, 0.6-2 N blows of 7-9 samples): the model
    EDDI identified (coefficients within 0.06 %) reproduced its 0.6 / 1.2 / 2 N blows at
    0.005 / 0.011 / 0.003 nrmse, at the mode's 9 Hz, where :func:`noise_floor` allows 0.002;
    this gives 0.011 / 0.006 / 0.004 (the noise is one draw per blow).
    0 without a force or its noise.
    """
    if record.force is None or record.force_noise <= 0 or record.impact[1] <= record.impact[0]:
        return 0.0
    i0, i1 = record.impact
    impulse = abs(float(np.sum(record.force[i0:i1])))
    if impulse <= 0:
        return 0.0
    return float(record.force_noise * np.sqrt(i1 - i0) / impulse)


def noise_floor(record: ChannelRecord) -> np.ndarray:
    """The nrmse the measurement noise alone leaves on each channel's conditioned displacement.

    White acceleration noise of RMS ``s_a`` (the record's ``noise`` carried back to the
    acceleration by the window's RMS ratio) integrated twice through the zero-phase drift
    high-pass (4th-order Butterworth at ``f_c``, run forward and backward on ``v`` and again on
    ``x``: power gain ``(1 + (f_c / f)^8)^-4``) has the displacement RMS
    ``s_a sqrt(int (2 pi f)^-4 (1 + (f_c / f)^8)^-4 df / (f_s / 2))``, relative to the
    channel's RMS over the window. It falls as ``f_c^-1.5``: a record whose lowest spectral
    peak set a 2 Hz cut-off (a small blow on the energy sink) has a floor of 0.05, one at
    7 Hz 0.005 (measured: the true model's nrmse on the same records 0.048-0.061 and
    0.005-0.010, predicted 0.047-0.052 and 0.005-0.011).

    ``s_a`` is the accelerometer's noise as measured (``record.acc_noise``) where known. Before
    session 18 it was ``record.noise`` carried back by the window's RMS ratio of acceleration to
    displacement; but ``noise`` went to metres through the channel's OWN window, and on a channel
    whose fast, heavily damped modes die early that window is a fraction of the record's, with
    far more acceleration per metre: on the low-large-mode chains of
    ``benchmarks/bench_mdof_leak.py`` (t3c, t3d: 2.5 / 15.6 / 22.5 Hz, modes 2-3 5-10 % damped)
    the floor of the light masses' channels was 1.5-2.3x below what the true model itself left
    (0.036-0.044 against 0.065-0.092); from the measured noise the ratio is 0.8-1.4.

    Returns
    -------
    ndarray, shape (n_channels,)
    """
    w0, w1 = record.window
    rate = 1.0 / float(record.t[1] - record.t[0])
    rms_x = np.sqrt(np.mean(record.x[:, w0:w1] ** 2, axis=1))
    rms_a = np.sqrt(np.mean(record.a[:, w0:w1] ** 2, axis=1))
    s_a = record.noise * rms_a / np.maximum(rms_x, 1e-300)
    if record.acc_noise is not None:
        s_a = np.where(np.isfinite(record.acc_noise), np.nan_to_num(record.acc_noise), s_a)
    fc = record.highpass_hz
    f = np.geomspace(0.05 * fc, rate / 2, 4000)
    gain = (2 * np.pi * f) ** -4 * (1 + (fc / f) ** 8) ** -4
    s_x = s_a * np.sqrt(trapezoid(gain, f) / (rate / 2))
    return s_x / np.maximum(rms_x, 1e-300)


def force_floor(model: MdofModel, record: ChannelRecord) -> np.ndarray:
    """The nrmse the uncertainty of the measured impulse alone leaves on each channel.

    The model simulated with the measured force scaled by ``1 +- u`` (``u`` from
    :func:`impulse_floor`): the RMS of the two predictions' moves, relative to each channel's
    RMS over the window. Where a response is sensitive to its initial energy (the energy sink:
    whether and when energy pumping sets in) this is no small correction: the bench's nes-5-1
    moves 0.12-0.29 on the sink channel for a 0.15-0.47 % impulse uncertainty, and the true model
    reproduced those captures at 0.07-0.21 while it met the ideal (noise-free) force to 0.0004.
    Zeros without a force or a force noise; NaN where a scaled simulation diverges.

    Returns
    -------
    ndarray, shape (n_channels,)
    """
    n_ch = len(model.channels)
    u = impulse_floor(record)
    if u <= 0:
        return np.zeros(n_ch)
    y0, _q, _how, div = predict_channels(model, record)
    if div:
        return np.full(n_ch, np.nan)
    w0, w1 = record.window
    rms = np.linalg.norm(record.x[:, w0:w1], axis=1)
    moves = []
    for sign in (1.0, -1.0):
        y, _q, _how, div = predict_channels(model, replace(record, force=record.force * (1.0 + sign * u)))
        if div:
            return np.full(n_ch, np.nan)
        moves.append(np.linalg.norm(y - y0, axis=1) ** 2)
    return np.sqrt(np.mean(moves, axis=0)) / np.maximum(rms, 1e-300)
