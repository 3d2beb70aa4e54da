"""Light, stiff, small-amplitude impact sets (session 15): the blind 15.7 g, 42 Hz symptom rebuilt.

A 5-30 g oscillator at 30-80 Hz (or the blind case's 15.7 g, 42 Hz) struck so that it moves
1e-5..1e-4 m, a mild cubic spring, one hidden mechanism of the rig (or none), 3-5 captures at
1-5 kHz, 25-45 dB, a force sensor at 40 dB. On such records the polynomial library's ``x``,
``x^3``, ``x^5`` are nearly collinear over one capture's amplitudes, and before session 15 the
pipeline kept refined models with ``x^5`` of 1e19-1e21 that predicted the other captures at
nrmse 0.3-2.5. The same draws as ``/tmp/s15-s15floor/light.py`` of the session's note
(``docs/diagnosis.md``, "Session 15").
"""

from __future__ import annotations

import math

import numpy as np

from eddi.conditioning import condition
from eddi.diagnosis import Record
from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test
from simulated_rig.hammer import HammerSpec
from simulated_rig.systems import hide_effect

#: The hidden mechanism's strength range (fraction of ``k1 A``, :func:`hide_effect`).
STRENGTH = {"hysteresis": (0.1, 0.3), "second_mode": (0.1, 0.4), "quadratic_damping": (0.01, 0.04),
            "coulomb_friction": (0.01, 0.03), "clearance": (0.1, 0.3)}


def light_records(kind: str, seed: int, *, blind_system: bool = True,
                  accel_only: bool = False) -> tuple[list[Record], dict]:
    """The records of one case and what was drawn (``blind_system``: 15.7 g, 42 Hz)."""
    rng = np.random.default_rng(70_000 + seed)
    mass = float(np.exp(rng.uniform(np.log(0.005), np.log(0.030))))
    f1 = float(rng.uniform(30.0, 80.0))
    if blind_system:
        mass, f1 = 0.0157, 42.0
    zeta = float(rng.uniform(0.005, 0.03))
    rate = float(rng.choice([1000.0, 2000.0, 5000.0]))
    snr = float(rng.uniform(25.0, 45.0))
    captures = int(rng.integers(3, 6))
    record_s = min(float(rng.uniform(20.0, 60.0)) / f1, 2.0)
    spread = float(rng.uniform(1.3, 2.5))
    shift = float(rng.uniform(-0.03, 0.10))
    mag = float(rng.uniform(0.0, 1.0))
    amp = float(np.exp(rng.uniform(np.log(1e-5), np.log(1e-4))))
    k1 = mass * (2 * math.pi * f1) ** 2
    c1 = 2 * zeta * math.sqrt(k1 * mass)
    hammer = HammerSpec(tip="rubber")
    lin = EquationOfMotion.create(mass=mass, damping={"v": c1}, stiffness={"x": k1})
    r0 = impact_test(lin, 1.0, rate_hz=20000.0, pretrigger_s=0.01, record_s=min(1.0, 2.0 / f1), snr_db=None,
                     hammer=hammer, seed=0)
    top = amp / float(np.max(np.abs(r0.truth_x)))
    vel = float(np.max(np.abs(r0.truth_v))) * top
    eom = EquationOfMotion.create(mass=mass, damping={"v": c1},
                                  stiffness={"x": k1, "x^3": shift * 8 * k1 / (3 * amp ** 2)})
    truth = eom
    if kind in STRENGTH:
        lo, hi = STRENGTH[kind]
        truth = hide_effect(eom, kind, lo + (hi - lo) * mag, seed, amplitude_m=amp, velocity_m_s=vel)
    elif kind == "friction+clearance":
        truth = hide_effect(eom, "coulomb_friction", 0.01 + 0.01 * mag, seed, amplitude_m=amp, velocity_m_s=vel)
        truth = hide_effect(truth, "clearance", 0.1 + 0.1 * mag, seed, amplitude_m=amp, velocity_m_s=vel)
    elif kind != "null":
        raise ValueError(f"unknown kind {kind!r}")
    levels = list(np.geomspace(1.0 / spread, 1.0, captures))
    rng.shuffle(levels)
    recs = []
    for i, lev in enumerate(levels):
        r = impact_test(truth, top * float(lev), rate_hz=rate, pretrigger_s=0.2, record_s=record_s, snr_db=snr,
                        force_snr_db=40.0, hammer=hammer, seed=1000 * seed + 10 * i + 1)
        force = None if accel_only else r.force_n
        c = condition(r.t, acc=r.acc_m_s2, force=force, pretrigger_samples=r.pretrigger_samples)
        recs.append(Record.from_conditioned(c, label=f"impact {i + 1}", pretrigger_samples=r.pretrigger_samples))
    return recs, {"mass_kg": mass, "f1_hz": f1, "zeta": zeta, "rate_hz": rate, "snr_db": snr,
                  "captures": captures, "record_s": record_s, "amp_m": amp}
