"""The frequency-bias symptom is judged against its own uncertainty (session 13).

The band rule (:func:`eddi.diagnosis.earn.earn`) turns ``none`` into ``unexplained`` when the
baseline is above the noise floor and a symptom is notable. The frequency bias was notable
beyond a constant 0.5 % (set on nulls at 30-60 dB). On noisy records (18-25 dB) the cycle
frequencies at small amplitude scatter by percents: nulls of ``benchmarks/bench_diagnose_floor.py``
read ``unexplained`` on a -1.66 % or -0.72 % bias at small amplitude. Now the bias must also
exceed three of its standard errors (from the cycles' own scatter), and cycles whose amplitude
is within five times the coordinate's noise give no frequency at all.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from eddi.diagnosis.earn import earn
from eddi.diagnosis.name import Decision
from eddi.diagnosis.results import Symptom
from eddi.diagnosis.show import backbone
from eddi.diagnosis.symptoms import _part_numbers, bias_uncertainty_pct, notable


def _ringdown(noise: float, seed: int, f: float = 10.0, zeta: float = 0.01, rate: float = 500.0):
    """A linear ring-down of unit amplitude with smooth (low-pass) noise of RMS ``noise`` on x."""
    w = 2 * math.pi * f
    wd = w * math.sqrt(1 - zeta ** 2)
    t = np.arange(0.0, 3.0, 1.0 / rate)
    env = np.exp(-zeta * w * t)
    x = env * np.cos(wd * t)
    v = env * (-zeta * w * np.cos(wd * t) - wd * np.sin(wd * t))
    rng = np.random.default_rng(seed)
    n = rng.standard_normal(t.size + 40)
    k = np.hanning(21)
    smooth = np.convolve(n, k / np.linalg.norm(k), mode="same")[20:-20]  # RMS 1, ~4 f1 wide
    return t, x, v, noise * smooth, wd / (2 * math.pi)


def test_standard_error_matches_the_spread_of_the_median() -> None:
    """Over 60 draws of the noise on a linear ring-down (the model's frequency exact), the
    spread of the median small-amplitude bias is what :func:`bias_uncertainty_pct` says it is,
    within a factor 1.6."""
    meds, ses = [], []
    for seed in range(60):
        t, x, v, nx, fd = _ringdown(0.01, seed)
        amp, fm, _ = backbone(t, x + nx, v, 1.0)
        lo = amp <= np.percentile(amp, 33.0)
        r = fd / fm[lo]
        meds.append(100 * (np.median(r) - 1))
        ses.append(bias_uncertainty_pct(r))
    spread, said = float(np.std(meds)), float(np.mean(ses))
    assert 0.05 < spread < 1.0
    assert 1 / 1.6 < said / spread < 1.6, (said, spread)
    assert bias_uncertainty_pct(np.ones(3)) == math.inf  # three cycles carry no claim


def test_cycles_at_the_noise_give_no_frequency() -> None:
    """A ring-down (10 Hz, zeta 2.5 %, 3 s) that ends in its noise (RMS 1 % of the peak; the last
    cycles are 2-3x the noise): read blind, the small-amplitude band gives a -11.5 % bias (the
    noise's own crossings: the kind of -52 % a blind 7.6 t set was called ``unexplained`` on);
    with the coordinate's noise known, the crossings need a passage through +-3 of it (session
    14: one noise for the dead band and the guard), cycles under 5x it give no frequency, and the
    small-amplitude band holds real cycles only: +0.94 % +- 0.98 %, no claim (session 13, with
    the guard alone, the noise's cycles still set the thirds and that band was empty); the
    large-amplitude band is read as before."""
    from eddi.diagnosis.symptoms import bias_threshold_pct

    t, x, v, nx, fd = _ringdown(0.01, 0, zeta=0.025)
    sigma = float(np.std(nx))
    blind = _part_numbers(t, x + nx, v, x, v, 1.0, 500.0)
    heard = _part_numbers(t, x + nx, v, x, v, 1.0, 500.0, noise=sigma)
    assert blind["frequency_bias_low_pct"] < -5.0
    assert abs(heard["frequency_bias_low_pct"]) < bias_threshold_pct(heard["frequency_bias_low_se_pct"])
    assert abs(heard["frequency_bias_low_pct"]) < 1.5
    assert heard["frequency_bias_high_pct"] == pytest.approx(blind["frequency_bias_high_pct"], abs=0.05)
    assert abs(heard["frequency_bias_high_pct"]) < 0.5


def _none() -> Decision:
    return Decision("none", None, None, False, "within the factor")


def test_band_rule_hears_the_uncertainty() -> None:
    """The rule on numbers measured on noisy nulls (main read ``unexplained`` on both): the
    s12floor family's null seed 102 (589 kg, 6.8 Hz, 256 Hz, 21.5 dB: -1.66 % at small amplitude,
    +-1.95 %) and the 7.6 t kind of set (-52 % at small amplitude, +-40 %) keep ``none``; a
    2 % bias measured to +-0.1 % still overturns it, and a symptom without a standard error
    keeps the constant 0.5 %."""
    noisy = Symptom("frequency_bias", "off", {"high_amplitude_pct": -0.19, "low_amplitude_pct": -1.66,
                                              "high_amplitude_se_pct": 0.66, "low_amplitude_se_pct": 1.95})
    assert not notable(noisy)
    assert earn(_none(), 1.1, [noisy]).cause == "none"
    floor_band = Symptom("frequency_bias", "off", {"high_amplitude_pct": 0.3, "low_amplitude_pct": -52.0,
                                                   "high_amplitude_se_pct": 0.2, "low_amplitude_se_pct": 40.0})
    assert earn(_none(), 1.4, [floor_band]).cause == "none"
    sure = Symptom("frequency_bias", "off", {"high_amplitude_pct": 2.0, "low_amplitude_pct": 0.1,
                                             "high_amplitude_se_pct": 0.1, "low_amplitude_se_pct": 0.1})
    assert earn(_none(), 1.1, [sure]).cause == "unexplained"
    at_noise = Symptom("frequency_bias", "off", {"high_amplitude_pct": 0.1, "low_amplitude_pct": float("nan"),
                                                 "high_amplitude_se_pct": 0.1,
                                                 "low_amplitude_se_pct": float("inf")})
    assert not notable(at_noise)
    old = Symptom("frequency_bias", "off", {"high_amplitude_pct": 0.6, "low_amplitude_pct": 0.1})
    assert notable(old)


@pytest.mark.parametrize("seed", [102, 111])
def test_noisy_null_of_the_floor_family_is_not_unexplained(seed: int) -> None:
    """``bench_diagnose_floor.py`` nulls (no hidden effect, x + x^3 spring) at 21.5 and 22.9 dB:
    on main ``unexplained`` through the band rule (frequency bias -1.66 % / -0.72 % at small
    amplitude, 1.1x / 1.0x the floor); now ``none`` (the bias is within three of its
    standard errors)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from bench_diagnose_floor import recipe

    from eddi.diagnosis import diagnose
    from eddi.diagnosis.pipeline_base import pipeline_baseline
    from eddi.terms import DEFAULT_STIFFNESS

    recs, info = recipe("null", seed)
    pipe = pipeline_baseline(recs, info["mass_kg"], stiffness=DEFAULT_STIFFNESS)
    d = diagnose(recs, info["mass_kg"], stiffness=DEFAULT_STIFFNESS, pipeline=pipe)
    assert d.cause == "none", d.verdict
    bias = next(s for s in d.symptoms if s.kind == "frequency_bias")
    assert not notable(bias) and bias.values["low_amplitude_se_pct"] > 0.2, bias.values
