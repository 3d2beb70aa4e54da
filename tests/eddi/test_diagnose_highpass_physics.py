"""``sensor_highpass`` judged like for like and ruled out by physics it cannot produce.

A strong amplitude-dependent damping ``c |x| v`` (0.2 k1 A, as the calibration ladder's top
rung) was named ``sensor_highpass`` in 2 of 3 held-out seeds: the corrected model refitted
on re-conditioned records beat a baseline whose fit was lost on a part. A first-order
coupling leaves the damping ratio per cycle independent of the amplitude; ``|x| v`` makes it
grow with the amplitude. The same wrong name is reproduced here on the test system with the
default libraries and the high-pass candidate alone (named with the check switched off).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import bilinear, lfilter

from eddi.diagnosis import diagnose
from eddi.diagnosis.highpass import HP_DAMPING_SLOPE, damping_slope, through_highpass
from tests.eddi.diagnose_cases import SYSTEM, rig_records


def _abs_x_v_records() -> list:
    """The test system with ``c |x| v`` at 0.2 k1 over the middle blow's peak velocity."""
    v_peak = float(np.max(np.abs(rig_records(3, forces=(25.0,))[0].v)))
    c = 0.2 * SYSTEM.linear_stiffness() / v_peak
    hidden = SYSTEM.model_copy(update={"damping": {**SYSTEM.damping, "abs(x)*v": c}})
    return rig_records(3, system=hidden)


def test_strong_abs_x_v_damping_is_not_named_sensor_highpass() -> None:
    recs = _abs_x_v_records()
    assert damping_slope(recs) > 0.4  # |x| v: the damping ratio rises with the amplitude
    d = diagnose(recs, SYSTEM.mass, mechanisms=["sensor_highpass"])
    hp = next(c for c in d.candidates if c.name == "sensor_highpass")
    assert not hp.skipped and hp.model is not None
    # the candidate still cuts the held-out error by half (what named it before) ...
    assert hp.nrmse <= 0.5 * d.baseline.nrmse
    # ... but the records contradict a coupling: never named, reason in the JSON
    assert "grows with the amplitude" in hp.contradicted
    assert d.cause == "unexplained", d.verdict
    assert d.to_dict()["candidates"][0]["contradicted"] == hp.contradicted


@pytest.mark.parametrize("corner_hz", [None, 0.5, 2.0])
def test_a_coupling_leaves_the_damping_ratio_amplitude_independent(corner_hz) -> None:
    slope = damping_slope(rig_records(4, highpass_hz=corner_hz))
    assert abs(slope) < HP_DAMPING_SLOPE


def test_through_highpass_matches_a_first_order_coupling_from_rest() -> None:
    rate, fc, f = 2000.0, 0.8, 7.0
    t = np.arange(0, 3.0, 1 / rate)
    x = np.where(t > 0.1, np.exp(-0.3 * (t - 0.1)) * np.sin(2 * np.pi * f * (t - 0.1)), 0.0) * 1e-3
    b, a = bilinear([1.0, 0.0], [1.0, 2 * np.pi * fc], fs=rate)  # s / (s + w_c), from rest
    xm = lfilter(b, a, x)
    k = int(1.2 * rate)  # a held-out part starting mid-record: the coupling's state read from both
    got = through_highpass(x[k:], t[k:], fc, float(x[k] - xm[k]))
    err = np.linalg.norm(got - xm[k:]) / np.linalg.norm(xm[k:])
    assert err < 2e-3
    # and the coupling matters here: the undistorted displacement is 10x further off
    assert np.linalg.norm(x[k:] - xm[k:]) / np.linalg.norm(xm[k:]) > 10 * err



def _heavy_slow_csvs(folder, corner_hz: float | None) -> list[str]:
    """A 12 kg, 9 Hz, 1 %-damped stiffening oscillator at 2 kHz, four 8 s blows written as a
    lab's CSV files (not the test system: EDDI's own fit of its coupled records is poor, so
    only a candidate refined like the baseline can win)."""
    import dataclasses
    import math

    from eddi.model import EquationOfMotion
    from simulated_rig.bench import default_sensors, impact_test

    m, f1 = 12.0, 9.0
    k1 = m * (2 * math.pi * f1) ** 2
    eom = EquationOfMotion.create(mass=m, damping={"v": 0.02 * math.sqrt(k1 * m)},
                                  stiffness={"x": k1, "x^3": 0.3 * k1 / 1e-4})
    s = default_sensors(45.0, 24, None)
    sensors = (s[0], dataclasses.replace(s[1], iepe_highpass_hz=corner_hz)) if corner_hz else s
    paths = []
    for i, peak in enumerate((2850.0, 3800.0, 4750.0, 3325.0)):
        r = impact_test(eom, peak, rate_hz=2000.0, pretrigger_s=0.3, record_s=8.0, sensors=sensors, seed=100 + i)
        path = folder / f"blow-{i}.csv"
        np.savetxt(path, np.c_[r.t, r.force_n, r.acc_m_s2], delimiter=",", header="t,force,acc", comments="",
                   fmt="%.10g")
        paths.append(str(path))
    return paths


