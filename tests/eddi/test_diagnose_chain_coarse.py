"""The chain checks on blows the sampling barely resolves (session 10): a pulse shorter than a
sample is not a double hit because its sampled peak is low, and a blow the spring takes
mostly is not a mass error (rig records, no fitting: seconds)."""

from __future__ import annotations

import math

import pytest

from eddi.diagnosis.chain import impulse_mass_ratio, inspect
from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test
from simulated_rig.hammer import HammerSpec
from tests.eddi.diagnose_cases import to_record


def _records(mass: float, f1: float, zeta: float, tip: str, rate: float, snr: float, record_s: float,
             top: float, seed: int, double_hit: bool = False) -> list:
    k1 = mass * (2 * math.pi * f1) ** 2
    eom = EquationOfMotion.create(mass=mass, damping={"v": 2 * zeta * math.sqrt(k1 * mass)}, stiffness={"x": k1})
    out = []
    for i, lev in enumerate((1 / 1.5, 1 / 1.22, 1.0)):
        r = impact_test(eom, top * lev, rate_hz=rate, pretrigger_s=0.05, record_s=record_s, snr_db=snr,
                        hammer=HammerSpec(tip=tip), double_hit=double_hit, seed=seed + i)
        out.append(to_record(r.t, r.acc_m_s2, r.force_n, r.pretrigger_samples, f"impact {i + 1}"))
    return out


def test_a_blow_shorter_than_a_sample_is_not_a_double_hit() -> None:
    """A 0.2 ms steel-tip blow of 2-3 N on an 11 g part at 5 kHz reads about 0.6 of its peak
    (the impulse is kept, the peak is not), so 5 % of the sampled peak is within 5 sigma of the
    force channel's 0.01 N noise: noise samples were second blows (1 of 3 records here before
    the noise rule). A real second blow of 30 % is still reported."""
    args = dict(mass=0.011, f1=13.7, zeta=0.0035, tip="steel", rate=5000.0, snr=57.0, record_s=2.9, top=3.4)
    clean = [_records(**args, seed=s) for s in (24_030, 24_060)]
    assert [s.kind for recs in clean for s in inspect(recs, 0.011, 13.7) if s.kind == "double_hit"] == []
    hit = _records(**args, seed=24_090, double_hit=True)
    found = [s for s in inspect(hit, 0.011, 13.7) if s.kind == "double_hit"]
    assert len(found) == 3
    assert all(s.values["delay_s"] == pytest.approx(4e-3, abs=4e-4) for s in found)


def test_a_blow_the_spring_takes_mostly_is_not_a_mass_error() -> None:
    """A 1 ms blow on a 142 Hz, 2.3 kg structure sampled at 2 kHz (14 samples a cycle): over the
    blow's samples the spring's share is 0.8 of the momentum, its correction off by a few % of
    itself, and the ratio read +4.3 % (a mass error) on the right mass. Such records do not
    enter the check: no finding, no ratio. A 1 ms blow on the same mass at 14 Hz (share about
    0.01) still reports a 5 % error."""
    fast = _records(mass=2.34, f1=141.9, zeta=0.009, tip="plastic", rate=2000.0, snr=31.5, record_s=0.28,
                    top=702.0, seed=51_000)
    assert impulse_mass_ratio(fast, 2.34) is None
    assert "impulse_mass" not in [s.kind for s in inspect(fast, 2.34, 141.9)]
    slow = _records(mass=2.34, f1=14.2, zeta=0.009, tip="plastic", rate=2000.0, snr=31.5, record_s=1.5,
                    top=702.0, seed=51_000)
    ratio = impulse_mass_ratio(slow, 2.34)
    assert ratio is not None and abs(ratio[0] - 1.0) < 0.01
    found = [s for s in inspect(slow, 1.05 * 2.34, 14.2) if s.kind == "impulse_mass"]
    assert len(found) == 1 and found[0].values["mismatch_pct"] == pytest.approx(100 * (1 / 1.05 - 1), abs=1.2)


def test_a_noise_bin_over_a_three_bin_comparison_is_not_base_motion() -> None:
    """A 0.56 s, 30 dB capture at 2 kHz (2.4 Hz bins) of a 72 Hz, 0.13 kg null: a noise bin at
    19 Hz, 1.6 times the noise's RMS per bin, stood 6.3 times over the three bins between
    38 and 43 Hz and was called base motion. The slow peak must also stand 4 times over the
    noise's level per bin (from the noise at rest); a real base (3x the mass at 0.2 f1) on
    the same structure still does."""
    m, f1, zeta, rate, top = 0.1288, 71.99, 0.0138, 2000.0, 38.64
    k1 = m * (2 * math.pi * f1) ** 2
    c = 2 * zeta * math.sqrt(k1 * m)
    lin = EquationOfMotion.create(mass=m, damping={"v": c}, stiffness={"x": k1})
    amp = float(max(abs(impact_test(lin, top, rate_hz=rate, pretrigger_s=0.01, record_s=5 / f1, snr_db=None,
                                    seed=0).truth_x)))
    k3 = 8 * 0.0444 * k1 / (3 * amp ** 2)  # +4.4 % at the strongest blow
    eom = EquationOfMotion.create(mass=m, damping={"v": c}, stiffness={"x": k1, "x^3": k3})
    r = impact_test(eom, top, rate_hz=rate, pretrigger_s=0.05, record_s=0.5556, snr_db=30.33, seed=136_029)
    rec = to_record(r.t, r.acc_m_s2, r.force_n, r.pretrigger_samples, "impact 3")
    assert "base_motion" not in [s.kind for s in inspect([rec], m, 71.4)]
    based = impact_test(eom, top, rate_hz=rate, pretrigger_s=0.05, record_s=0.5556, snr_db=30.33, seed=136_029,
                        base_motion={"mass_kg": 3 * m, "frequency_hz": 0.2 * f1, "damping_ratio": 0.05})
    rec = to_record(based.t, based.acc_m_s2, based.force_n, based.pretrigger_samples, "impact 3")
    assert "base_motion" in [s.kind for s in inspect([rec], m, 71.4)]


def test_a_heavily_damped_short_ring_down_is_not_a_mass_error() -> None:
    """A 38 g, 105 Hz structure at 6.8 % damping, 1 ms blows at 20 kHz, 0.09 s records: a cycle
    keeps exp(-4 pi zeta) = 42 % of its energy, and the small-damping form dE / (4 pi E) read
    the damping ratio as 4.6 %, so the damper's impulse came short and the ratio read +2.5 %,
    a mass error (the session-10 hold-out's false alarm). Read as -ln(1 - dE/E) / (4 pi), the
    ratio is within 1 %; a 5 % error is still said."""
    from eddi.diagnosis.chain import _damping_ratio

    recs = _records(mass=0.0381, f1=105.1, zeta=0.068, tip="plastic", rate=20000.0, snr=41.4, record_s=0.0891,
                    top=11.43, seed=299_000)
    assert _damping_ratio(recs[-1]) == pytest.approx(0.068, rel=0.08)
    ratio = impulse_mass_ratio(recs, 0.0381)
    assert ratio is not None and abs(ratio[0] - 1.0) < 0.012
    assert "impulse_mass" not in [s.kind for s in inspect(recs, 0.0381, 105.1)]
    assert "impulse_mass" in [s.kind for s in inspect(recs, 1.05 * 0.0381, 105.1)]
