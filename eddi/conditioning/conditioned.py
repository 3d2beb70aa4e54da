"""The result of conditioning: ``x, v, a`` on a uniform grid and the free-response window."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from eddi.errors import SignalError



@dataclass(frozen=True)
class ConditionedSignal:
    """Signals ready for identification.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
        Uniform time (the exact grid from the first to the last input time).
    x : ndarray, shape (n,), [m] (or [rad])
        Coordinate, from rest (0 before the impact when a pre-trigger was seen).
    v : ndarray, shape (n,), [m/s]
        Rate.
    a : ndarray, shape (n,), [m/s^2]
        Second derivative.
    force : ndarray, shape (n,), [N], or None
        Measured force with its pre-trigger offset removed.
    rate_hz : float
        Sample rate [Hz].
    free_start, free_stop : int
        Free-response window ``[free_start, free_stop)``: after the impact has ended, until
        the response sinks into the noise.
    method : str
        How ``x``, ``v`` and ``a`` were obtained.
    notes : tuple of str
        Facts found on the way (noise floor, knots, impact indices...).
    impact_start : int
        First sample of the motion (rest before it), 0 when no rest was seen.
    impact_end : int
        First sample after the impact force is back within the noise (== ``free_start``
        when there is a force channel).
    noise_rms : float
        Noise RMS of the measured response channel (units of that channel).
    force_noise_rms : float
        Noise RMS of the force channel [N] (0 without force).
    acc_measured : bool
        True when ``a`` is the measured acceleration (not a derivative).
    response : str
        The measured response channel the window and noise floor refer to: ``"acc"``,
        ``"vel"`` or ``"disp"`` (acceleration first when several were given).
    sample_kernel_var : float
        Variance of the DAQ's sampling kernel [sample intervals^2]: each sample is the
        signal's weighted mean over that kernel (its decimation filter: 0 for point samples
        or a flat passband, ``K / 12`` for a sinc^K decimator). The output-error fit compares
        the model through the same kernel (:func:`eddi.intervals.sampling_curvature`).
    sample_kernel_known : bool
        True when the sampling was stated (point samples or a decimation filter); otherwise the
        95 % intervals make room for means over each sample interval
        (:func:`eddi.intervals.sampling_kernel_margin`).
    ac_coupling_s : float
        Time constant [s] of the AC coupling inverted on the response channel (0: none). The
        inversion multiplies the channel's noise by ``|1 + 1 / (j 2 pi f tau)|`` at ``f``:
        white noise at rest comes out with a ``1/f`` rise below the corner.
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    force: np.ndarray | None
    rate_hz: float
    free_start: int
    free_stop: int
    method: str
    notes: tuple[str, ...] = field(default_factory=tuple)
    impact_start: int = 0
    impact_end: int = 0
    noise_rms: float = 0.0
    force_noise_rms: float = 0.0
    acc_measured: bool = False
    response: str = "acc"
    sample_kernel_var: float = 0.0
    sample_kernel_known: bool = False
    ac_coupling_s: float = 0.0

    def __post_init__(self) -> None:
        n = self.t.size
        for name in ("x", "v", "a"):
            if getattr(self, name).shape != (n,):
                raise SignalError(f"conditioned {name} has shape {getattr(self, name).shape}, expected ({n},)")
        if not 0 <= self.free_start < self.free_stop <= n:
            raise SignalError(
                f"free-response window [{self.free_start}, {self.free_stop}) is not inside 0..{n}"
            )

    @property
    def window(self) -> tuple[int, int]:
        """``(free_start, free_stop)``."""
        return (self.free_start, self.free_stop)

    @cached_property
    def impact_force(self) -> np.ndarray | None:
        """The force during the impact ``[impact_start, impact_end)``, zero elsewhere [N].

        Outside the impact a hammer's force sensor shows only its noise; this is the force
        a validation simulation should be driven with. Built once per record (a record's
        identification reads it ~6 times; each copy of a 45 s record at 19.2 kHz cost
        ~2.5 ms): do not modify it in place.
        """
        if self.force is None:
            return None
        f = np.zeros_like(self.force)
        f[self.impact_start: self.impact_end] = self.force[self.impact_start: self.impact_end]
        return f

