"""The conditioner: measured channels -> ``x, v, a`` and the free-response window.

See the package docstring (:mod:`eddi.conditioning`) for the method.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eddi.calculus import cumulative_trapezoid, integrate, spline_cumulative_integral
from eddi.conditioning.checks import check_channel, check_time
from eddi.conditioning.conditioned import ConditionedSignal
from eddi.conditioning.equilibrium import EquilibriumIntegral, _equilibrium_note, integrate_about_equilibrium
from eddi.conditioning.kinematics import (
    _drift_spline, _drift_spline_eval, _sg_derivative, _sg_derivative_modes, anchor_residual,
)
from eddi.conditioning.levels import _envelope_stop, _onset, _pulse_end, crossings, noise_rms, pre_motion
from eddi.errors import SignalError
from eddi.peaks import first_abs_above, peak_abs, peak_abs_at, varies


#: e.g. dry friction that sticks after a cycle, is data; fewer hold nothing to anchor the drift).
MIN_CROSSINGS = 3
#: Knot spacing of the drift spline, in (longest) periods of the response.
KNOT_PERIODS = 2.0
#: Half width of the sample groups around each acceleration zero crossing, in periods.
ANCHOR_HALF_WIDTH = 0.02
#: A record that starts in motion is treated as one restoring force (drift anchored where
#: ``a = 0``) when ``x`` there is within this fraction of its RMS of ``c_a a + c_v v`` (plus
#: a line in time); otherwise (several modes) it is integrated about the equilibrium only.
#: Measured: one mode 0.0004-0.05, two modes 0.5-0.9 (docs/conditioning.md).
ONE_FORCE_RESIDUAL = 0.3
#: Anchors per group (and per tail stretch) of the drift fit: on a record sampled far faster
#: than its period, each group of ``2 half_w + 1`` samples around a crossing is fitted as this
#: many block means of ``run`` samples (odd), the tail as means of ``run`` samples around every
#: ``run``-th of its points (session 15: the 45 s, 19.2 kHz record's 77k anchor samples -> 6k
#: rows; see :func:`_anchor_means`).
ANCHOR_BLOCKS = 17



def condition(
    t: np.ndarray,
    *,
    acc: np.ndarray | None = None,
    vel: np.ndarray | None = None,
    disp: np.ndarray | None = None,
    force: np.ndarray | None = None,
    pretrigger_samples: int | None = None,
    ac_coupling_s: float | None = None,
    noise_factor: float = 10.0,
    free_drift_slope: bool = False,
    coupling_offset: bool = True,
) -> ConditionedSignal:
    """Turn measured channels into ``x, v, a`` and find the free-response window.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Uniform, increasing time.
    acc, vel, disp : ndarray, shape (n,), optional
        Measured acceleration [m/s^2], velocity [m/s], displacement [m]; at least one. Given
        ``disp`` and ``vel`` are used as they are.
    force : ndarray, shape (n,), [N], optional
        Measured hammer force; used to find the impact and its end.
    pretrigger_samples : int, optional
        Samples of rest before the trigger (default: detected; 0 is detected too, see
        ``_onset_and_rest``).
    ac_coupling_s : float, optional
        Time constant [s] of a first-order AC coupling (IEPE) on ``acc`` (with no ``acc``: on
        ``vel``, a velocity sensor's); when given, the coupling is inverted before integration.
    coupling_offset : bool
        With ``ac_coupling_s``: remove the ramp a residual rest offset grows into through the
        inversion (default; ``_uncoupled``). False for trial corners (the ``sensor_highpass``
        search): at a corner off the truth the inverted channel is not "motion + offset ramp"
        and the removal misreads it (module notes of :mod:`eddi.diagnosis.highpass`).
    noise_factor : float
        The free response stops where the envelope of the measured response falls below
        ``noise_factor`` times its noise RMS.
    free_drift_slope : bool
        With a rest before the impact, the integration drift is 0 at the motion's start;
        False (default) also holds its slope at 0 there, True leaves the slope free: the
        integral over the impact pulse leaves a small velocity step that a clamped slope
        spreads over the first knot intervals (on a clean 50 Hz record at 41 samples a
        period the displacement error fell from 1.7e-3 to 3.9e-4 of its RMS, 4.4e-4 in the
        first tenth of the window instead of 1.8e-3).
    Returns
    -------
    ConditionedSignal

    Raises
    ------
    SignalError
        Bad time base, NaN, no response channel, no motion, too few zero crossings.
    """
    w = _inputs(t, acc, vel, disp, force)
    w.free_slope = bool(free_drift_slope)
    _onset_and_rest(w, pretrigger_samples)
    _remove_rest_offsets(w, ac_coupling_s, coupling_offset)
    _impact_end_from_force(w)
    _period(w)
    if w.disp is not None:
        _kinematics_from_disp(w)
    elif w.vel is not None or w.acc is not None:
        _kinematics_by_integration(w, noise_factor)
    return _free_window(w, noise_factor)



@dataclass
class _Work:
    """State passed between the steps of :func:`condition` (internal, mutable)."""

    t: np.ndarray
    rate: float
    acc: np.ndarray | None
    vel: np.ndarray | None
    disp: np.ndarray | None
    force: np.ndarray | None
    resp_name: str
    resp: np.ndarray
    notes: list[str]
    margin: int = 2
    start: int = 0
    rest: bool = False
    noise_stop: int = 0
    sigma: float = 0.0
    f_sigma: float = 0.0
    impact_end: int = -1
    period_s: float = 0.0
    x: np.ndarray | None = None
    v: np.ndarray | None = None
    a: np.ndarray | None = None
    method: str = ""
    free_slope: bool = False
    ac_coupling_s: float = 0.0

    @property
    def n(self) -> int:
        return self.t.size



def _inputs(t: np.ndarray, acc: np.ndarray | None, vel: np.ndarray | None, disp: np.ndarray | None,
            force: np.ndarray | None) -> _Work:
    """Check the channels; the exact uniform grid; the response channel that shows the motion."""
    rate = check_time(t)
    t = np.asarray(t, dtype=float)
    n = t.size
    # the exact uniform grid (times in files are often printed with few digits)
    grid = np.arange(n, dtype=float)  # t[0] + i step, in one buffer
    grid *= (t[-1] - t[0]) / (n - 1)
    grid += t[0]
    t = grid
    if acc is None and vel is None and disp is None:
        raise SignalError("need at least one of acc, vel, disp; got none")
    acc = None if acc is None else check_channel("acc", acc, n)
    vel = None if vel is None else check_channel("vel", vel, n)
    disp = None if disp is None else check_channel("disp", disp, n)
    force = None if force is None else check_channel("force", force, n)
    if acc is not None:
        name, resp = "acc", acc
    elif vel is not None:
        name, resp = "vel", vel
    else:
        name, resp = "disp", disp
    return _Work(t, rate, acc, vel, disp, force, name, resp, [],  # type: ignore[arg-type]
                 margin=max(2, int(round(2e-4 * rate))))



#: Quiet samples before a force pulse that make a rest when the pre-trigger is not stated.
MIN_REST_WITH_FORCE = 8


def _onset_and_rest(w: _Work, pretrigger_samples: int | None) -> None:
    """Onset of the motion, whether a rest was seen before it, and the response's noise RMS."""
    n, resp = w.n, w.resp
    if pretrigger_samples == 0:
        # "no row before the trigger" and "unknown" (a file format that stores 0 for it) both
        # leave the rest to be found in the data: a quiet head before the force's onset is a
        # rest either way, and a real 0 puts the onset near sample 0 (no rest found). Before,
        # 0 meant "no rest" outright: the same CSV captures imported to HDF5 (0 stored) got
        # another noise estimate and window than read as CSV (None), and another verdict
        pretrigger_samples = None
    head = max(8, min(pretrigger_samples or n // 20, n // 5))
    struck = w.force is not None and varies(w.force)  # a force channel that shows a blow
    if struck:
        onset, _ = _onset(w.force, head, float(np.median(w.force[:head])))
    else:
        onset, _ = _onset(resp, head, float(np.median(resp[:head])))
    if pretrigger_samples is not None:
        if not 0 <= pretrigger_samples < n:
            raise SignalError(f"pretrigger_samples must be in 0..{n - 1}, got {pretrigger_samples}")
        onset = min(onset, int(pretrigger_samples)) if pretrigger_samples > 0 else onset
    start = max(0, onset - w.margin)
    # unknown pre-trigger: a quiet head of 32 samples is a rest; with a force channel the onset
    # is the blow's, so 8 quiet samples are enough (a lab's export with 23 samples before the
    # blow, 256 Hz, went to the equilibrium integration, which a friction ring-down that sticks
    # after a few cycles cannot feed: refused "no spectral peak with 8 cycles")
    least = MIN_REST_WITH_FORCE if struck else 32
    rest = start >= least if pretrigger_samples is None else (pretrigger_samples > 0 and start > 0)
    if rest and pretrigger_samples is None:
        # rest means quiet: the head must be small compared with the response
        quiet = resp[:start]
        if np.std(quiet) > 0.02 * peak_abs_at(resp, float(np.mean(quiet)))[1]:
            rest = False
    # a stated pre-trigger that moves far more than the record's quiet end is no rest either: struck
    # before the last ring-down died (session 19: the README tour's 3 s hold-off); the record is
    # then treated as starting in motion, its noise read off the end
    moving = pre_motion(resp, max(0, start - w.margin)) if rest else None
    if moving:
        rest = False
        w.notes.append(f"WARNING: not at rest before the blow: the pre-trigger's RMS {moving[0]:.3g} is "
                       f"{moving[0] / moving[1]:.1f}x the record's quiet end ({moving[1]:.3g}): struck before "
                       "the last ring-down died (or a disturbance); the free response starts from a state the "
                       "blow did not set (treated as a record that starts in motion) - wait longer between "
                       "blows (the bench config's hold-off)")
    w.start = start if rest else 0
    w.rest = rest
    w.noise_stop = max(0, w.start - w.margin) if rest else 0
    w.sigma = noise_rms(resp, w.noise_stop)
    w.notes.append(f"motion starts at sample {w.start} ({'rest before' if rest else 'no rest seen'})")



def _remove_rest_offsets(w: _Work, ac_coupling_s: float | None, ramp: bool = True) -> None:
    """Offsets seen at rest removed from the force and the acceleration; AC coupling inverted."""
    n, ns = w.n, w.noise_stop
    if w.force is not None:
        f_off = float(np.mean(w.force[:ns])) if ns >= 8 else float(np.median(w.force[: max(8, n // 50)]))
        w.force = w.force - f_off
    if w.acc is not None and w.rest and ns >= 8:
        w.acc = w.acc - float(np.mean(w.acc[:ns]))
    if ac_coupling_s is not None and (w.acc is not None or w.vel is not None):
        if not ac_coupling_s > 0:
            raise SignalError(f"ac_coupling_s must be > 0, got {ac_coupling_s}")
        w.ac_coupling_s = float(ac_coupling_s)
        if w.acc is not None:
            w.acc = w.acc + cumulative_trapezoid(w.acc, w.t) / ac_coupling_s
            if ramp:
                w.acc = _uncoupled(w.acc, w.t, ac_coupling_s)
            w.notes.append(f"AC coupling ({ac_coupling_s:g} s) inverted")
        else:
            # a velocity sensor's AC coupling (session 14): the same first-order inversion; the
            # rest's offset first (integrated, it would become a ramp). Left in, the coupling's
            # phase lead biased a Duffing record's x^3 by 2.7-6.6 standard errors at a corner of
            # 3 % of the frequency (its interval did not know; tests/eddi/test_velocity_ac_coupling.py)
            if w.rest and ns >= 8:
                w.vel = w.vel - float(np.mean(w.vel[:ns]))
            w.vel = _uncoupled(w.vel + cumulative_trapezoid(w.vel, w.t) / ac_coupling_s, w.t, ac_coupling_s)
            w.notes.append(f"AC coupling ({ac_coupling_s:g} s) of vel inverted")


def _uncoupled(inverted: np.ndarray, t: np.ndarray, tau: float) -> np.ndarray:
    """The inverted channel without the ramp its residual offset grows into.

    An offset ``d`` left in the coupled channel (the rest's mean is an estimate: a few hundred
    noisy or quantized samples) comes out of the inversion as ``d g`` with
    ``g = 1 + (t - t0) / tau``: a ramp that grows by ``d T / tau`` over the record. At a corner
    of 25 % of the frequency a 2 mm/s^2 offset (one quantization step) became 0.26 m/s^2 after
    2.4 s, the acceleration's zero crossings left the decay's tail, and the anchored drift ran
    to 15 mm at the record's end (true amplitude 0.3 mm; blind unseen11 D1: an unstable model,
    exit 1). ``d`` is read against a weight ``h = s^2 (1 - s)^2`` (``s`` the record's time
    from 0 to 1), zero with its slope at both ends: by parts, the motion's share
    ``int a h dt = int x h'' dt`` carries no end state (``v_end``, ``x_end``) and no constant
    or linear part of ``x``, only the slow curvature of ``x`` against ``h''`` (nearly 0 over
    many cycles). A plain projection on ``g`` assumed the record ends at rest; on records
    still ringing at the end (the held-out calibration ladder: 35 % of the amplitude left) it
    took the end state for an offset and biased the acceleration.
    """
    g = (t - t[0]) / tau
    g += 1.0
    span = float(t[-1] - t[0])
    if not span > 0:
        return inverted
    s = (t - t[0]) / span
    h = s * s * (1.0 - s) ** 2
    d = float(np.dot(inverted, h) / np.dot(g, h))
    return inverted - d * g


def _impact_end_from_force(w: _Work) -> None:
    """End of the impact where the force returns within its noise of zero (force measured)."""
    f = w.force
    if f is None or not varies(f):
        return  # decided after integration (first extremum of x)
    w.f_sigma = noise_rms(f, w.noise_stop)
    f_peak_i = _first_blow_peak(f, w.rate)
    thr = max(5.0 * w.f_sigma, 0.01 * abs(float(f[f_peak_i])))
    look = f[f_peak_i: min(w.n, f_peak_i + int(0.1 * w.rate))]
    above = np.nonzero(np.abs(look) > thr)[0]
    if above.size == 0:
        # the largest force is within 5 noise sd: no blow to end (a light structure struck so
        # gently that the hammer's noise hides it raised an IndexError here, session 15)
        raise SignalError(f"the force channel shows no blow above its noise: largest force "
                          f"{abs(float(f[f_peak_i])):.3g} N, noise {w.f_sigma:.3g} N rms at rest (a blow needs "
                          f"> {thr:.3g} N); strike harder or leave the force channel out")
    w.impact_end = min(w.n - 1, f_peak_i + int(above[-1]) + 1 + w.margin)
    w.notes.append(f"impact ends at sample {w.impact_end} (force within {thr:.3g} N of zero)")
    _cut_at_second_blow(w, abs(float(f[f_peak_i])))


#: A later force pulse above this fraction of the first blow's peak (and 10 noise sd) is a
#: second blow; the record is used up to it (the free response it ends is the first blow's).
SECOND_BLOW_FRACTION = 0.05


def _first_blow_peak(f: np.ndarray, rate: float) -> int:
    """The first blow's peak: the largest ``|f|`` within 0.1 s of the first sample at half the
    record's largest force (a second, larger blow later in the record is not the impact)."""
    first = max(0, first_abs_above(f, 0.5 * peak_abs(f), strict=False))  # none: 0, as argmax
    stop = min(f.size, first + max(1, int(0.1 * rate)))
    return first + peak_abs_at(f[first:stop])[0]


def _cut_at_second_blow(w: _Work, peak: float) -> None:
    """Drop the record from a second blow on (a hammer struck again while recording).

    A second blow is a force above ``SECOND_BLOW_FRACTION`` of the first peak and 10 noise sd
    after at least 0.05 s of quiet force since the impact ended (a continuous excitation has no
    such quiet and is left whole). The record's channels end ``margin`` samples before the
    second blow's onset, with a warning: the free response after the first blow is what EDDI
    reads, and the second blow's response would read as a mechanism.
    """
    f = w.force
    assert f is not None
    thr = max(10.0 * w.f_sigma, SECOND_BLOW_FRACTION * peak)
    after = first_abs_above(f[w.impact_end:], thr)
    if after < 0 or after < int(0.05 * w.rate):
        return
    onset = w.impact_end + after
    below = np.flatnonzero(np.abs(f[w.impact_end:onset]) > max(5.0 * w.f_sigma, 0.01 * peak))
    onset = w.impact_end + int(below[-1]) + 1 if below.size else onset  # the pulse's foot
    cut = max(w.impact_end + 2, onset - w.margin)
    t_blow, f_blow = float(w.t[onset]), peak_abs(f[onset:onset + int(0.1 * w.rate) + 1])
    for name in ("t", "acc", "vel", "disp", "force", "resp"):
        arr = getattr(w, name)
        if arr is not None:
            setattr(w, name, arr[:cut])
    w.notes.append(f"WARNING: a second blow at {t_blow:.4g} s ({f_blow:.3g} N, the first {peak:.3g} N): "
                   f"the record is used up to {float(w.t[-1]):.4g} s (strike once per capture, or "
                   "`on_double_hit = \"reject\"` in the bench config)")



def _period(w: _Work) -> None:
    """Longest period of the response, from its zero crossings."""
    resp = w.resp
    hyst = max(3.0 * w.sigma, 1e-9 * peak_abs(resp))
    base = resp if w.resp_name == "acc" else resp - np.median(resp[w.start:])
    crs = crossings(base, hyst, start=max(w.start, w.impact_end))
    if crs.size < MIN_CROSSINGS:
        raise SignalError(
            f"too few zero crossings of {w.resp_name} in the response: {crs.size}, expected >= {MIN_CROSSINGS}"
        )
    half = np.diff(crs)
    w.period_s = 2.0 * float(np.percentile(half[: max(4, half.size // 2)], 90)) / w.rate
    w.notes.append(f"longest period {w.period_s:.4g} s; drift knots every {KNOT_PERIODS * w.period_s:.4g} s")



def _kinematics_from_disp(w: _Work) -> None:
    """A measured displacement: ``v`` and ``a`` as measured or by Savitzky-Golay derivatives."""
    split = w.impact_end if w.impact_end >= 0 else w.start
    x = w.disp
    assert x is not None
    if w.vel is not None:
        w.x, w.v = x, w.vel
        w.a = w.acc if w.acc is not None else _sg_derivative(w.vel, w.rate, w.period_s, 1, split)
        w.method = "disp and vel as measured" + (", acc as measured" if w.acc is not None
                                                 else ", acc by Savitzky-Golay derivative of vel")
        return
    w.x = x
    w.v = _sg_derivative(x, w.rate, w.period_s, 1, split)
    w.a = w.acc if w.acc is not None else _sg_derivative(x, w.rate, w.period_s, 2, split)
    w.method = "disp as measured; vel and acc by Savitzky-Golay derivatives"



def _anchored_drift(w: _Work, x_int: np.ndarray, v_int: np.ndarray, a_for_anchor: np.ndarray,
                    noise_factor: float, subtract: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The drift ``d, d'`` of an integrated ``x``, anchored where ``a = 0`` and in the noise tail
    (``subtract``: ``x_int - d, v_int - d'``, in place)."""
    first = max(w.start, w.impact_end)
    a_sigma = noise_rms(a_for_anchor, w.noise_stop)
    h = max(3.0 * a_sigma, 1e-9 * peak_abs(a_for_anchor))
    anc = crossings(a_for_anchor, h, start=first)
    if w.impact_end < 0 and anc.size:
        anc = anc[1:]  # no force: the first crossing is at the end of the impact
    stop = _envelope_stop(a_for_anchor, first, a_sigma, noise_factor, w.period_s, w.rate)
    anc = anc[anc < stop]
    if anc.size < MIN_CROSSINGS:
        raise SignalError(
            f"too few zero crossings of the acceleration above the noise: {anc.size}, expected >= {MIN_CROSSINGS}"
        )
    # samples within +-2 % of a period of each crossing (|x| below ~12 % of its amplitude)
    half_w = max(1, int(round(ANCHOR_HALF_WIDTH * w.period_s * w.rate)))
    step = max(1, int(round(w.period_s * w.rate / (2 * half_w + 1) / 2.0)))
    run = _anchor_run(half_w)
    if run > 1:
        ta, xa, local = _anchor_means(w, x_int, v_int, a_for_anchor, anc, half_w, step, run, first, stop)
    else:
        centre = np.rint(anc).astype(int)
        near = (centre[:, None] + np.arange(-half_w, half_w + 1)[None, :]).ravel()
        near = near[(near > max(first, w.start)) & (near < stop)]
        tail = np.arange(stop, w.n, step)
        mark = np.zeros(w.n, dtype=bool)  # sorted and unique, as np.unique gives, in one O(n) pass
        mark[near] = True
        mark[tail] = True
        pts = np.flatnonzero(mark)
        ta, xa, local = w.t[pts], x_int[pts], -np.column_stack((a_for_anchor[pts], v_int[pts]))
    spl = _drift_spline(w.t, xa, ta, KNOT_PERIODS * w.period_s, w.start, clamped=w.rest, local=local,
                        free_slope=w.free_slope)
    return _drift_spline_eval(spl, w.t, w.start, minus=(x_int, v_int) if subtract else None)



def _anchor_run(half_w: int) -> int:
    """Samples per anchor block mean (odd; 1: every sample is its own anchor, as before session 15)."""
    run = (2 * half_w + 1) // ANCHOR_BLOCKS
    return max(1, run if run % 2 else run - 1)


def _anchor_means(w: _Work, x_int: np.ndarray, v_int: np.ndarray, acc: np.ndarray, anc: np.ndarray,
                  half_w: int, step: int, run: int, first: int, stop: int,
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The drift fit's anchors as block means of ``run`` samples: times, ``x_int``, ``-(a, v)``.

    The samples of the per-sample fit (``+-half_w`` around each crossing, every ``step``-th of
    the tail), in runs of ``run`` consecutive samples, each run replaced by its mean (time: its
    centre sample's). Every row of the fit is linear in the samples (a cubic spline of knots two
    periods apart and ``x ~ -c_a a - c_v v``), and a run spans ``run / rate`` s (0.7 ms on the
    45 s record: 4 % of ``half_w``, ~0.015 rad of its cycle), so a run's mean stands for its
    samples to second order in that span (the curvature of ``x_int`` within it, ~1e-5 of the
    anchors' spread) and carries the same white-noise average (the fit sees as many samples, in
    ``1 / run`` of the rows). The tail (``x ~ 0``): runs centred every ``run step`` samples, as
    many samples as the per-sample fit's every ``step``-th.
    """
    g = half_w // run  # blocks each side of a crossing
    hr = (run - 1) // 2
    centres = np.rint(anc).astype(int)[:, None] + (run * np.arange(-g, g + 1))[None, :]
    centres = centres.ravel()
    centres = centres[(centres - hr > max(first, w.start)) & (centres + hr < stop)]
    tail = np.arange(stop + hr, w.n - hr, run * step)
    centres = np.unique(np.concatenate((centres, tail)))  # sorted; a shared centre once
    # each run's mean as numpy's mean of the gathered (centres, run) table, without the table
    # (eddi.refine_grid.window_means: bit for bit; local: refine_grid imports the model)
    from eddi.refine_grid import window_means

    lo = centres - hr
    xa = window_means(x_int, lo, run)
    local = -np.column_stack((window_means(acc, lo, run), window_means(v_int, lo, run)))
    return w.t[centres], xa, local


def _kinematics_by_integration(w: _Work, noise_factor: float) -> None:
    """Velocity and/or acceleration: integrate (from rest, or about the equilibrium), remove the drift."""
    eq: EquilibriumIntegral | None = None
    one_force = True
    if not w.rest:
        # recorded already in motion: integration constants unknown; first integrate about the
        # equilibrium (valid for any number of modes), then check whether the record behaves as
        # one restoring force (x ~ 0 where a = 0)
        eq = integrate_about_equilibrium(w.t, vel=w.vel) if w.vel is not None else \
            integrate_about_equilibrium(w.t, acc=w.acc)
        w.a = w.acc if w.acc is not None else _sg_derivative_modes(w.vel, w.rate, w.period_s)  # type: ignore[arg-type]
        v_eq = w.vel if w.vel is not None else eq.v
        resid = anchor_residual(eq.x, v_eq, w.a)
        one_force = resid < ONE_FORCE_RESIDUAL
        w.notes.append(_equilibrium_note(eq) + f"; x at the acc zero crossings off a single "
                       f"restoring force by {resid:.3g} of its RMS")
    if not one_force:
        assert eq is not None
        w.x, w.v = eq.x, (w.vel if w.vel is not None else eq.v)
        w.method = ("vel as measured" if w.vel is not None else "acc") + \
            "; integrated about the equilibrium (zero mean over every cycle of every mode)" + \
            ("; acc as measured" if w.acc is not None else "; acc by Savitzky-Golay derivative of vel")
    elif w.vel is not None:
        _integrate_velocity(w, noise_factor)
    else:
        _integrate_acceleration(w, eq, noise_factor)



def _integrate_velocity(w: _Work, noise_factor: float) -> None:
    """A measured velocity (one restoring force): ``x`` by integration, drift anchored."""
    vel, start, dt = w.vel, w.start, 1.0 / w.rate
    assert vel is not None
    split = w.impact_end if w.impact_end >= 0 else start
    if w.rest:
        w.a = w.acc if w.acc is not None else _sg_derivative(vel, w.rate, w.period_s, 1, split)
    v0 = vel - (float(np.mean(vel[:w.noise_stop])) if w.rest and w.noise_stop >= 8 else 0.0)
    x_int = np.zeros(w.n)
    x_int[start:] = (integrate(v0[start:], dt, smooth_from=_pulse_end(v0, start, w.impact_end) - start)
                     if w.rest else spline_cumulative_integral(w.t, v0))
    assert w.a is not None
    d, dd = _anchored_drift(w, x_int, v0, w.a, noise_factor)
    # from rest, the drift of x_int is the integral of the velocity's baseline (a slow drift
    # after the pre-trigger's offset): remove its rate from v too, else it inflates every
    # dissipation integral (int v^2 dt) where the decay is small against it and phase one's
    # damping comes out low (3x on a 1 mm/s per s drift, tests/eddi/test_velocity_baseline.py).
    # Not from the start: the drift there also carries the unknown x0 and start slope, and
    # the measured v is kept (d' made a diagnosed ring-down "unexplained").
    w.x, w.v = x_int - d, (v0 - dd if w.rest else vel)
    w.method = (("vel less its offset and drift; disp by integration from rest" if w.rest
                 else "vel as measured; disp by integration from the start")
                + " with drift anchored at acc zero crossings")


def _integrate_acceleration(w: _Work, eq: EquilibriumIntegral | None, noise_factor: float) -> None:
    """A measured acceleration alone: ``v, x`` by integration, drift anchored."""
    a, start, t = w.acc, w.start, w.t
    assert a is not None
    w.a = a
    if eq is None:
        # integrate() writes every sample of its out: only the samples before the start are set
        # here (np.zeros would clear the whole record first: a pass over 7 MB each)
        v_int = np.empty(w.n)
        x_int = np.empty(w.n)
        v_int[:start] = 0.0
        x_int[:start] = 0.0
        # 4th-order integration (the trapezoid loses (w h)^2 / 12 a pass: eddi.calculus),
        # trapezoid over the impact (a pulse is not smooth)
        smooth = _pulse_end(a, start, w.impact_end) - start
        integrate(a[start:], 1.0 / w.rate, smooth_from=smooth, out=v_int[start:])
        integrate(v_int[start:], 1.0 / w.rate, smooth_from=smooth, out=x_int[start:])
    else:
        # unknown v0 and x0: a line in x, removed by least squares before the anchored fit (it
        # dwarfs x; the cycle-mean v is biased where a damped response chirps)
        v_int = spline_cumulative_integral(t, a)
        x_int = spline_cumulative_integral(t, v_int)
        line = np.polynomial.polynomial.polyfit(t - t[0], x_int, 1)
        x_int = x_int - line[0] - line[1] * (t - t[0])
        v_int = v_int - line[1]
    w.x, w.v = _anchored_drift(w, x_int, v_int, a, noise_factor, subtract=True)  # in place: x_int, v_int no longer needed
    w.method = ("acc integrated from rest" if w.rest else "acc integrated about the equilibrium") + \
        "; drift anchored at acc zero crossings (x = 0) and the noise tail"



def _free_window(w: _Work, noise_factor: float) -> ConditionedSignal:
    """The free-response window: after the impact, until the response sinks into the noise."""
    x, v, a, n, start = w.x, w.v, w.a, w.n, w.start
    assert x is not None and v is not None and a is not None
    impact_end = w.impact_end
    if impact_end < 0:
        # without force: from the first extremum of x after the motion starts (the first
        # crossing of v after v has left its rest: at the onset v is still ~0)
        moving = np.nonzero(np.abs(v[start:]) >= 0.3 * peak_abs(v[start:]))[0]
        first_move = start + (int(moving[0]) if moving.size else 0)
        vx = crossings(v, max(3.0 * noise_rms(v, w.noise_stop), 1e-12), start=first_move)
        impact_end = int(math.ceil(vx[0])) if (w.rest and vx.size) else start
    free_start = min(impact_end, n - 2)
    free_stop = _envelope_stop(w.resp if w.resp_name != "disp" else x, free_start, w.sigma, noise_factor,
                               w.period_s, w.rate)
    free_stop = max(free_stop, min(n, free_start + 2))
    w.notes.append(f"noise RMS of {w.resp_name}: {w.sigma:.3g}; free response [{free_start}, {free_stop})")
    return ConditionedSignal(
        t=w.t, x=np.ascontiguousarray(x), v=np.ascontiguousarray(v), a=np.ascontiguousarray(a),
        force=w.force, rate_hz=w.rate, free_start=int(free_start), free_stop=int(free_stop),
        method=w.method, notes=tuple(w.notes), impact_start=int(start), impact_end=int(impact_end),
        noise_rms=w.sigma, force_noise_rms=w.f_sigma, acc_measured=w.acc is not None,
        response=w.resp_name, ac_coupling_s=w.ac_coupling_s,
    )

