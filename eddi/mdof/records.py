"""One conditioned multi-channel record (:class:`ChannelRecord`), the input of :mod:`eddi.mdof`.

No I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eddi.mdof.signals import HIGHPASS_HZ


@dataclass(frozen=True)
class ChannelRecord:
    """One conditioned multi-channel record.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
    x, v, a : ndarray, shape (n_channels, n)
        Displacement [m], velocity [m/s], acceleration [m/s^2] of every response channel.
    force : ndarray, shape (n,), [N], or None
        Impact force at the driving point (zero outside the impact).
    impact : (int, int)
        ``[start, end)`` of the impact (``(0, 0)`` without force).
    window : (int, int)
        Free-response window ``[start, stop)``.
    noise : ndarray, shape (n_channels,)
        Noise RMS of each channel's displacement [m] (sets the zero-crossing dead band).
    label : str
    highpass_hz : float
        Cut-off of the zero-phase drift high-pass ``x`` and ``v`` went through [Hz].
    force_noise : float
        RMS of the force channel's noise per sample before the trigger [N] (0: unknown); the
        impulse it leaves in the blow sets the input's share of the noise floor
        (:func:`eddi.mdof.validate.impulse_floor`).
    acc_noise : ndarray, shape (n_channels,), [m/s^2], or None
        RMS of each accelerometer's noise as measured (before the trigger; NaN for a channel of
        another quantity; None: not known). :func:`eddi.mdof.validate.noise_floor` starts from it:
        ``noise`` went to metres through the channel's own window, which on a channel whose fast
        modes die early is far shorter than the record's (session 18).
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    force: np.ndarray | None
    impact: tuple[int, int]
    window: tuple[int, int]
    noise: np.ndarray
    label: str = ""
    highpass_hz: float = HIGHPASS_HZ
    force_noise: float = 0.0
    acc_noise: np.ndarray | None = None

