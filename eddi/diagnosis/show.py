"""Show: what a model's held-out simulation gets wrong, in the views a test engineer reads.

The figure of merit (:func:`nrmse`, :func:`nmte`), the held-out simulation of a part
(:func:`simulate_part_xv`), and the views: energy lost per cycle versus amplitude, the
backbone (frequency and damping ratio versus amplitude), the residual force, the spectrum.
:mod:`eddi.diagnosis.symptoms` turns them into numbers and words.
"""

from __future__ import annotations

import numpy as np

from eddi.diagnosis.records import Part, Record
from eddi.diagnosis.settings import NRMSE_CAP
from eddi.energy import zero_crossings
from eddi.initial_state import fitted_state as _fitted_state
from eddi.model import EquationOfMotion
from eddi.multimode import trajectory_errors
from eddi.simulate import DENSE_H_OMEGA, max_angular_frequency, simulate, simulate_dense


def simulate_part(eom: EquationOfMotion, rec: Record, part: Part) -> np.ndarray:
    return simulate_part_xv(eom, rec, part)[0]


def simulate_part_xv(eom: EquationOfMotion, rec: Record, part: Part) -> tuple[np.ndarray, np.ndarray]:
    """Simulated coordinate and rate over the part, shape (k,) each.

    A part ``from_rest`` is simulated as the pipeline validates a record
    (:func:`eddi.fit_record.validate_conditioned`): from rest at the impact's start, driven by
    the force during the impact only, fused with ``m a + R(x, v)`` when the acceleration was
    measured (:func:`drive_force`), and returned over ``[part.start, part.stop)``. A record
    without the impact's indices is driven by its whole force from sample 0. A record whose
    impact window starts at its first sample has no rest before the blow (the pipeline then
    validates from the measured state, :func:`eddi.driven_validation.validate_conditioned`):
    its part is a free response too, since its conditioned state there is the drift removal's
    extrapolation, not rest (a 246 kg, 4.3 Hz null at 512 Hz with 26 samples before the blow
    and a bounce 62 ms later read x = -1.7 mm, v = 25 mm/s there for a 3.6 mm ring-down: the
    true model's driven part was 0.74 off, its free response 0.018). Other parts are free
    responses from the measured state at ``part.start`` (fitted over their first cycles), driven
    only by what is left of the impact in them (:func:`drive_force`: never by the force sensor's
    noise after the blow).
    """
    s, e = part.start, part.stop
    no_rest = rec.impact_end > rec.impact_start == 0
    if part.from_rest and rec.force is not None and not no_rest:
        s0 = rec.impact_start if rec.impact_end > rec.impact_start else 0
        s0 = min(s0, s)
        t = rec.t[s0:e] - rec.t[s0]
        sim = _simulated(eom, t, drive_force(eom, rec)[s0:e], float(rec.x[s0]), float(rec.v[s0]),
                         float(np.max(np.abs(rec.x[s0:e]))) or None, float(np.max(np.abs(rec.v[s0:e]))) or None)
        return sim.x[s - s0:], sim.v[s - s0:]
    t = rec.t[s:e] - rec.t[s]
    xs = float(np.max(np.abs(rec.x[s:e]))) or None
    vs = float(np.max(np.abs(rec.v[s:e]))) or None
    # the force sensor's noise after the blow drives nothing (as the pipeline validates): a 30 dB
    # force channel's noise, integrated by a lightly damped structure over a free response, put the
    # true model of a clean linear null 1.2 off on the part of its largest blow (session 11)
    f = drive_force(eom, rec)[s:e] if rec.force is not None else None
    x0, v0 = fitted_state(eom, rec, s, e, xs, vs)
    sim = _simulated(eom, t, f, x0, v0, xs, vs)
    return sim.x, sim.v


