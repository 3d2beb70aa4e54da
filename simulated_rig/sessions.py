"""Captures from several acquisition sessions whose measurement chains differ slightly.

A real lab does not measure every capture of a set with the same chain: between two sessions
the accelerometer is remounted or recalibrated (its sensitivity differs by a few tenths of a
percent: ISO 16063-21 back-to-back calibration quotes an expanded uncertainty of about 0.5-1 %
at reference conditions), the DAQ's sample clock runs at a slightly different rate (a crystal
oscillator is specified to +-10-100 ppm and drifts with temperature), the channels' DC offsets
change, the trigger fires a few samples early or late and the pretrigger length is set
differently. :class:`Chain` is one session's chain; :func:`session_test` is
:func:`simulated_rig.bench.impact_test` through it.

The clock: the DAQ samples at ``rate_hz (1 + clock_ppm 1e-6)`` but stamps the samples at the
nominal ``rate_hz``, so the record is the truth sampled at the true rate and labelled at the
nominal one (every frequency reads ``1 / (1 + ppm 1e-6)`` times the true one). The gains
multiply the measured channel (noise included, as a sensitivity does in the volts the ADC
sees); the offsets add a constant in SI units to the whole record (pretrigger included).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from eddi.model import EquationOfMotion
from simulated_rig.bench import ImpactRecord, impact_test
from simulated_rig.errors import ScenarioError


@dataclass(frozen=True)
class Chain:
    """One acquisition session's measurement chain, relative to the nominal one.

    Attributes
    ----------
    acc_gain : float
        Accelerometer sensitivity error (relative, 0.003 = +0.3 %).
    force_gain : float
        Force-sensor sensitivity error (relative).
    clock_ppm : float
        Sample-clock error [ppm]: the true rate is ``rate_hz (1 + 1e-6 clock_ppm)``.
    acc_offset : float
        DC offset of the acceleration channel [m/s^2].
    force_offset : float
        DC offset of the force channel [N].
    pretrigger_s : float
        Record before the blow [s].
    jitter_samples : int
        The trigger's jitter: each capture's pretrigger moves by up to this many samples.
    """

    acc_gain: float = 0.0
    force_gain: float = 0.0
    clock_ppm: float = 0.0
    acc_offset: float = 0.0
    force_offset: float = 0.0
    pretrigger_s: float = 0.2
    jitter_samples: int = 0

    def __post_init__(self) -> None:
        for name in ("acc_gain", "force_gain"):
            if not (abs(getattr(self, name)) < 0.5):
                raise ScenarioError(f"chain.{name}: must be in (-0.5, 0.5), got {getattr(self, name)}")
        if not (abs(self.clock_ppm) < 1e4):
            raise ScenarioError(f"chain.clock_ppm: must be in (-1e4, 1e4), got {self.clock_ppm}")
        if not (self.pretrigger_s >= 0 and self.jitter_samples >= 0):
            raise ScenarioError("chain.pretrigger_s and chain.jitter_samples must be >= 0")


def session_test(system: str | EquationOfMotion, peak_force_n: float, chain: Chain, *, rate_hz: float,
                 seed: int = 0, **kw: Any) -> ImpactRecord:
    """One impact test measured through ``chain`` (keywords as :func:`impact_test`).

    Returns the record with ``t`` and ``rate_hz`` at the nominal rate, the channels scaled by
    the gains and shifted by the offsets; ``truth_*`` stay the true signals at the true
    sample instants.
    """
    rng = np.random.default_rng(seed + 7_919)
    true_rate = rate_hz * (1.0 + 1e-6 * chain.clock_ppm)
    jit = int(rng.integers(-chain.jitter_samples, chain.jitter_samples + 1)) if chain.jitter_samples else 0
    pre = max(0.0, chain.pretrigger_s + jit / true_rate)
    r = impact_test(system, peak_force_n, rate_hz=true_rate, pretrigger_s=pre, seed=seed, **kw)
    n_pre = r.pretrigger_samples
    t = (np.arange(r.t.size) - n_pre) / rate_hz
    return replace(r, t=t, rate_hz=float(rate_hz),
                   acc_m_s2=r.acc_m_s2 * (1.0 + chain.acc_gain) + chain.acc_offset,
                   force_n=r.force_n * (1.0 + chain.force_gain) + chain.force_offset)


def draw_chains(rng: np.random.Generator, sessions: int, *, gain: tuple[float, float] = (0.001, 0.01),
                clock_ppm: tuple[float, float] = (10.0, 100.0), acc_offset: float = 0.0,
                force_offset: float = 0.0, pretrigger_s: tuple[float, float] = (0.05, 0.3),
                jitter_samples: int = 3) -> list[Chain]:
    """``sessions`` chains: the first nominal in gain and clock, each later one off by a gain
    drawn log-uniformly in ``gain`` (either sign, on the accelerometer; the force sensor off by
    a third of that range), a clock drawn log-uniformly in ``clock_ppm`` (either sign), DC
    offsets uniform within +-``acc_offset`` [m/s^2] / +-``force_offset`` [N] (every session),
    pretrigger lengths uniform in ``pretrigger_s`` and the trigger jitter."""
    def logu(lo: float, hi: float) -> float:
        return float(np.exp(rng.uniform(np.log(lo), np.log(hi)))) * (1.0 if rng.random() < 0.5 else -1.0)

    out = []
    for s in range(sessions):
        out.append(Chain(acc_gain=logu(*gain) if s else 0.0,
                         force_gain=logu(gain[0] / 3, gain[1] / 3) if s else 0.0,
                         clock_ppm=logu(*clock_ppm) if s else 0.0,
                         acc_offset=float(rng.uniform(-acc_offset, acc_offset)),
                         force_offset=float(rng.uniform(-force_offset, force_offset)),
                         pretrigger_s=float(rng.uniform(*pretrigger_s)), jitter_samples=jitter_samples))
    return out
