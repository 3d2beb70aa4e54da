"""Predicting a record with a modal-sum model: initial states from a short window, recombined simulation, errors."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eddi.errors import SignalError
from eddi.multimode.model import ModalSumModel
from eddi.simulate import simulate


@dataclass(frozen=True)
class ModalSimulation:
    """Simulated modal-sum response.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
    v : ndarray, shape (n,)
        Summed velocity (the observable).
    x_modes, v_modes : ndarray, shape (n_modes, n)
        Each mode's coordinate and rate.
    diverged : bool
        True when any mode blew up.
    """

    t: np.ndarray
    v: np.ndarray
    x_modes: np.ndarray
    v_modes: np.ndarray
    diverged: bool


def simulate_modal(
    model: ModalSumModel, t: np.ndarray, initial_states: np.ndarray
) -> ModalSimulation:
    """Free response of every mode from its initial state, summed.

    Parameters
    ----------
    model : ModalSumModel
    t : ndarray, shape (n,), [s]
        Uniform output times; ``t[0]`` is where the initial states hold.
    initial_states : ndarray, shape (n_modes, 2)
        ``(x_k, v_k)`` of each mode at ``t[0]``.

    Returns
    -------
    ModalSimulation
    """
    init = np.asarray(initial_states, dtype=float)
    if init.shape != (len(model.modes), 2):
        raise SignalError(
            f"initial_states must have shape ({len(model.modes)}, 2), got {init.shape}"
        )
    xs, vs, div = [], [], False
    for eom, (x0, v0) in zip(model.modes, init):
        res = simulate(eom, t, x0=float(x0), v0=float(v0))
        xs.append(res.x)
        vs.append(res.v)
        div = div or res.diverged
    v_modes = np.array(vs)
    return ModalSimulation(
        t=np.asarray(t, dtype=float), v=v_modes.sum(axis=0), x_modes=np.array(xs),
        v_modes=v_modes, diverged=div,
    )


def estimate_initial_states(
    model: ModalSumModel, t: np.ndarray, v: np.ndarray, window_s: float | None = None
) -> np.ndarray:
    """Modal states at ``t[0]`` that best explain the first ``window_s`` of the velocity.

    Only samples in ``[t[0], t[0] + window_s]`` are used, so the estimate is available
    ``window_s`` after the start (no filter looks beyond it). Each mode's amplitude and phase
    are found by linear least squares on the modes' linear free responses, then refined by
    nonlinear least squares on the full model.

    Parameters
    ----------
    model : ModalSumModel
    t : ndarray, shape (n,), [s]
    v : ndarray, shape (n,), [m/s]
    window_s : float, optional
        Defaults to ``model.initial_window_s``.

    Returns
    -------
    ndarray, shape (n_modes, 2)
        ``(x_k, v_k)`` per mode at ``t[0]``.
    """
    from eddi.multimode.separate import check_signal  # local: separate imports scipy.signal

    t, v, dt = check_signal(t, v)
    w = model.initial_window_s if window_s is None else float(window_s)
    n = min(t.size, max(8, int(round(w / dt)) + 1))
    tw, vw = t[:n], v[:n]
    n_modes = len(model.modes)
    # linear start: basis responses of each mode's linear part, from unit x0 and unit v0
    basis = []
    for eom in model.modes:
        lin = eom.model_copy(update={
            "damping": {k_: c for k_, c in eom.damping.items() if k_ == "v"},
            "stiffness": {k_: c for k_, c in eom.stiffness.items() if k_ == "x"},
            "effects": (),
        })
        basis.append(simulate(lin, tw, x0=1.0, v0=0.0).v)
        basis.append(simulate(lin, tw, x0=0.0, v0=1.0).v)
    p0, *_ = np.linalg.lstsq(np.column_stack(basis), vw, rcond=None)
    scale = np.array([[1.0 / max(math.sqrt(abs(m.linear_stiffness())), 1.0), 1.0] for m in model.modes])
    scale = scale * max(float(np.max(np.abs(vw))), 1e-300)

    big = 1e3 * max(float(np.max(np.abs(vw))), 1e-300)

    def resid(p: np.ndarray) -> np.ndarray:
        st = p.reshape(n_modes, 2) * scale
        r = simulate_modal(model, tw, st).v - vw
        return np.where(np.isfinite(r), r, big)

    z0 = (p0.reshape(n_modes, 2) / scale).ravel()
    from scipy import optimize  # local: station identify reads trajectory_errors only (no scipy.optimize)

    sol = optimize.least_squares(resid, z0, method="lm", xtol=1e-10, ftol=1e-10)
    return sol.x.reshape(n_modes, 2) * scale


def impact_index(v: np.ndarray) -> int:
    """Index of the largest ``|v|``: where the free decay is taken to start.

    Parameters
    ----------
    v : ndarray, shape (n,)
    """
    v = np.asarray(v, dtype=float)
    if v.size == 0:
        raise SignalError("empty record")
    return int(np.argmax(np.abs(v)))


@dataclass(frozen=True)
class TrajectoryErrors:
    """Prediction errors of one record.

    Attributes
    ----------
    nmte : float
        ``mean_t |y_pred - y| / max_t |y|`` (Cenedese et al. 2022, ``computeTrajectoryErrors``).
    nrmse : float
        ``||y_pred - y||_2 / ||y||_2`` (the form :func:`eddi.validate.validate` uses).
    """

    nmte: float
    nrmse: float


def trajectory_errors(y_pred: np.ndarray, y: np.ndarray) -> TrajectoryErrors:
    """NMTE and NRMSE of a predicted trajectory against the measured one.

    Parameters
    ----------
    y_pred, y : ndarray, shape (n,)

    Returns
    -------
    TrajectoryErrors
    """
    y_pred = np.asarray(y_pred, dtype=float)
    y = np.asarray(y, dtype=float)
    if y_pred.shape != y.shape or y.size == 0:
        raise SignalError(f"expected two arrays of the same non-zero length, got {y_pred.shape} and {y.shape}")
    err = y_pred - y
    if not np.all(np.isfinite(err)):
        return TrajectoryErrors(nmte=math.inf, nrmse=math.inf)
    peak = float(np.max(np.abs(y)))
    norm = float(np.linalg.norm(y))
    return TrajectoryErrors(
        nmte=float(np.mean(np.abs(err)) / peak) if peak > 0 else math.inf,
        nrmse=float(np.linalg.norm(err) / norm) if norm > 0 else math.inf,
    )


@dataclass(frozen=True)
class Prediction:
    """A record predicted from its initial state.

    Attributes
    ----------
    start : int
        Index of the record where prediction starts (the impact).
    t : ndarray, shape (m,), [s]
    v_measured, v_predicted : ndarray, shape (m,)
    initial_states : ndarray, shape (n_modes, 2)
    errors : TrajectoryErrors
    simulation : ModalSimulation
    """

    start: int
    t: np.ndarray
    v_measured: np.ndarray
    v_predicted: np.ndarray
    initial_states: np.ndarray
    errors: TrajectoryErrors
    simulation: ModalSimulation


def predict_record(
    model: ModalSumModel, t: np.ndarray, v: np.ndarray, *, start: int | None = None,
    window_s: float | None = None,
) -> Prediction:
    """Predict a velocity record from its initial state and score it.

    Parameters
    ----------
    model : ModalSumModel
    t : ndarray, shape (n,), [s]
    v : ndarray, shape (n,), [m/s]
    start : int, optional
        First sample of the free decay (default: :func:`impact_index`).
    window_s : float, optional
        Initial-state window (default ``model.initial_window_s``).

    Returns
    -------
    Prediction
    """
    from eddi.multimode.separate import check_signal  # local: separate imports scipy.signal

    t, v, _dt = check_signal(t, v)
    i0 = impact_index(v) if start is None else int(start)
    if not 0 <= i0 < t.size - 64:
        raise SignalError(f"start index must leave at least 64 samples, got {i0} of {t.size}")
    tt, vv = t[i0:], v[i0:]
    init = estimate_initial_states(model, tt, vv, window_s)
    sim = simulate_modal(model, tt, init)
    return Prediction(
        start=i0, t=tt, v_measured=vv, v_predicted=sim.v, initial_states=init,
        errors=trajectory_errors(sim.v, vv), simulation=sim,
    )