def _simulated(eom: EquationOfMotion, t: np.ndarray, force: np.ndarray | None, x0: float, v0: float,
               x_scale: float | None, v_scale: float | None):
    """The part's simulation: :func:`eddi.simulate.simulate_dense` where the record samples the
    model's fastest motion finely (every sample while the force acts, then RK4 steps of
    ``omega h <= 0.05`` on a grid of ``omega q dt <= 0.2`` and cubic Hermite back onto the
    samples), else :func:`eddi.simulate.simulate` on every sample.

    The two differ by < 1e-5 of the peak ``x`` and ``v`` (``omega``: the model's largest local
    angular frequency over the part's amplitudes, its stiffening at the peak included; masses
    0.005-500 kg, 2-40 kHz, 5-60 Hz, hardening / softening / linear, 1 ms blows: at most
    3.9e-6 in ``x`` and 8.7e-6 in ``v``, the same order as :func:`eddi.simulate.simulate`'s own
    step-doubling error at 2 kHz), some 100 times below the sensor noise of a 45 dB record,
    at 0.15-0.5 of the cost on records of 10-40 kHz (docs/performance.md, session 9). Models
    with effects or ``sign`` terms, and records where the grid would be under 4 samples (the
    looser bound :func:`eddi.simulate.max_angular_frequency` decides, so the check costs
    nothing), keep every sample.
    """
    dt = float(t[1] - t[0]) if t.size > 1 else 0.0
    if x_scale and v_scale and dt > 0 and max_angular_frequency(eom, x_scale, v_scale) * dt * 4 <= DENSE_H_OMEGA:
        return simulate_dense(eom, t, force=force, x0=x0, v0=v0, x_scale=x_scale, v_scale=v_scale)
    return simulate(eom, t, force=force, x0=x0, v0=v0, x_scale=x_scale, v_scale=v_scale)


def fitted_state(eom: EquationOfMotion, rec: Record, s: int, e: int, x_scale: float | None,
                 v_scale: float | None) -> tuple[float, float]:
    """Initial state ``(x0 [m], v0 [m/s])`` of a free response from sample ``s`` of ``rec``
    (:func:`eddi.initial_state.fitted_state`: fitted over its first cycles, so the noise of one
    sample no longer sets the start)."""
    f = drive_force(eom, rec) if rec.force is not None else None  # not the sensor's noise (above)
    return _fitted_state(eom, rec.t, rec.x, rec.v, f, s, e, x_scale, v_scale)


def drive_force(eom: EquationOfMotion, rec: Record) -> np.ndarray:
    """The force a from-rest simulation of ``rec`` is driven with [N] (see
    :func:`simulate_part_xv`; :func:`eddi.fit_record.fused_impact_force` on a record)."""
    assert rec.force is not None
    i0, i1 = rec.impact_start, rec.impact_end
    if not i1 > i0:
        return rec.force
    out = np.zeros_like(rec.force)
    f = rec.force[i0:i1]
    if rec.acc_measured:
        f_acc = eom.mass * rec.a[i0:i1] + eom.restoring_force(rec.x[i0:i1], rec.v[i0:i1])
        var_f, var_a = rec.force_noise_rms ** 2, (eom.mass * rec.noise_rms) ** 2
        w = var_a / (var_f + var_a) if var_f + var_a > 0 else 0.5
        f = w * f + (1.0 - w) * f_acc
    out[i0:i1] = f
    return out


def nmte(v_sim: np.ndarray, v_meas: np.ndarray) -> float:
    """Velocity NMTE ``mean |v_sim - v| / max |v|`` (:func:`eddi.multimode.trajectory_errors`),
    capped at :data:`NRMSE_CAP` (a diverged simulation counts as the cap)."""
    if v_sim.shape != v_meas.shape or not np.all(np.isfinite(v_sim)):
        return NRMSE_CAP
    return float(min(NRMSE_CAP, trajectory_errors(v_sim, v_meas).nmte))


def nrmse(x_sim: np.ndarray, x_meas: np.ndarray) -> float:
    """``||x_sim - x_meas||_2 / ||x_meas||_2``, capped at :data:`NRMSE_CAP` (inf/NaN -> cap).

    The same figure of merit as :func:`eddi.validate.validate`.
    """
    den = float(np.linalg.norm(x_meas)) or 1.0
    if not np.all(np.isfinite(x_sim)):
        return NRMSE_CAP
    return float(min(NRMSE_CAP, np.linalg.norm(x_sim - x_meas) / den))


