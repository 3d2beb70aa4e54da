"""The check for an undeclared accelerometer AC coupling (IEPE) on one record, run on the fit
record by every command that identifies (``identify``, ``replay``, ``report``, ``demo``, a
campaign's identify; ``diagnose`` once for its diagnosis), so that each warns alike.

Cheap part, on every record with a measured force and acceleration: the corner that best
explains the pipeline's drive misfit (:func:`eddi.coupling_check.highpass_estimate`, no new
simulation). The identified model has absorbed part of the coupling (its phase lead leaks into
the coefficients), so that corner is low (0.10 Hz for a 0.3 Hz coupling on a 5 Hz, 500 kg
system): it is a *symptom*. Only when it stands far above its noise (:data:`SYMPTOM_SIGMAS`
standard errors, :data:`SYMPTOM_HZ` and :data:`SYMPTOM_PHASE`), or when the drive judge rejected
the refinement on a structure slower than :data:`SLOW_HZ`, the expensive part runs: the record is conditioned again
with the coupling inverted at the corners of :data:`CORNERS_HZ` (increasing, up to a fifth of
the structure's frequency, stopping :data:`PATIENCE` corners past the best), EDDI refitted (no
refinement: 0.12 s CPU each on a 20 s, 5 kHz record), and each refit simulated, passed through
its corner and compared with the record *as measured* (like for like with the drive judge); a
parabola in ``log f_c`` through the best three gives the corner (one more refit). The coupling is evident when that corner is
plausible for a sensor and its model, simulated and passed through the coupling, reproduces the
record *as measured* with at most ``1 - EXPLAINED`` of the as-is squared misfit beyond the
measured noise's share (like for like with the drive judge). Then identify warns and reports the corner; coefficients are not changed
(the sensor's data-sheet corner, passed as ``--sensor-highpass``, is the better number).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Sequence

from eddi.coupling_check import CORNER_RANGE_HZ, EXPLAINED, MAX_CORNER_SHARE, highpass_estimate, misfit_through

if TYPE_CHECKING:
    from eddi.fit_record import PipelineResult
    from station.readers import Measurement
    from station.session import SessionResult

#: The cheap estimate must exceed this many standard errors to run the corner search ...
SYMPTOM_SIGMAS = 10.0
#: ... and this corner [Hz].
SYMPTOM_HZ = 0.02
#: ... and this share of the structure's frequency (the phase lead ``f_c / f`` it stands for, in
#: rad): a model's own phase error on a fast, light system gave symptoms of 0.007-0.012 Hz at
#: 45-50 Hz (0.0002 rad), a 0.3-0.5 Hz coupling on a 2-8 Hz structure 0.009-0.1 rad.
SYMPTOM_PHASE = 0.003
#: ... or the drive judge rejected the refinement on a structure slower than this [Hz] (30x the
#: highest usual IEPE corner): a 0.5 Hz coupling on a 3.2 Hz, 1 kHz record left the drive misfit
#: at 0.12 with no phase-lead symptom (the model had taken the lead into its frequency).
SLOW_HZ = 30.0
#: Corners tried [Hz], as diagnose's ``sensor_highpass`` (:data:`eddi.diagnosis.chain.CORNERS_HZ`).
CORNERS_HZ = (0.1, 0.14, 0.2, 0.28, 0.41, 0.58, 0.83, 1.2, 1.7, 2.5, 3.5, 5.0)
#: The scan stops after this many corners in a row worse than the best.
PATIENCE = 2


@dataclass(frozen=True)
class CouplingCheck:
    """What the check found (``corner_hz`` None when the search did not run)."""

    symptom_hz: float
    symptom_se_hz: float
    nrmse_as_is: float
    corner_hz: float | None = None
    nrmse_through_coupling: float | None = None
    refits: int = 0
    evident: bool = False

    def as_dict(self) -> dict[str, object]:
        return {"symptom_hz": self.symptom_hz, "symptom_se_hz": self.symptom_se_hz, "nrmse_as_is": self.nrmse_as_is,
                "corner_hz": self.corner_hz, "nrmse_through_coupling": self.nrmse_through_coupling,
                "refits": self.refits, "evident": self.evident}


def check_coupling(meas: Measurement, res: PipelineResult, damping: str, stiffness: str,
                   route: str) -> CouplingCheck | None:
    """Look for an undeclared first-order accelerometer coupling on one identified record."""
    from eddi.fit_record import highest_frequency

    if not res.driven_by_force:
        return None
    f1 = highest_frequency(res.conditioned)
    est = highpass_estimate(res.model.eom, res.conditioned, res.validation, f1)
    if est is None:
        return None
    out = CouplingCheck(est.corner_hz, est.corner_se_hz, est.nrmse_as_is)
    ch = res.choices
    rejected = ch is not None and ch.refinement == "rejected" and ch.judged_on == "fit record"
    if not (est.corner_hz > max(SYMPTOM_SIGMAS * est.corner_se_hz, SYMPTOM_HZ, SYMPTOM_PHASE * f1)
            or (rejected and f1 < SLOW_HZ)):
        return out
    hi = min(CORNER_RANGE_HZ[1], MAX_CORNER_SHARE * f1)
    tried: dict[float, float] = {}
    worse = 0
    for fc in [c for c in CORNERS_HZ if c <= hi]:  # increasing; the misfit has one minimum over the corner
        m = _refit(meas, res, fc, damping, stiffness, route)
        tried[fc] = m
        best = min(tried.values())
        worse = 0 if m <= best else worse + 1
        if worse >= PATIENCE:
            break
    if not tried or not math.isfinite(min(tried.values())):
        return CouplingCheck(est.corner_hz, est.corner_se_hz, est.nrmse_as_is, refits=len(tried))
    fc = _parabola_min(tried)
    misfit = min(tried.values())
    if fc not in tried:  # the parabola's vertex: one more refit, kept only if it is no worse
        m = _refit(meas, res, fc, damping, stiffness, route)
        tried[fc] = m
        if m > misfit:
            fc = min(tried, key=tried.__getitem__)
        misfit = min(misfit, m)
    floor = est.noise_nrmse ** 2  # the noise's share of either squared misfit
    excess0, excess1 = est.nrmse_as_is ** 2 - floor, misfit * misfit - floor
    evident = bool(CORNER_RANGE_HZ[0] <= fc <= hi and excess0 > 0 and excess1 <= (1.0 - EXPLAINED) * excess0)
    return CouplingCheck(est.corner_hz, est.corner_se_hz, est.nrmse_as_is, fc, misfit, len(tried), evident)


def add_coupling_check(meas: Measurement, res: PipelineResult, damping: str, stiffness: str, route: str,
                       obj: dict[str, Any], which: str = "the record", search: bool = True) -> None:
    """Run :func:`check_coupling` and put what it found in an identification's JSON object (as
    ``station identify --json`` prints it): ``conditioning.sensor_highpass_check``, and when the
    coupling is evident ``conditioning.sensor_highpass_estimate_hz`` and a warning in ``warnings``
    (``which``: how it names the record checked; ``search=False``: the coupling is declared, only
    the impulse is checked). The hammer impulse is checked first
    (:mod:`station.impulse_check`); when it finds the response's sign or unit slipped, the
    force-driven misfit the coupling search reads is that slip's, and the search does not run."""
    from station.impulse_check import add_impulse_check

    imp = add_impulse_check(res, obj, which)
    if not search or (imp is not None and imp.biases_drive):  # a declared coupling: no search
        return
    chk = check_coupling(meas, res, damping, stiffness, route)
    if chk is None:
        return
    obj["conditioning"]["sensor_highpass_check"] = chk.as_dict()
    if chk.evident and chk.corner_hz is not None:
        obj["conditioning"]["sensor_highpass_estimate_hz"] = chk.corner_hz
        obj["warnings"].append(coupling_warning(chk, which))


