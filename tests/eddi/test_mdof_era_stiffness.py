"""A modal fit whose small-amplitude frequency departs from the tail's takes the tail's stiffness.

Session 17 (helper s17leak, issue 14). ``bench_mdof_leak.py``'s t3c (5 / 0.5 / 0.3 kg, modes 2.5 /
15.6 / 22.5 Hz, m3 held to ground too, the upper modes 5-7 % damped, a cubic spring under the heavy
mass, 1024 Hz, 45 dB, no mass): on its own span (``own_span``) mode 3's fit still traded its
linear stiffness for a cubic (21.58 Hz, 4.1 % low; ERA 22.43 Hz in the tail); the uncoupled modal
model now carries ERA's linear stiffness where its own departs by more than 3 %, and says so.
Fails on the old code (14.4 % off on main, 4.1 % with the own span alone; no note).

Session 19 (helper s19weak): each modal equation's phase two now runs on its own band
(:func:`eddi.mdof.equations.own_band`) and mode 3's own fit lands at 22.496 Hz (-0.02 %), so the
pin is no longer needed there (bands on; they are off by default); the pin's path with the bands off.
"""

from __future__ import annotations

import numpy as np

from eddi.mdof.identify import identify_mdof
from simulated_rig.mdof_systems import MdofSystem
from station.mdof_data import condition_multichannel
from tests.eddi.mdof_target_cases import leak_system, system_measurements


def _system() -> MdofSystem:
    return leak_system("t3c")  # benchmarks/bench_mdof_leak.py's case


def test_uncoupled_modes_take_the_tails_stiffness_when_theirs_departs(monkeypatch):
    import eddi.mdof.identify as ident_mod

    monkeypatch.setattr(ident_mod, "BAND_FRACTION", 0.0)  # the fits on the whole band, as before session 19
    system = _system()
    recs = [condition_multichannel(m) for m in system_measurements(system, seed=700)]
    ident = identify_mdof(recs, system.channels, "acc2", coordinates="modal", coupling=False, highpass_hz=None)
    assert ident.coordinates == "modal"
    truth = np.sort(system.model().natural_frequencies_hz())
    f_id = np.sort(ident.model.natural_frequencies_hz())
    assert np.all(np.abs(f_id - truth) / truth < 0.03), (f_id, truth)
    assert any("linear stiffness from the tail's modes (ERA) for mode(s) 3" in n for n in ident.notes), ident.notes


def test_on_its_own_band_the_fit_needs_no_pin(monkeypatch):
    import eddi.mdof.identify as ident_mod

    monkeypatch.setattr(ident_mod, "BAND_FRACTION", 0.3)  # off by default (eddi.mdof.equations.BAND_FRACTION)
    system = _system()
    recs = [condition_multichannel(m) for m in system_measurements(system, seed=700)]
    ident = identify_mdof(recs, system.channels, "acc2", coordinates="modal", coupling=False, highpass_hz=None)
    truth = np.sort(system.model().natural_frequencies_hz())
    f_id = np.sort(ident.model.natural_frequencies_hz())
    assert np.all(np.abs(f_id - truth) / truth < 0.003), (f_id, truth)  # ERA's own: 0.02 / 0.10 / 0.30 %
    assert not any("linear stiffness from the tail's modes" in n for n in ident.notes), ident.notes
