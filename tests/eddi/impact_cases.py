"""Simulated hammer-impact records for the acceleration-only chain.

A half-sine hammer pulse drives an :class:`~eddi.model.EquationOfMotion` from rest (after a
pre-trigger of rest); a force sensor and an accelerometer see the force and the model's
acceleration with white noise at a given SNR and 24-bit quantisation. The exact ``x, v``
come with the record so that conditioning can be scored against them.

SNR convention: the noise RMS is ``signal_rms * 10**(-snr_db / 20)``, where ``signal_rms``
is the RMS of the channel over its *ring-down* (accelerometer: from the end of the pulse until the
envelope ``max |a|`` over the rest of the record falls below 10 % of its peak; force: over
the pulse). This is harsher than the RMS over a whole long record.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from eddi import EquationOfMotion, simulate


@dataclass(frozen=True)
class ImpactRecord:
    """One simulated impact test (all arrays shape (n,), SI units)."""

    t: np.ndarray
    force: np.ndarray
    acc: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    pretrigger_samples: int
    eom: EquationOfMotion


#: Duffing-like systems of several kinds (mass [kg], damping, stiffness, hammer peak [N]).
#: Peaks are chosen so that k3 x^2 / k1 reaches 0.3 - 1.5 at the first peak.
SYSTEMS: dict[str, dict] = {
    # the paper's Duffing oscillator (Sec. 4.1, Eq. 23: k1 = 390 N/m, k3 = 1.3e7 N/m^3) with
    # more damping than the paper's b1 = 0.196 Ns/m so that it rings down within 6 s
    "paper_do": dict(mass=0.815, damping={"v": 1.0}, stiffness={"x": 390.0, "x^3": 1.3e7},
                     peak_n=200.0),
    # a stiffer, lighter, lightly damped oscillator (~20 Hz)
    "light_stiff": dict(mass=0.05, damping={"v": 0.15}, stiffness={"x": 800.0, "x^3": 2.0e8},
                        peak_n=35.0),
    # a heavy, soft one with a quadratic term (~5 Hz)
    "heavy_asym": dict(mass=2.0, damping={"v": 3.0},
                       stiffness={"x": 2000.0, "x^2": 2.0e5, "x^3": 4.0e7}, peak_n=700.0),
    # hardening with nonlinear damping (~12 Hz)
    "nl_damping": dict(mass=0.3, damping={"v": 0.45, "x^2*v": 1.0e4},
                       stiffness={"x": 1700.0, "x^3": 1.5e8}, peak_n=180.0),
}


def half_sine_pulse(t: np.ndarray, start_s: float, width_s: float, peak_n: float) -> np.ndarray:
    """Half-sine force pulse ``peak * sin(pi (t - start) / width)`` on ``[start, start + width]``."""
    tau = (t - start_s) / width_s
    return np.where((tau >= 0) & (tau <= 1), peak_n * np.sin(np.pi * np.clip(tau, 0, 1)), 0.0)


def _quantise(y: np.ndarray, full_scale: float, bits: int) -> np.ndarray:
    step = 2.0 * full_scale / 2**bits
    return np.clip(np.round(y / step) * step, -full_scale, full_scale - step)


def ringdown_rms(a: np.ndarray, start: int) -> float:
    """RMS of ``a[start:]`` until its remaining envelope falls below 10 % of its peak."""
    tail_env = np.maximum.accumulate(np.abs(a[start:])[::-1])[::-1]
    below = np.nonzero(tail_env < 0.1 * tail_env[0])[0]
    stop = start + (int(below[0]) if below.size else a.size - start)
    return float(np.sqrt(np.mean(a[start:stop] ** 2)))


def impact_record(
    system: str | dict,
    *,
    rate_hz: float = 10_000.0,
    duration_s: float = 6.0,
    pretrigger_s: float = 1.0,
    pulse_s: float = 1e-3,
    snr_db: float | None = 45.0,
    bits: int = 24,
    range_factor: float = 1.2,
    peak_n: float | None = None,
    seed: int = 0,
) -> ImpactRecord:
    """Simulate one impact test.

    Parameters
    ----------
    system : str or dict
        A key of :data:`SYSTEMS` or a dict with ``mass, damping, stiffness, peak_n``.
    rate_hz, duration_s, pretrigger_s : float
        Sampling and record length; the pulse starts at ``pretrigger_s``.
    pulse_s : float
        Hammer pulse width [s].
    snr_db : float or None
        Noise on both channels (None: no noise, no quantisation).
    bits, range_factor : int, float
        Quantisation: ``bits`` over ``+-range_factor * peak`` of each channel.
    peak_n : float, optional
        Hammer peak force (default: the system's).
    seed : int
        Noise seed.
    """
    spec = SYSTEMS[system] if isinstance(system, str) else system
    eom = EquationOfMotion.create(mass=spec["mass"], damping=spec["damping"],
                                  stiffness=spec["stiffness"])
    n = int(round(duration_s * rate_hz))
    t = np.arange(n) / rate_hz
    force = half_sine_pulse(t, pretrigger_s, pulse_s, peak_n or spec["peak_n"])
    sim = simulate(eom, t, force=force)
    pre = int(round(pretrigger_s * rate_hz))
    if snr_db is None:
        return ImpactRecord(t, force, sim.a.copy(), sim.x, sim.v, sim.a, pre, eom)
    rng = np.random.default_rng(seed)
    scale = 10.0 ** (-snr_db / 20.0)
    pulse = force > 0
    f_noise = scale * float(np.sqrt(np.mean(force[pulse] ** 2)))
    a_noise = scale * ringdown_rms(sim.a, pre + int(np.ceil(pulse_s * rate_hz)) + 1)
    f_meas = force + f_noise * rng.standard_normal(n)
    a_meas = sim.a + a_noise * rng.standard_normal(n)
    f_meas = _quantise(f_meas, range_factor * float(np.max(np.abs(force))), bits)
    a_meas = _quantise(a_meas, range_factor * float(np.max(np.abs(sim.a))), bits)
    return ImpactRecord(t, f_meas, a_meas, sim.x, sim.v, sim.a, pre, eom)
