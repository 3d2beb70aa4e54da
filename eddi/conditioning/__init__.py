"""Measurement conditioning: what a bench measures -> ``x, v, a`` and the free-response window.

A hammer test measures force and acceleration (or a laser vibrometer measures velocity).
EDDI needs the coordinate ``x``, its rate ``v`` and (for phase two) ``a``, over the part of
the record where the structure rings down freely and the response is above the noise.

Drift-free integration (``acc`` -> ``v``, ``x``), see ``docs/conditioning.md``
---------------------------------------------------------------------------------
1. Integrate the (bias-corrected) acceleration from rest: the pre-trigger proves
   ``x = v = 0`` there, so nothing is filtered and the impulse response keeps all of its
   low-frequency content (the mean of an impulse response is the impulse times the
   compliance, which a high-pass removes).
2. The integrated ``x`` carries a smooth drift ``d(t)`` (noise random walk, sensor bias,
   IEPE coupling). ``d`` is estimated only where the true ``x`` is known to be zero: at the
   zero crossings of the acceleration in the free response (``a = 0`` means
   ``K(x) = -B(x, v)``, i.e. ``x ~ 0`` for a restoring force with its only zero at 0; the
   small damping offset alternates in sign and averages out), and in the tail where the
   response has sunk into the noise. ``d`` is a cubic spline with knots every two of the
   longest periods, clamped to ``d = d' = 0`` at the start of the motion.
3. ``x = x_int - d`` and ``v = v_int - d'``; ``a`` is the measured acceleration.

Velocity-only input (laser vibrometer) is integrated the same way (``v`` is kept as
measured) and differentiated with a Savitzky-Golay filter (zero phase) for ``a``.

Records that start in motion (no rest before them, e.g. vibrometer ring-downs): the
integration constants are unknown. :func:`integrate_about_equilibrium` makes the integral
average to zero over every cycle of every mode (a cascade of moving averages over the
modes' periods, the lowest mode's period tracked along the record; the drift is a spline
through those means), integrating through a cubic spline (the trapezoid rule loses
``(w h)^2 / 12`` of the amplitude). When ``x`` at the zero crossings of ``a`` behaves as one
restoring force (:func:`anchor_residual` < :data:`ONE_FORCE_RESIDUAL`) the ``a = 0``
anchors above are used on top (they handle damping, chirp and asymmetry); with several
modes ``a = 0`` does not mean ``x = 0`` and the cycle means alone are used.

:func:`integrate_highpass` is the paper's procedure (integrate, then a zero-phase
third-order Butterworth high-pass at 2-3 Hz; paper Sec. 4.1 and 4.2), kept for comparison.
"""

from eddi.calculus import spline_cumulative_integral
from eddi.conditioning.checks import check_channel, check_time, clip_on_blow, clipped_run, dropout_runs
from eddi.conditioning.conditioned import ConditionedSignal
from eddi.conditioning.conditioner import (
    ANCHOR_HALF_WIDTH, KNOT_PERIODS, MIN_CROSSINGS, ONE_FORCE_RESIDUAL, condition,
)
from eddi.conditioning.equilibrium import EquilibriumIntegral, integrate_about_equilibrium
from eddi.conditioning.kinematics import anchor_residual, integrate_highpass
from eddi.conditioning.levels import crossings, noise_rms

__all__ = [
    "ANCHOR_HALF_WIDTH", "KNOT_PERIODS", "MIN_CROSSINGS", "ONE_FORCE_RESIDUAL",
    "ConditionedSignal", "EquilibriumIntegral", "anchor_residual", "check_channel", "check_time",
    "clip_on_blow", "clipped_run", "dropout_runs", "condition", "crossings", "integrate_about_equilibrium", "integrate_highpass",
    "noise_rms", "spline_cumulative_integral",
]
