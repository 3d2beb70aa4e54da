"""Is the refined model measurably worse than EDDI's on the record it was fitted to?

With no held-out record, :meth:`eddi.fit_record.Pipeline.fit` judges the output-error
refinement on the fit record's validation: the model simulated from rest, driven by the
measured impact, against the signal the sensor measured over the free response (the
refinement fitted a free response from a fitted state, not this). That judge has two
errors of its own, which neither model is responsible for:

* the measured noise: for two simulations ``s_r`` (refined) and ``s_e`` (EDDI) of the same
  measurement ``y = y_true + n``, ``||s_r - y||^2 - ||s_e - y||^2`` carries
  ``-2 n . (s_r - s_e)``, of standard deviation ``2 sigma ||s_r - s_e||`` (white noise
  ``sigma``);
* the impact's impulse: the simulation starts from the state the measured force gives it,
  and the impulse is known to ``sqrt(n_pulse var_f) dt`` (``var_f``: the per-sample noise
  variance of the drive, the force sensor's, or of its inverse-variance fusion with
  ``m a + B + K`` when the acceleration was measured). A drive off by that much scales the
  whole response: measured on ``benchmarks/bench_vs_sindy.py``'s held-out ``fast_hard``
  (80 Hz, a 1 ms pulse of 8 samples) at 45 dB, a drive 0.2 % off moved the judged nrmse from
  0.0085 to 0.011-0.016, while the refined and EDDI models differed by 0.0004 (and the
  refined one was the better by 1.4-3.7x in its coefficients).

So the refined model, the maximum-likelihood fit of the measured signal, is kept unless its
squared error exceeds EDDI's by more than :data:`WHITE_SIGMAS` standard deviations of the
noise term both at the measured drive and with each model's error profiled over the drive
scale within two standard uncertainties of the impulse (a parabola of the squared error
through the scales ``1 - u, 1, 1 + u``, minimised on ``[1 - 2u, 1 + 2u]``; run only when the
first test finds it worse: four more simulations).

A free decay (no force, no drive) is judged from each model's initial state fitted over the
window's first cycles (:func:`eddi.initial_state.fitted_state`), not from the state at its
first sample, which the pipeline's validation uses: on a record that starts in motion the
displacement of a velocity (or acceleration) record is an integral whose constant the
conditioning anchored over the whole record, and the velocity one noisy sample; EDDI, fitted
to that integral, then won. Session 14 (s14ci95), ``benchmarks/bench_ci_coverage_coarse.py
--family sensor --record free-vel`` draw seeds 1 and 2: the refinement was rejected on 12 and
14 of 40 records (``free-acc``: 32 and 31), EDDI's coefficients a median 16-32x further from
the truth than the refined ones on those records, their interval ``|c_EDDI - c_OE| + ci95_OE``
6-10x wider (coverage held either way).
Before (session 5: kept only when its nominal error was lower at all) the refinement was
rejected on 10 of the 40 held-out records (seeds 1-4, 30 and 45 dB), the refined
coefficients being the better ones on 7 of them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from eddi.driven_validation import fused_impact_force, validate_conditioned
from eddi.energy import noise_level
from eddi.model import EquationOfMotion
from eddi.peaks import finite

if TYPE_CHECKING:
    from eddi.conditioning import ConditionedSignal
    from eddi.validate import Validation

#: Most samples compared (evenly spaced over the window): the 45 s, 19.2 kHz record
#: compares 20,000 of its 460,000.
JUDGE_SAMPLES = 20000
#: The refined model is rejected when its squared error exceeds EDDI's by more than this
#: many standard deviations of the measured noise's share of the difference.
WHITE_SIGMAS = 2.0
#: The drive scale is profiled over this many standard uncertainties of the impulse.
DRIVE_SIGMAS = 2.0
#: The measured signal of each conditioned response.
CHANNEL = {"acc": "a", "vel": "v", "disp": "x"}


@dataclass(frozen=True)
class Judgement:
    """The refined model against EDDI's on the fit record.

    Attributes
    ----------
    nrmse_eddi, nrmse_refined : float
        ``||s - y|| / ||y||`` of each model's simulation (``inf`` when it blew up): at the
        measured drive, or, when the refined model was worse there, at the drive scale that
        suits each best within the impulse's uncertainty.
    excess_sigmas : float
        ``(nrmse_refined^2 - nrmse_eddi^2) ||y||^2`` over the standard deviation of the
        noise's share of it (negative: the refined model fits better).
    drive_uncertainty : float
        Relative standard uncertainty of the measured impulse (0 for a free response).
    refined_worse : bool
        True when ``excess_sigmas > WHITE_SIGMAS``.
    """

    nrmse_eddi: float
    nrmse_refined: float
    excess_sigmas: float
    drive_uncertainty: float
    refined_worse: bool


def judge_stride(cond: "ConditionedSignal") -> int:
    """The judge compares every ``judge_stride``-th sample of the window (at most :data:`JUDGE_SAMPLES`)."""
    w0, w1 = cond.window
    return max(1, (w1 - w0) // JUDGE_SAMPLES)


def impulse_uncertainty(cond: "ConditionedSignal", eom: EquationOfMotion) -> float:
    """Relative standard uncertainty of the impulse the validation drives ``eom`` with.

    0 when the validation is a free response (no force, or no rest before the impact).
    """
    if cond.impact_force is None or cond.impact_start <= 0 or cond.impact_end <= cond.impact_start:
        return 0.0
    s0, s1 = cond.impact_start, cond.impact_end
    var_f = cond.force_noise_rms**2
    if cond.acc_measured:
        var_a = (eom.mass * cond.noise_rms) ** 2
        var = var_f * var_a / (var_f + var_a) if var_f + var_a > 0 else 0.0
        drive = fused_impact_force(cond, eom, span=(s0, s1))  # the impact's samples alone
    else:
        var, drive = var_f, cond.impact_force[s0:s1]
    impulse = abs(float(np.sum(drive)))
    return math.sqrt(var * (s1 - s0)) / impulse if impulse > 0 else 0.0


def _simulated(eom: EquationOfMotion, cond: "ConditionedSignal", scale: float, k: int,
               val: "Validation | None" = None) -> np.ndarray:
    """The measured channel as ``eom`` simulates it for ``cond`` (drive times ``scale``), every ``k``-th sample.

    ``val``: ``validate_conditioned(eom, cond)`` when the caller has it (``scale`` 1), so it
    is not simulated again; it may hold every ``k``-th sample only (``val.every``, see
    :meth:`eddi.fit_record.Pipeline.fit`), not with a sampling kernel.
    """
    kv = cond.sample_kernel_var
    if val is None or scale != 1.0 or (val.every > 1 and (k % val.every or kv)):
        val, _ = validate_conditioned(eom, cond, drive_scale=scale, fitted_free_state=cond.impact_force is None)
    sub = k // val.every  # every k-th sample of the window in val's arrays
    if not math.isfinite(val.nrmse) or not finite(val.x_simulated):
        return np.full(val.x_simulated[::sub].size, np.inf)
    channel = CHANNEL[cond.response]
    step = 1 if kv else sub  # the DAQ's kernel needs neighbouring samples
    if channel == "x":
        out = val.x_simulated[::step]
    elif channel == "v":
        out = val.v_simulated[::step]
    else:
        from eddi.simulate import internal_force  # local: the simulator imports numba

        # the window is after the impact: no external force
        out = -internal_force(eom, val.x_simulated[::step], val.v_simulated[::step]) / eom.mass
    if kv and out.size >= 3:  # samples are the DAQ's kernel means (eddi.intervals.sampling_curvature)
        d2 = np.empty_like(out)
        d2[1:-1] = out[2:] - 2.0 * out[1:-1] + out[:-2]
        d2[0], d2[-1] = d2[1], d2[-2]
        out = (out + 0.5 * kv * d2)[::k]
    return out


def _profiled(eom: EquationOfMotion, cond: "ConditionedSignal", y: np.ndarray, u: float, k: int,
              sq: float) -> float:
    """Smallest ``||s - y||^2`` over drive scales within ``DRIVE_SIGMAS u`` of 1 (``sq``: at 1)."""
    if u <= 0 or not math.isfinite(sq):
        return sq
    lo = float(np.sum((_simulated(eom, cond, 1.0 - u, k) - y) ** 2))
    hi = float(np.sum((_simulated(eom, cond, 1.0 + u, k) - y) ** 2))
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return sq
    # parabola in the scale offset d (units of u) through d = -1, 0, 1
    curv, slope = 0.5 * (lo + hi) - sq, 0.5 * (hi - lo)
    ends = [-DRIVE_SIGMAS, DRIVE_SIGMAS, 0.0]
    if curv > 0:
        ends.append(min(max(-slope / (2.0 * curv), -DRIVE_SIGMAS), DRIVE_SIGMAS))
    return min(max(curv * d * d + slope * d + sq, 0.0) for d in ends)


def judge_fit_record(refined: EquationOfMotion, eddi: EquationOfMotion, cond: "ConditionedSignal",
                     validations: "tuple[Validation, Validation] | None" = None) -> Judgement:
    """Whether ``refined`` fits the fit record's measured signal measurably worse than ``eddi``.

    Parameters
    ----------
    refined, eddi : EquationOfMotion
        The refined model and EDDI's estimate.
    cond : ConditionedSignal
        The fit record.
    validations : (Validation, Validation), optional
        ``validate_conditioned(refined, cond)[0]`` and ``validate_conditioned(eddi, cond)[0]``
        when the caller already has them (:meth:`eddi.fit_record.Pipeline.fit` does): the
        same simulations, not run twice.

    Returns
    -------
    Judgement
    """
    w0, w1 = cond.window
    k = judge_stride(cond)
    meas_all = {"a": cond.a, "v": cond.v, "x": cond.x}[CHANNEL[cond.response]][w0:w1]
    y = meas_all[::k]
    norm2 = float(np.sum(y**2)) or 1.0
    # a free decay (no force): each model from its own state fitted over the first cycles, not
    # the pipeline's validations from the first sample's state (see the module notes)
    free = cond.impact_force is None
    val_r, val_e = validations if (validations is not None and not free) else (None, None)
    s_r, s_e = _simulated(refined, cond, 1.0, k, val_r), _simulated(eddi, cond, 1.0, k, val_e)
    with np.errstate(invalid="ignore", over="ignore"):  # a diverged simulation (inf - inf): judged below
        sq_r, sq_e = float(np.sum((s_r - y) ** 2)), float(np.sum((s_e - y) ** 2))
        diff = s_r - s_e
    sd = 2.0 * noise_level(meas_all) * float(np.linalg.norm(diff)) if np.all(np.isfinite(diff)) else 0.0
    u = impulse_uncertainty(cond, refined)
    excess = _excess(sq_r, sq_e, sd)
    if excess > WHITE_SIGMAS:
        # worse at the measured drive: is it at each model's best drive within the impulse's
        # uncertainty too? (only then measurably worse; 4 more simulations, so only here)
        sq_r, sq_e = _profiled(refined, cond, y, u, k, sq_r), _profiled(eddi, cond, y, u, k, sq_e)
        excess = _excess(sq_r, sq_e, sd)
    return Judgement(nrmse_eddi=math.sqrt(sq_e / norm2), nrmse_refined=math.sqrt(sq_r / norm2),
                     excess_sigmas=excess, drive_uncertainty=u, refined_worse=excess > WHITE_SIGMAS)


def _excess(sq_r: float, sq_e: float, sd: float) -> float:
    """``(sq_r - sq_e) / sd``, with the infinities of blown-up simulations."""
    if not math.isfinite(sq_r) or not math.isfinite(sq_e):
        if math.isfinite(sq_r) == math.isfinite(sq_e):
            return 0.0
        return math.inf if not math.isfinite(sq_r) else -math.inf
    diff = sq_r - sq_e
    return diff / sd if sd > 0 else (0.0 if diff == 0 else math.copysign(math.inf, diff))
