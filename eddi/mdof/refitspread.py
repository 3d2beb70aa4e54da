"""The identification's scatter from the measurement noise, measured by refitting a fold on noisier
copies of its training captures (session 20, issue 14 item 4).

A held-out fold's model is identified from noisy captures: its frequencies, damping, shapes and
masses carry the noise's scatter, and so does its prediction of the held-out capture. Session 19's
prediction floor (:mod:`eddi.mdof.predfloor`) counts the held-out capture's own noise and the blows'
impulses, not that scatter; linear nulls sat 1.04-1.39x above it (``none (uncertain)``). Its first
estimate, the folds' jackknife, measures how the model moves with WHICH captures it is fitted to,
and that grows with a missing nonlinear effect (the captures differ in amplitude): it hid a 5 %
coupling. This part moves the NOISE only: each training capture's accelerations get a fresh draw of
white noise at the level measured before the trigger (``acc_noise``; the displacement noise carried
back otherwise), from the impact on (the conditioning zeroes what comes before), and go again
through the same integration and zero-phase drift high-pass; the fold's model class (its
coordinates and coupling: :func:`refit_variant`) is identified again and predicts the held-out
capture. To first order the change of the prediction is the scatter one draw of the noise gives the
identification (the added draw has the measured level: the difference between the model from noise
``n`` and from ``n + n'`` is ``J n'``). RMS over :data:`REFIT_DRAWS` draws, per channel, relative to the
capture's RMS (the nrmse it adds).

A missing effect does not change the noise: this scatter is that of the model class as identified,
whatever the class misses (a class that misses an effect can be worse conditioned, and then its
scatter is larger; that is part of what its identification from these records leaves undetermined).

Cost: ``REFIT_DRAWS`` identifications of one variant per fold; the diagnosis runs it only where a
``none`` would otherwise be uncertain (:mod:`station.mdof_commands`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from scipy import signal

#: Noise draws per fold (each one identification): the RMS over them estimates the scatter.
REFIT_DRAWS = 2


def refit_variant(ident) -> tuple[str, bool | str]:
    """``(coordinates, coupling)`` that identify a model of ``ident``'s class again: lumped elements
    (linear), physical coordinates with linear springs between them, or each coordinate alone; a
    model with nonlinear terms between coordinates: the coupled class (``True``)."""
    model = ident.model
    cross = [t for i in range(model.n_coords) for t, c in model.terms(i) if c != 0.0 and set(t.coordinates) - {i}]
    if any(t.degree >= 2 for t in cross):
        return ident.coordinates, True
    if getattr(ident, "lumped", None) is not None:
        return "lumped", "linear"
    return ident.coordinates, ("linear" if cross else False)


def acc_sigma(record) -> np.ndarray:
    """Per channel the accelerometer's noise RMS [m/s^2] (as :func:`eddi.mdof.validate.noise_floor`)."""
    w0, w1 = record.window
    rms_x = np.sqrt(np.mean(record.x[:, w0:w1] ** 2, axis=1))
    rms_a = np.sqrt(np.mean(record.a[:, w0:w1] ** 2, axis=1))
    s_a = np.asarray(record.noise, float) * rms_a / np.maximum(rms_x, 1e-300)
    if record.acc_noise is not None:
        s_a = np.where(np.isfinite(record.acc_noise), np.nan_to_num(record.acc_noise), s_a)
    return s_a


def noisier(record, rng: np.random.Generator):
    """``record`` with a fresh draw of its accelerometers' noise added from the impact on, integrated
    and high-passed as the conditioning does (:func:`eddi.mdof.signals.kinematics`)."""
    from eddi.mdof.signals import motion_from_acc

    dt = float(record.t[1] - record.t[0])
    a = np.array(record.a, float)
    start = int(record.impact[0]) if record.impact[1] > 0 else 0
    a[:, start:] += acc_sigma(record)[:, None] * rng.standard_normal((a.shape[0], a.shape[1] - start))
    sos = signal.butter(4, record.highpass_hz, btype="highpass", fs=1.0 / dt, output="sos")
    v, x = motion_from_acc(a, dt, sos)
    return replace(record, x=x, v=v, a=a)


def refit_spread(ident, train: Sequence, held, names: Sequence[str], dp: str, seed: int = 0,
                 draws: int = REFIT_DRAWS) -> np.ndarray:
    """Per channel the RMS over ``draws`` of the change of the held-out prediction when the fold
    (``ident`` from ``train``) is identified again on noisier copies of ``train`` (module notes),
    relative to the held-out capture's RMS over its window. Zeros when no refit runs."""
    from eddi.errors import IdentificationError
    from eddi.mdof.identify import identify_mdof
    from eddi.mdof.validate import validate_mdof

    base = validate_mdof(ident.model, held)
    n_ch = len(names)
    if base.diverged:
        return np.zeros(n_ch)
    w0, w1 = held.window
    scale = np.maximum(np.linalg.norm(held.x[:, w0:w1], axis=1), 1e-300)
    coords, coupling = refit_variant(ident)
    rng = np.random.default_rng(seed)
    moves = []
    for _ in range(draws):
        try:
            again = identify_mdof([noisier(r, rng) for r in train], names, dp, coordinates=coords, coupling=coupling)
            v = validate_mdof(again.model, held)
        except (IdentificationError, ValueError, FloatingPointError, np.linalg.LinAlgError):
            continue
        if not v.diverged and v.simulated.shape == base.simulated.shape:
            moves.append(np.linalg.norm(v.simulated - base.simulated, axis=1) / scale)
    if not moves:
        return np.zeros(n_ch)
    return np.sqrt(np.mean(np.array(moves) ** 2, axis=0))
