"""Cases for the verdict tests: the rig's acceleration-only chain, and effects it cannot hide.

Catalogue effects and measurement-chain effects go through the simulated rig (hammer, sensors
with noise, 24-bit ADC); out-of-catalogue physics the rig's simulator does not hold (a
Bouc-Wen hysteretic spring) is integrated here (RK4) and measured with the same noise model.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from eddi.conditioning import condition
from eddi.diagnosis import Record
from eddi.model import EquationOfMotion
from simulated_rig.bench import default_sensors, impact_test
from simulated_rig.hammer import HammerSpec, hammer_force
from simulated_rig.sensors import ac_couple

#: 12.3 Hz, zeta 0.4 %, mildly hardening (about 8 % frequency shift at 1.6 mm).
SYSTEM = EquationOfMotion.create(mass=0.1, damping={"v": 0.06}, stiffness={"x": 600.0, "x^3": 2e7})
DAMPING = "v,x^2*v,v^3"
STIFFNESS = "x,x^2,x^3,x^4,x^5"
RATE_HZ = 5000.0


def to_record(t, acc, force, pretrigger, label, highpass_hz=()) -> Record:
    """Condition an acceleration (through extra first-order high-passes, if any) as the
    station does."""
    for fc in highpass_hz:
        acc = ac_couple(acc, fc, 1.0 / (t[1] - t[0]))
    c = condition(t, acc=acc, force=force, pretrigger_samples=pretrigger)
    return Record.from_conditioned(c, label=label, pretrigger_samples=pretrigger)


def rig_records(seed: int, *, system: EquationOfMotion = SYSTEM, effects=(), forces=(20.0, 25.0, 30.0),
                record_s: float = 3.0, snr_db: float = 40.0, highpass_hz: float | None = None,
                second_highpass_hz: float | None = None, double_hit: bool = False,
                base_motion=None, acc_range: float | None = None, runs: int = 1) -> list[Record]:
    """Impacts through the rig; ``runs`` > 1 repeats the set with other noise seeds (another
    acquire run)."""
    sens = default_sensors(snr_db, 24, None)
    if highpass_hz is not None or acc_range is not None:
        sens = (sens[0], dataclasses.replace(sens[1], iepe_highpass_hz=highpass_hz, range_si=acc_range))
    out = []
    for run in range(runs):
        for i, f in enumerate(forces):
            r = impact_test(system, f, rate_hz=RATE_HZ, pretrigger_s=0.2, record_s=record_s, sensors=sens,
                            effects=list(effects), seed=100 * seed + 7919 * run + i, double_hit=double_hit,
                            base_motion=base_motion)
            extra = (second_highpass_hz,) if second_highpass_hz else ()
            out.append(to_record(r.t, r.acc_m_s2, r.force_n, r.pretrigger_samples,
                                 f"run {run + 1} impact {i + 1}", extra))
    return out


def bouc_wen_records(seed: int, *, forces=(20.0, 25.0, 30.0), record_s: float = 3.0,
                     snr_db: float = 40.0) -> list[Record]:
    """A hysteretic (Bouc-Wen) spring: ``m a + c v + alpha k x + (1 - alpha) k z = F`` with
    ``z' = v (1 - (beta sign(v z) + gamma) |z|^n)`` scaled by the yield displacement.

    Integrated here in plain Python (independent of ``eddi.hysteresis``), ~1 s of CPU (was ~6 s
    with small numpy arrays per stage; the same records bit for bit): the records of a seed are
    made once per test process."""
    return list(_bouc_wen_records(seed, tuple(forces), record_s, snr_db))


@functools.lru_cache(maxsize=4)
def _bouc_wen_records(seed: int, forces: tuple, record_s: float, snr_db: float) -> tuple[Record, ...]:
    m, c, k, alpha = 0.1, 0.06, 600.0, 0.6
    dy, beta, gamma, n_exp = 0.6e-3, 0.5, 0.5, 1.5
    rng = np.random.default_rng(seed)
    out = []
    for i, f0 in enumerate(forces):
        n_pre = int(0.2 * RATE_HZ)
        n = n_pre + int(record_s * RATE_HZ)
        t = (np.arange(n) - n_pre) / RATE_HZ
        force = hammer_force(t, f0, HammerSpec(), False)
        fl = force.tolist()
        sub = 8
        h = 1.0 / (RATE_HZ * sub)

        # plain floats, not small numpy arrays: the same IEEE operations in the same order
        # (the same record bit for bit), ~6x less time
        def rhs(x, v, z, fk):
            zz = z / dy
            p = v * zz
            sg = 1.0 if p > 0 else (-1.0 if p < 0 else 0.0)
            dz = v * (1.0 - (beta * sg + gamma) * abs(zz) ** n_exp)
            a = (fk - c * v - alpha * k * x - (1 - alpha) * k * z) / m
            return v, a, dz

        x = v = z = 0.0
        acc = np.zeros(n)
        for j in range(n):
            fk = fl[j]
            acc[j] = rhs(x, v, z, fk)[1]
            f_next = fl[j + 1] if j + 1 < n else fk
            for q in range(sub):
                fa = fk + (f_next - fk) * q / sub
                fb = fk + (f_next - fk) * (q + 0.5) / sub
                fc = fk + (f_next - fk) * (q + 1) / sub
                k1 = rhs(x, v, z, fa)
                k2 = rhs(x + 0.5 * h * k1[0], v + 0.5 * h * k1[1], z + 0.5 * h * k1[2], fb)
                k3 = rhs(x + 0.5 * h * k2[0], v + 0.5 * h * k2[1], z + 0.5 * h * k2[2], fb)
                k4 = rhs(x + h * k3[0], v + h * k3[1], z + h * k3[2], fc)
                x = x + h / 6.0 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
                v = v + h / 6.0 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
                z = z + h / 6.0 * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2])
        free = acc[n_pre + int(0.01 * RATE_HZ):]
        sigma = float(np.sqrt(np.mean(free ** 2))) * 10 ** (-snr_db / 20)
        acc_m = acc + sigma * rng.standard_normal(n)
        force_m = force + 0.01 * rng.standard_normal(n)
        out.append(to_record(t, acc_m, force_m, n_pre, f"bouc-wen {i + 1}"))
    return tuple(out)
