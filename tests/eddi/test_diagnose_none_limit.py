"""The one-coordinate ``none`` limit: what nulls reach (session 18; docs/diagnosis.md "Session 18:
`none` above the floor").

``none`` (``none (uncertain)`` above the floor) needs the judged baseline within
:data:`~eddi.diagnosis.settings.NONE_LIMIT` (2.5) of the floor of the data; until session 18 it was
:data:`~eddi.diagnosis.settings.NONE_FACTOR` (3.5), and hidden effects between the two read
``none (uncertain)``. The limit is the largest ratio measured on nulls, rounded up
(``benchmarks/bench_diagnose_none_limit.py``, the calibration's nulls and chain-difference nulls:
1.82, a 20.8 dB null of the noisy family; 2.39, test_diagnose_earned.py's heavy null in the library
call), not set on these cases. Above it the verdict is a name by the ordinary cut or ``unexplained``.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

from eddi.diagnosis import NONE_FACTOR, NONE_LIMIT, diagnose
from eddi.diagnosis.pipeline_base import pipeline_baseline
from eddi.diagnosis.tolerance import ChainTolerance
from simulated_rig.bench import default_sensors

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import bench_diagnose_calibration as B  # noqa: E402
from bench_diagnose_none_limit import null_set  # noqa: E402
from bench_diagnose_own16 import OWN  # noqa: E402


def _ratio(d) -> float:
    return d.judging.nrmse / d.noise_floor.data_nrmse


def _run(recs, mass: float):
    return diagnose(recs, mass, pipeline=pipeline_baseline(recs, mass), chain=ChainTolerance())


def _highpass(family: str, corner_hz: float, seed: int):
    """s16ee's own family with the accelerometer's AC coupling at ``corner_hz`` (its ladder rung)."""
    cfg = OWN[family]
    s = default_sensors(cfg["snr"], 24, None)
    sensors = (s[0], dataclasses.replace(s[1], iepe_highpass_hz=corner_hz))
    forces = tuple(cfg["mass"] / 0.1 * f for f in (20.0, 25.0, 30.0))
    return _run(B._records(B._system(cfg), forces, cfg, seed, sensors), cfg["mass"])


def test_hidden_coupling_past_the_pipelines_limit_is_unexplained() -> None:
    # held-out family ownB (0.6 kg, 6 Hz, hard, 15 kHz, 33 dB), AC coupling at 0.5 Hz, seed 2: the
    # judged baseline 2.4x the floor of the data (within the limit) but the pipeline's model 3.0x
    # its records' own share (nulls: at most 2.04x), and no candidate earns its place.
    # Before (main fa3f89a, factor 3.5 for both): `none (uncertain)` at 2.4x
    d = _highpass("ownB", 0.5, 2)
    assert 2.3 < _ratio(d) < NONE_LIMIT, _ratio(d)
    assert d.cause == "unexplained", d.verdict
    assert d.verdict.startswith("Cause: unexplained. The baseline departs from the held-out measurements")
    assert "3.0x the records' own share of the floor" in d.verdict
    assert "follows" not in d.symptom


def test_hidden_coupling_above_the_limit_is_named() -> None:
    # held-out family ownC (0.05 kg, 15 Hz, soft, 8 kHz, 42 dB), AC coupling at 1.2 Hz, seed 2:
    # 2.9x the floor; above the limit the ordinary cut names the coupling (within the former 3.5
    # only the strong cut could, and it fell short: `none (uncertain)` on main fa3f89a)
    d = _highpass("ownC", 1.2, 2)
    assert NONE_LIMIT < _ratio(d) < NONE_FACTOR, _ratio(d)
    assert d.cause == "sensor_highpass", d.verdict


def test_nulls_above_the_floor_stay_none_uncertain() -> None:
    # the two largest ratios of the limit's nulls (tuning seeds): the noisy family's seed 6
    # (0.093 kg, 8.9 Hz, damping ratio 0.2 %, 10 kHz, 20.8 dB) at 1.82x and the wide family's
    # seed 10 (29 kg, 35 Hz, 1 kHz, 31.6 dB, x^2 v damping) at 1.08x: a limit under them would call
    # a complete model incomplete
    for family, seed, shown in (("noisy", 6, "1.8x"), ("wide", 10, "1.1x")):
        recs, info = null_set(seed, family)
        d = _run(recs, info["mass_kg"])
        assert 1.0 < _ratio(d) < NONE_LIMIT, (family, seed, _ratio(d))
        assert d.cause == "none", d.verdict
        assert d.verdict.startswith(f"Cause: none (uncertain). The baseline's held-out error is {shown} the noise "
                                    "floor"), d.verdict
        assert f"within the {NONE_LIMIT:g}x allowed" in d.verdict
