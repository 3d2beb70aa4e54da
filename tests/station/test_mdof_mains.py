"""Mains interference on two-channel captures (``station.mdof_mains``): a 50 Hz tone on both
accelerometers is named per channel with its frequency and amplitude; the same captures without
it, and a structure with a mode at 49.4 Hz, name none; an amplitude symptom ringing at the tone
does not decide the verdict."""

from __future__ import annotations

import pytest

from simulated_rig.mdof_systems import MdofSystem, load_mdof_system, mdof_impact_test
from station.mdof_commands import _read
from station.mdof_mains import line_tone_symptoms, split_amplitude


def _plate(**upd) -> MdofSystem:
    """Two masses, linear, modes at 32.9 and 74.6 Hz (own case: 0.8/0.4 kg), 4096 Hz, 1.2 s."""
    base = load_mdof_system("two-mass-cubic")
    els = (base.elements[0].model_copy(update={"k": 60000.0, "c": 5.0}),
           base.elements[1].model_copy(update={"k": 50000.0, "k3": 0.0, "c": 2.0}))
    return base.model_copy(update={"elements": els, "masses_kg": (0.8, 0.4), "rate_hz": 4096.0, "record_s": 1.2,
                                   "impacts_n": (60.0, 120.0, 200.0), **upd})


def _files(system: MdofSystem, tmp_path, tag: str, mains=None, seed=40) -> list[str]:
    return [str(mdof_impact_test(system, p, seed=seed + k, mains=mains).write_csv(tmp_path / f"{tag}-{k}.csv"))
            for k, p in enumerate(system.impacts_n)]


def test_a_tone_on_both_channels_is_named_per_channel(tmp_path) -> None:
    files = _files(_plate(), tmp_path, "tone", dict(mains_si=0.1, mains_hz=49.97))
    found = line_tone_symptoms(_read(files), ("acc1", "acc2"))
    assert sorted(s["channel"] for s in found) == ["acc1", "acc2"]
    for s in found:
        assert s["frequency_hz"] == pytest.approx(49.97, rel=3e-3)
        assert s["amplitude_m_s2"] == pytest.approx(0.1, rel=0.25)
        assert "mains interference" in s["text"]


def test_no_tone_and_a_mode_at_49_hz_name_none(tmp_path) -> None:
    assert line_tone_symptoms(_read(_files(_plate(), tmp_path, "null")), ("acc1", "acc2")) == []
    # the rig's two-mass chain: modes at 23.4 and 49.4 Hz, no tone (a held-out structure: not tuned on)
    chain = load_mdof_system("two-mass-cubic")
    chain = chain.model_copy(update={"record_s": 1.2, "impacts_n": (40.0, 120.0)})
    assert line_tone_symptoms(_read(_files(chain, tmp_path, "mode49", seed=7)), ("acc1", "acc2")) == []


def test_an_amplitude_symptom_at_the_tone_is_the_tones() -> None:
    tone = {"channel": "acc2", "frequency_hz": 49.95, "amplitude_m_s2": 0.049}
    at_tone = {"channel": "acc2", "measured_hz": 49.9, "amplitude_m": 6.7e-7, "text": "mode at 73.7 Hz ..."}
    a_mode = {"channel": "acc2", "measured_hz": 73.0, "amplitude_m": 6.7e-7, "text": "mode at 73.7 Hz ..."}
    big = {"channel": "acc2", "measured_hz": 49.9, "amplitude_m": 1e-4, "text": "mode at 49.4 Hz ..."}
    other = {"channel": "acc1", "measured_hz": 49.9, "amplitude_m": 6.7e-7, "text": "..."}
    keep, by_tone = split_amplitude([at_tone, a_mode, big, other], [tone])
    assert keep == [a_mode, big, other]
    assert len(by_tone) == 1 and by_tone[0]["explained_by"] == "line_tone" and "line tone" in by_tone[0]["text"]


def test_a_tone_is_found_on_captures_whose_time_starts_at_the_first_sample(tmp_path) -> None:
    """A lab's CSV: time from 0, no pre-trigger count; the rest is what comes before the blow (as
    for one coordinate). Session 20: before, such captures were not searched (rest 0)."""
    import numpy as np

    files = _files(_plate(), tmp_path, "t0", dict(mains_si=0.1, mains_hz=49.97))
    for f in files:
        rows = np.loadtxt(f, delimiter=",", skiprows=1)
        head = open(f).readline().strip()
        assert rows[0, 0] < 0  # the rig writes its pre-trigger at negative times
        rows[:, 0] -= rows[0, 0]
        np.savetxt(f, rows, delimiter=",", header=head, comments="", fmt="%.17g")
    meas = _read(files)
    assert all(not m.pretrigger_samples and m.t[0] == 0 for m in meas)
    found = line_tone_symptoms(meas, ("acc1", "acc2"))
    assert sorted(s["channel"] for s in found) == ["acc1", "acc2"]
    assert all(s["frequency_hz"] == pytest.approx(49.97, rel=3e-3) for s in found)
