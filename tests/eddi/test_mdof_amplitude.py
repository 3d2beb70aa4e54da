"""Backbones (frequency and damping ratio against amplitude per mode): the records' beside a model's.

A model that passes leave-one-capture-out folds of similar blows can still depend on the
amplitude the wrong way; these tests hide such a model (linear damping where the structure has
quadratic drag) and require the symptom, and require silence for the true model on the same records.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.diagnosis.settings import NONE_FACTOR
from eddi.mdof.amplitude import amplitude_symptoms, backbones, capture_span, implied_nrmse
from eddi.mdof.model import MdofModel
from eddi.mdof.validate import validate_mdof
from simulated_rig.mdof_systems import MdofSystem, mdof_impact_test

#: our own pair (not a rig system): ground - 1.1 kg - 0.45 kg, hammer on mass 1, modes ~23 / 46 Hz
SYSTEM = MdofSystem(name="drag-pair", masses_kg=(1.1, 0.45), elements=(
    {"between": (0, 1), "k": 38000.0, "c": 4.5}, {"between": (1, 2), "k": 21000.0, "c": 1.3}), record_s=2.0)
#: quadratic drag on mass 1 [N s^2/m^2]: about the linear dashpot's force at the blows below
DRAG = 45.0


def _with(model: MdofModel, damping0: dict) -> MdofModel:
    d = list(model.damping)
    d[0] = {**d[0], **damping0}
    return model.model_copy(update={"damping": tuple(d)})


def _records(model: MdofModel, peaks, tmp_path):
    from station.mdof_data import condition_all
    from station.readers import read_measurement

    meas = [read_measurement(str(mdof_impact_test(SYSTEM, p, seed=20 + k, model=model).write_csv(
        tmp_path / f"r{k}.csv"))) for k, p in enumerate(peaks)]
    records, names, dp = condition_all(meas, "acc1")
    return records, names, dp


def test_implied_nrmse_matches_a_ring_down_with_that_error():
    # a decay at 0.8 % damping and a copy 0.1 % off in frequency and 10 % off in damping
    t = np.arange(0, 20.0, 1 / 2000.0)
    f, z = 20.0, 0.008
    ref = np.exp(-z * 2 * np.pi * f * t) * np.sin(2 * np.pi * f * t)
    for df, dz in ((0.001, 0.0), (0.0, 0.1 * z), (0.0005, 0.05 * z)):
        off = np.exp(-(z + dz) * 2 * np.pi * f * t) * np.sin(2 * np.pi * f * (1 + df) * t)
        measured = float(np.linalg.norm(off - ref) / np.linalg.norm(ref))
        assert implied_nrmse(df, dz, z) == pytest.approx(measured, rel=0.15)
    assert np.isnan(implied_nrmse(0.01, 0.0, 0.0))


def test_linear_damping_fitted_to_drag_is_a_symptom_and_the_true_model_is_silent(tmp_path):
    truth = _with(SYSTEM.model(), {"abs(v1)*v1": DRAG})
    records, names, dp = _records(truth, (45.0, 50.0, 55.0), tmp_path)
    floors = {c: 0.02 for c in names}
    true_modes = backbones(truth, records, [validate_mdof(truth, r) for r in records])
    assert len(true_modes) == 2 and all(b.amplitude_m.size >= 3 for b in true_modes)
    assert amplitude_symptoms(true_modes, floors, NONE_FACTOR) == []
    # the records' damping ratio of the lower mode grows with amplitude (drag), by more than 10 %
    low = true_modes[0]
    assert low.measured_zeta[-1] > 1.1 * low.measured_zeta[0]
    # a linear dashpot giving the drag's mean loss at the top of the range: right at the top, wrong below
    v_top = 2 * np.pi * low.mode_hz * 3e-4
    wrong = _with(SYSTEM.model(), {"v1": SYSTEM.model().damping[0]["v1"] + DRAG * 8 / (3 * np.pi) * v_top})
    wrong_modes = backbones(wrong, records, [validate_mdof(wrong, r) for r in records])
    found = amplitude_symptoms(wrong_modes, floors, NONE_FACTOR)
    assert [s["kind"] for s in found] == ["amplitude_dependence"]
    (s,) = found
    assert s["mode_hz"] == pytest.approx(low.mode_hz, rel=0.02)
    assert s["implied_nrmse"] > NONE_FACTOR * 0.02 and s["model_zeta"] > s["measured_zeta"]
    assert "damping ratio" in s["text"] and "allowed" in s["text"]


def test_capture_span_says_whether_leave_one_out_extrapolates(tmp_path):
    from types import SimpleNamespace

    def rec(peak):
        return SimpleNamespace(a=np.array([[0.0, peak, -0.5 * peak], [0.0, 0.1, 0.0]]))

    narrow = capture_span([rec(40.0), rec(44.0), rec(50.0)], ("acc1", "acc2"), "acc1")
    assert not narrow.tested and narrow.peaks_m_s2 == (40.0, 44.0, 50.0)
    assert narrow.up == pytest.approx(50 / 44) and narrow.down == pytest.approx(44 / 40)
    assert "40..50 m/s^2 at acc1; extrapolation in amplitude not tested" in narrow.text()
    wide = capture_span([rec(40.0), rec(120.0), rec(250.0)], ("acc1", "acc2"), "acc1")
    assert wide.tested and wide.up == pytest.approx(250 / 120) and wide.down == pytest.approx(3.0)
    assert wide.as_dict()["extrapolation_tested"] is True


def test_a_tone_leaking_into_a_modes_band_from_outside_is_not_read_as_that_mode():
    # session 12: the 2 f_1 tone of a quadratic coupling under a weak upper mode; here a synthetic
    # record: a strong 24 Hz ring-down plus its 48 Hz tone and a weak, fast 120 Hz mode, the model
    # the same without the 48 Hz tone. The 120 Hz band starts at sqrt(24 * 120) = 53.7 Hz.
    from types import SimpleNamespace

    rate, t = 2000.0, np.arange(0, 4.0, 1 / 2000.0)
    low = np.exp(-0.5 * t) * np.sin(2 * np.pi * 24 * t)
    tone = 0.05 * np.exp(-1.0 * t) * np.sin(2 * np.pi * 48 * t)
    upper = 0.2 * np.exp(-10.0 * t) * np.sin(2 * np.pi * 120 * t)
    meas, sim = (low + tone + upper)[None, :], (low + upper)[None, :]
    model = SimpleNamespace(natural_frequencies_hz=lambda: np.array([24.0, 120.0]), channels=("acc1",))
    rec = SimpleNamespace(window=(0, t.size), t=t, x=meas, a=meas * (2 * np.pi * 24) ** 2,
                          noise=np.array([1e-9]))
    val = SimpleNamespace(diverged=False, t=t, measured=meas, simulated=sim)
    modes = backbones(model, [rec], [val])
    up = next(b for b in modes if b.mode_hz == 120.0)
    lo, hi = np.sqrt(24 * 120), 120 * 1.6  # the last mode's band ends at EDGE times it
    assert up.measured_hz.size and np.all((up.measured_hz >= lo) & (up.measured_hz <= hi))
    # (the 24 Hz mode's band holds the tone: a difference there is the model's, and may be a symptom)
    assert [s for s in amplitude_symptoms(modes, {"acc1": 0.01}, NONE_FACTOR) if s["mode_hz"] == 120.0] == []
