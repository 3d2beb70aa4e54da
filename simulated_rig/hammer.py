"""The modal hammer: a half-sine force pulse whose width is set by the tip.

A hammer blow of peak ``P`` and contact time ``T`` is modelled as::

    F(t) = P * sin(pi * t / T)   for 0 <= t <= T, else 0

whose impulse is ``2 P T / pi`` [N s]. The contact time depends mainly on the tip (typical
values for a small modal hammer such as the PCB 086C03 of paper Sec. 3.3.1): steel ~0.2 ms,
plastic ~1 ms, rubber ~3 ms. A *double hit* (the hammer bouncing back onto the structure)
adds a second, smaller pulse a few milliseconds later.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import Mapping

import numpy as np

from simulated_rig.errors import ScenarioError

#: Contact time [s] of each tip.
TIP_PULSE_WIDTH_S: Mapping[str, float] = MappingProxyType(
    {"steel": 0.2e-3, "plastic": 1.0e-3, "rubber": 3.0e-3}
)


@dataclass(frozen=True)
class HammerSpec:
    """How the hammer hits.

    Attributes
    ----------
    tip : str
        One of :data:`TIP_PULSE_WIDTH_S` (``"steel"``, ``"plastic"``, ``"rubber"``).
    pulse_width_s : float or None
        Contact time [s]; overrides the tip's when given.
    double_hit_delay_s : float
        Start of the second pulse after the first [s] (double hits only).
    double_hit_ratio : float
        Peak of the second pulse relative to the first, in (0, 1].
    """

    tip: str = "plastic"
    pulse_width_s: float | None = None
    double_hit_delay_s: float = 4.0e-3
    double_hit_ratio: float = 0.3

    def __post_init__(self) -> None:
        if self.tip not in TIP_PULSE_WIDTH_S:
            raise ScenarioError(
                f"hammer.tip: unknown tip {self.tip!r}; known: {', '.join(TIP_PULSE_WIDTH_S)}"
            )
        if self.pulse_width_s is not None and not (1e-5 <= self.pulse_width_s <= 0.1):
            raise ScenarioError(
                f"hammer.pulse_width_s: must be in [1e-05, 0.1] s, got {self.pulse_width_s}"
            )
        if not (0.0 < self.double_hit_ratio <= 1.0):
            raise ScenarioError(
                f"hammer.double_hit_ratio: must be in (0, 1], got {self.double_hit_ratio}"
            )
        if not (self.double_hit_delay_s >= self.width_s):
            raise ScenarioError(
                f"hammer.double_hit_delay_s: must be >= the pulse width {self.width_s} s, "
                f"got {self.double_hit_delay_s}"
            )

    @property
    def width_s(self) -> float:
        """Contact time of one pulse [s]."""
        return float(self.pulse_width_s if self.pulse_width_s is not None else TIP_PULSE_WIDTH_S[self.tip])

    @property
    def duration_s(self) -> float:
        """Time from the start of the first pulse to the end of a double hit [s]."""
        return self.double_hit_delay_s + self.width_s


def half_sine(t: np.ndarray, peak_n: float, width_s: float, start_s: float = 0.0) -> np.ndarray:
    """A half-sine pulse sampled at ``t`` as its average over each sample interval.

    Sample ``i`` holds the mean of the pulse over ``[t_i - dt/2, t_i + dt/2]`` (an ideal
    integrating anti-alias filter), so the samples carry the exact impulse at any rate (a
    0.2 ms steel-tip pulse point-sampled at 5 kHz would vanish). For pulses much wider than
    a sample this equals point sampling to ``O((pi dt / T)^2 / 24)``.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Uniform sample times.
    peak_n : float
        Peak force [N].
    width_s : float
        Contact time [s].
    start_s : float
        Start of the pulse [s].

    Returns
    -------
    ndarray, shape (n,), [N]
    """
    t = np.asarray(t, dtype=float)
    if t.size < 2:
        tau = t - start_s
        inside = (tau >= 0.0) & (tau <= width_s)
        return np.where(inside, peak_n * np.sin(np.pi * np.clip(tau, 0.0, width_s) / width_s), 0.0)
    dt = float(t[1] - t[0])
    a = np.clip(t - 0.5 * dt - start_s, 0.0, width_s)
    b = np.clip(t + 0.5 * dt - start_s, 0.0, width_s)
    w = np.pi / width_s
    return peak_n * (np.cos(w * a) - np.cos(w * b)) / (w * dt)


def pulse_impulse(peak_n: float, width_s: float) -> float:
    """Impulse [N s] of a half-sine pulse: ``2 P T / pi``."""
    return 2.0 * peak_n * width_s / math.pi


def hammer_force(t: np.ndarray, peak_force_n: float, hammer: HammerSpec = HammerSpec(),
                 double_hit: bool = False) -> np.ndarray:
    """Force of one blow starting at ``t = 0``.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Sample times; the blow starts at 0.
    peak_force_n : float
        Peak of the (first) pulse [N].
    hammer : HammerSpec
    double_hit : bool
        Add the second pulse (``hammer.double_hit_ratio * peak`` at ``hammer.double_hit_delay_s``).

    Returns
    -------
    ndarray, shape (n,), [N]
    """
    f = half_sine(t, peak_force_n, hammer.width_s)
    if double_hit:
        f = f + half_sine(t, hammer.double_hit_ratio * peak_force_n, hammer.width_s,
                          hammer.double_hit_delay_s)
    return f