def session_coupling_check(session: SessionResult, damping: str | Sequence[str], stiffness: str | Sequence[str],
                           route: str, obj: dict[str, Any], search: bool = True) -> None:
    """:func:`add_coupling_check` on the record a session's model was fitted to (the others share
    the sensor; no corner search when a record declares its coupling): ``station identify``, ``replay`` and
    ``report`` on the same records give the same warning. ``obj``: the fit's JSON object."""
    from station.records import Records, RecordInfo

    recs = session.measurements
    info = recs.info if isinstance(recs, Records) else tuple(RecordInfo.of(m) for m in recs)
    meas = recs[session.fit_index]
    which = "the record" if len(info) == 1 else f"the fit record ({meas.source})"
    add_coupling_check(meas, session.fit, _terms(damping), _terms(stiffness), route, obj, which,
                       search=search and not any(i.ac_coupling_s for i in info))


def _terms(terms: str | Sequence[str]) -> str:
    return terms if isinstance(terms, str) else ",".join(terms)


def coupling_warning(chk: CouplingCheck, which: str = "the record") -> str:
    """The warning of an evident coupling: the corner, the misfits and the option to pass."""
    fc = f"{chk.corner_hz:.2g}"
    return (f"{which} looks AC-coupled (first-order high-pass near {fc} Hz, IEPE?): the driven simulation "
            f"matches the measured acceleration with nrmse {chk.nrmse_as_is:.3g} as identified, "
            f"{chk.nrmse_through_coupling:.3g} with that coupling inverted and refitted; coefficients are "
            f"biased: pass --sensor-highpass {fc} (better: the sensor's data-sheet corner) or use a DC "
            f"accelerometer")


def _parabola_min(tried: dict[float, float]) -> float:
    """The corner [Hz] at the vertex of the parabola in ``log f_c`` through the best trial and its
    neighbours (the best trial itself at an end of the scan)."""
    xs = sorted(tried)
    i = min(range(len(xs)), key=lambda j: tried[xs[j]])
    if i == 0 or i == len(xs) - 1:
        return xs[i]
    (x0, x1, x2) = (math.log(xs[i - 1]), math.log(xs[i]), math.log(xs[i + 1]))
    y0, y1, y2 = tried[xs[i - 1]], tried[xs[i]], tried[xs[i + 1]]
    den = (x0 - x1) * (x0 - x2) * (x1 - x2)
    a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / den
    b = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / den
    if not a > 0:
        return xs[i]
    return float(math.exp(min(max(-b / (2 * a), x0), x2)))


def _refit(meas: Measurement, res: PipelineResult, corner_hz: float, damping: str, stiffness: str,
           route: str) -> float:
    """Acceleration nrmse, on the record as measured, of EDDI refitted with ``corner_hz`` inverted and
    simulated through it (``inf`` when the refit fails)."""
    from eddi.errors import EddiError
    from eddi.fit_record import Pipeline
    from station.session import condition_measurement, with_sensor_highpass

    pipe = Pipeline.create(damping, stiffness, route, refine=False)
    try:
        cond = condition_measurement(with_sensor_highpass(meas, corner_hz), pipe)
        r = pipe.fit(cond, res.model.eom.mass)
    except EddiError:
        return math.inf
    if not r.driven_by_force:
        return math.inf
    return misfit_through(r.model.eom, r.validation, res.conditioned, corner_hz)