def energy_per_cycle(t: np.ndarray, x: np.ndarray, v: np.ndarray, mass: float,
                     hysteresis: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Energy lost per cycle versus amplitude, from the kinetic energy at zero crossings.

    At a zero crossing the potential energy is zero, so ``E = m v^2 / 2`` there; the energy
    lost over one cycle is the drop between crossings ``i`` and ``i + 2``.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    x, v : ndarray, shape (n,)
    mass : float, [kg]
    hysteresis : float, [m]
        Dead band of the zero crossings (:func:`eddi.energy.zero_crossings`; 0: every sign change).

    Returns
    -------
    amplitude : ndarray, shape (k,), [m]
        Largest ``|x|`` over each cycle.
    energy_lost : ndarray, shape (k,), [J]
    """
    amp, _level, lost = cycle_energies(t, x, v, mass, hysteresis)
    return amp, lost


def cycle_energies(t: np.ndarray, x: np.ndarray, v: np.ndarray, mass: float,
                   hysteresis: float = 0.0, noise: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`energy_per_cycle` with each cycle's level: ``amplitude`` [m] (largest ``|x|``),
    ``level`` [m] (``sqrt(2 (mean x^2 - noise^2))`` over the cycle, ``noise`` the coordinate's
    noise sd [m]; at most halved by it) and ``energy_lost`` [J].

    The level places a cycle on the ring-down without reading its peak: the largest ``|x|`` of a
    noisy measured cycle is the peak plus the largest noise near it, a bias that grows as the motion
    nears the noise (to 10 % of the amplitude at a noise a tenth of it), and the model's loss read
    at that amplitude was 8-19 % too large at small amplitude on a strongly softening null (session
    20, s20strong). The mean square carries the noise as ``noise^2`` only, which is subtracted.
    Model and measurement are read the same way, so a spring that changes the ratio of peak to
    RMS (a strong cubic) changes both alike."""
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    v = np.asarray(v, float)
    ok = np.isfinite(x) & np.isfinite(v)
    if not np.all(ok):
        n = int(np.argmin(ok))
        t, x, v = t[:n], x[:n], v[:n]
    if t.size < 4:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    g = zero_crossings(t, x, v, hysteresis)
    if g.size < 3:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    vg = np.interp(g, t, v)
    e = 0.5 * mass * vg**2
    idx = np.searchsorted(t, g)
    amp = np.array([np.max(np.abs(x[idx[i]:max(idx[i + 2], idx[i] + 1)])) for i in range(g.size - 2)])
    ms = np.array([np.mean(x[idx[i]:max(idx[i + 2], idx[i] + 1)] ** 2) for i in range(g.size - 2)])
    return amp, np.sqrt(2.0 * np.maximum(ms - noise ** 2, 0.25 * ms)), e[:-2] - e[2:]


def backbone(t: np.ndarray, x: np.ndarray, v: np.ndarray, mass: float,
             hysteresis: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Instantaneous frequency and damping ratio versus amplitude, cycle by cycle (zero crossings
    with the dead band ``hysteresis``, as :func:`energy_per_cycle`).

    Returns
    -------
    amplitude : ndarray, shape (k,), [m]
    frequency_hz : ndarray, shape (k,), [Hz]
        ``1 / (gamma_i+2 - gamma_i)``.
    damping_ratio : ndarray, shape (k,)
        ``dE / (4 pi E)`` with ``E`` the energy at the start of the cycle.
    """
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    v = np.asarray(v, float)
    ok = np.isfinite(x) & np.isfinite(v)
    if not np.all(ok):
        n = int(np.argmin(ok))
        t, x, v = t[:n], x[:n], v[:n]
    if t.size < 4:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    g = zero_crossings(t, x, v, hysteresis)
    if g.size < 3:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    vg = np.interp(g, t, v)
    e = 0.5 * mass * vg**2
    amp, de = energy_per_cycle(t, x, v, mass, hysteresis)
    freq = 1.0 / (g[2:] - g[:-2])
    with np.errstate(divide="ignore", invalid="ignore"):
        zeta = np.where(e[:-2] > 0, de / (4 * np.pi * e[:-2]), np.nan)
    return amp, freq, zeta


def residual_force(eom: EquationOfMotion, x: np.ndarray, v: np.ndarray, a: np.ndarray,
                   force: np.ndarray | None = None) -> np.ndarray:
    """Force the model misses: ``F - m a - (internal force of the model)``.

    Parameters
    ----------
    eom : EquationOfMotion
    x, v, a : ndarray, shape (n,)
    force : ndarray, shape (n,), [N], optional

    Returns
    -------
    ndarray, shape (n,), [N]
    """
    f = np.zeros_like(np.asarray(x, float)) if force is None else np.asarray(force, float)
    return f - eom.mass * np.asarray(a, float) - eom.restoring_force(x, v)


def spectrum(x: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude spectrum (Hann window).

    Returns
    -------
    freqs_hz : ndarray, shape (n // 2 + 1,)
    amplitude : ndarray, shape (n // 2 + 1,)
        Same unit as ``x``.
    """
    x = np.nan_to_num(np.asarray(x, float))
    w = np.hanning(x.size)
    amp = np.abs(np.fft.rfft(x * w)) * 2.0 / max(np.sum(w), 1e-300)
    return np.fft.rfftfreq(x.size, 1.0 / rate_hz), amp