def test_a_coupling_on_a_heavy_slow_oscillator_is_named_refined_like_the_baseline(tmp_path, capsys) -> None:
    # judged unrefined against the refined baseline the candidate read 0.30 against 0.055 and
    # the verdict was `none (uncertain)`: refined on its corner's records it is like for like
    import json

    from station.cli import main

    assert main(["diagnose", *_heavy_slow_csvs(tmp_path, 0.6), "--mass", "12", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["cause"] == "sensor_highpass", d["verdict"]
    hp = next(c for c in d["candidates"] if c["name"] == "sensor_highpass")
    assert 0.4 <= hp["params"]["corner_hz"] <= 0.85
    assert hp["nrmse"] <= 0.5 * d["baseline"]["nrmse"]


def _two_session_asymmetric_records(m: float = 20.0, f1: float = 30.0, seed: int = 3) -> list:
    """A null of my own with the character of the calibration's chain-difference false alarm
    (seed 6017: 7.1 kg, 25 Hz): nothing hidden, a strongly asymmetric spring (``x^2 + x^3``,
    tangent stiffness up 170 % at the largest blow's linear peak), damping ratio 0.006, 2 kHz,
    59 dB, 24 cycles a record, six blows from two acquisition sessions (accelerometer +0.55 %,
    clock -15 ppm in the second, read as CSV without the pre-trigger length)."""
    import math

    from eddi.conditioning import condition
    from eddi.diagnosis import Record
    from eddi.model import EquationOfMotion
    from simulated_rig.bench import impact_test
    from simulated_rig.sessions import Chain, session_test

    k1 = m * (2 * math.pi * f1) ** 2
    c = 2 * 0.006 * math.sqrt(k1 * m)
    top, rise, rate = 300.0 * m, 1.7, 2000.0
    lin = EquationOfMotion.create(mass=m, damping={"v": c}, stiffness={"x": k1})
    amp = float(np.max(np.abs(impact_test(lin, top, rate_hz=rate, pretrigger_s=0.01, record_s=min(0.5, 5 / f1),
                                          snr_db=None, seed=0).truth_x)))
    eom = EquationOfMotion.create(mass=m, damping={"v": c}, stiffness={
        "x": k1, "x^2": 0.5 * rise * k1 / (2 * amp), "x^3": rise * k1 / (3 * amp ** 2)})
    chains = (Chain(pretrigger_s=0.2), Chain(acc_gain=0.0055, force_gain=0.00055, clock_ppm=-15.0, pretrigger_s=0.12))
    out = []
    for i, level in enumerate((1.0, 0.62, 0.8, 0.71, 0.55, 0.9)):
        r = session_test(eom, top * level, chains[i // 3], rate_hz=rate, record_s=24 / f1, snr_db=59.0,
                         seed=seed + 10 * i)
        pre = r.pretrigger_samples if i < 3 else None
        cnd = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=pre)
        out.append(Record.from_conditioned(cnd, label=f"session {i // 3 + 1} blow {i % 3 + 1}", pretrigger_samples=pre))
    return out


def test_a_refit_of_re_conditioned_records_does_not_name_a_coupling() -> None:
    # the baseline's fold fits miss the three largest blows when the sessions' gains differ
    # (0.03-0.04 held out, 0.002-0.006 on the others); the candidate's refit on records
    # conditioned again at 0.2-0.28 Hz reads 0.007 and cut the error by 64 %, beating EDDI's
    # baseline on every part, so the strong cut named sensor_highpass within the floor (the
    # verdict fails without the coupling's own cut)
    from eddi.diagnosis.pipeline_base import pipeline_baseline
    from eddi.diagnosis.settings import STRONG_MARGIN

    m = 20.0
    recs = _two_session_asymmetric_records(m)
    d = diagnose(recs, m, pipeline=pipeline_baseline(recs, m))
    hp = next(c for c in d.candidates if c.name == "sensor_highpass")
    assert not hp.skipped and hp.model is not None and not hp.contradicted
    # what named it before session 15: the strong cut on every part against a baseline that missed the
    # three largest blows; the pipeline now keeps the equation-error fit of its terms (held out 0.035 ->
    # 0.032) and the folds judge with the better of their contenders (0.0089: 0.0185 / 0.0028 / 0.015 /
    # 0.007 / 0.0042 / 0.0056), so the candidate's refit (0.0068) no longer makes that cut here
    assert not (hp.wins_every_part and hp.nrmse <= (1.0 - STRONG_MARGIN) * d.judging.nrmse) or hp.params[
        "coupling_cut"] < STRONG_MARGIN
    assert d.judging.nrmse <= d.noise_floor.nrmse  # within the floor: a clean chain's records
    assert d.cause == "none", d.verdict
    # its fold models reproduce the records as measured as well without the coupling
    assert hp.params["coupling_cut"] < 0.2
    assert abs(hp.params["uncoupled_nrmse"] - hp.nrmse) < 0.2 * hp.nrmse


def test_coupling_cut_compares_the_same_models_with_and_without_the_coupling() -> None:
    from eddi.diagnosis.highpass import coupling_cut

    assert coupling_cut([0.01, 0.02], [0.04, 0.02]) == pytest.approx(0.5)
    assert coupling_cut([0.03], [0.02]) == pytest.approx(-0.5)
    assert np.isnan(coupling_cut([], []))
