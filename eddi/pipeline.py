"""From conditioned measurements to a validated equation of motion.

A straight line, no numerics of its own: :func:`identify_measurement` takes a
:class:`~eddi.conditioning.ConditionedSignal`, runs :func:`eddi.identify.identify` on its
free-response window and :func:`eddi.validate.validate` on the same window:

* with a measured force and a rest seen before the impact: the identified equation is
  simulated from rest at the start of the motion, driven by the measured hammer force
  (zero after the impact has ended: what the force sensor shows then is its noise).
  During the impact the accelerometer measures the force too (``F = m a + B + K``, and
  ``m a`` dominates); when the acceleration was measured, the two estimates are averaged
  with inverse-variance weights (noise RMS of each channel from the pre-trigger). The
  impulse of a 45 dB force sensor is uncertain by ~0.2 %, which for a lightly damped,
  strongly hardening system shifts the simulated frequency enough to give nrmse ~0.05-0.1
  for the *true* model over tens of cycles; ``nrmse_force_sensor`` reports the
  validation driven by the force sensor alone;
* otherwise: a free response from the measured state at the start of the window.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eddi.conditioning import ConditionedSignal
from eddi.identify import IdentifiedModel, identify
from eddi.model import EquationOfMotion
from eddi.terms import DEFAULT_DAMPING, DEFAULT_STIFFNESS
from eddi.validate import Validation, validate


@dataclass(frozen=True)
class PipelineResult:
    """An identified and validated model.

    Attributes
    ----------
    conditioned : ConditionedSignal
        The signals identification ran on.
    model : IdentifiedModel
        What :func:`eddi.identify.identify` returned (``model.eom`` is the equation).
    validation : Validation
        Simulation of ``model.eom`` against ``conditioned.x`` over the free-response window
        (``validation.window`` is in the indices of ``conditioned``).
    driven_by_force : bool
        True when the validation was driven by the measured force from rest.
    nrmse_force_sensor : float or None
        The nrmse when driven by the force sensor alone (None when not computed).
    """

    conditioned: ConditionedSignal
    model: IdentifiedModel
    validation: Validation
    driven_by_force: bool
    nrmse_force_sensor: float | None = None


def identify_measurement(
    cond: ConditionedSignal,
    mass: float,
    *,
    damping: str | tuple[str, ...] | list[str] = DEFAULT_DAMPING,
    stiffness: str | tuple[str, ...] | list[str] = DEFAULT_STIFFNESS,
    route: str = "auto",
    sensor_only: bool = False,
    refine: bool = False,
) -> PipelineResult:
    """Identify and validate an equation of motion from a conditioned measurement.

    Parameters
    ----------
    cond : ConditionedSignal
        From :func:`eddi.conditioning.condition`.
    mass : float
        Mass [kg] (or inertia), > 0.
    damping, stiffness : str or sequence of str
        Candidate terms (see :func:`eddi.identify.identify`).
    route : {"auto", "potential", "lagrangian"}
        Phase-two route.
    sensor_only : bool
        Also validate with the force sensor alone (one more simulation), filling
        ``nrmse_force_sensor``.
    refine : bool
        Refine EDDI's coefficients by an output-error fit (see :func:`eddi.identify.identify`)
        to the signal the sensor measured (``cond.response``: acceleration, rate or
        coordinate), not to one derived from it.

    Returns
    -------
    PipelineResult

    Raises
    ------
    ModelError, TermError, SignalError, IdentificationError
        As :func:`eddi.identify.identify`.
    """
    model = identify(cond.t, cond.x, cond.v, mass, damping=damping, stiffness=stiffness,
                     route=route, a=cond.a, window=cond.window,
                     refine={"acc": "a", "vel": "v", "disp": "x"}[cond.response] if refine else False)
    force = cond.impact_force
    if force is not None and cond.impact_start > 0:
        # simulate from the start of the motion to the end of the window, no further (the
        # samples after the window are noise; simulating them doubled the cost on a 45 s record)
        s, e = cond.impact_start, cond.free_stop
        window = (cond.free_start - s, cond.free_stop - s)
        if not cond.acc_measured:
            sensor = validate(model.eom, cond.t[s:e], cond.x[s:e], v=cond.v[s:e],
                              force=force[s:e], window=window)
            return PipelineResult(cond, model, _shift(sensor, s), True, sensor.nrmse)
        val = validate(model.eom, cond.t[s:e], cond.x[s:e], v=cond.v[s:e],
                       force=fused_impact_force(cond, model.eom)[s:e], window=window)
        nrmse_sensor = None
        if sensor_only:
            nrmse_sensor = validate(model.eom, cond.t[s:e], cond.x[s:e], v=cond.v[s:e],
                                    force=force[s:e], window=window).nrmse
        return PipelineResult(cond, model, _shift(val, s), True, nrmse_sensor)
    val = validate(model.eom, cond.t, cond.x, v=cond.v, window=cond.window)
    return PipelineResult(cond, model, val, False)


def fused_impact_force(cond: ConditionedSignal, eom: EquationOfMotion) -> np.ndarray:
    """Impact force from the force sensor and the accelerometer, inverse-variance weighted.

    Parameters
    ----------
    cond : ConditionedSignal
        With a force channel and a measured acceleration.
    eom : EquationOfMotion
        Gives ``F_acc = m a + restoring_force(x, v)`` during the impact.

    Returns
    -------
    ndarray, shape (n,), [N]
        Zero outside ``[impact_start, impact_end)``.
    """
    f = cond.impact_force
    assert f is not None
    s0, s1 = cond.impact_start, cond.impact_end
    f_acc = eom.mass * cond.a[s0:s1] + eom.restoring_force(cond.x[s0:s1], cond.v[s0:s1])
    var_f = cond.force_noise_rms**2
    var_a = (eom.mass * cond.noise_rms) ** 2
    w = var_a / (var_f + var_a) if var_f + var_a > 0 else 0.5
    out = np.zeros_like(f)
    out[s0:s1] = w * f[s0:s1] + (1.0 - w) * f_acc
    return out


def _shift(val: Validation, offset: int) -> Validation:
    """The same validation with its window in the indices of the whole record."""
    w0, w1 = val.window
    return Validation(
        nrmse=val.nrmse, nmte=val.nmte, t=val.t, x_measured=val.x_measured,
        x_simulated=val.x_simulated, v_measured=val.v_measured, v_simulated=val.v_simulated,
        window=(w0 + offset, w1 + offset), diverged=val.diverged,
    )
