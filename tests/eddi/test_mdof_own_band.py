"""Weak, fast modes: each modal equation on its own band; a low mode at the first Welch bin.

Session 19 (helper s19weak, issue 14). Own cases, not the session's tuning cases:

1. A fast, weak mode's coordinate ``q_i = P y`` carries slow content over its short span (the first
   mode leaking through the shapes, the drift band's integrated noise). Phase two's sample balance
   ``k q_i = -q_i'' - B`` read it as stiffness: the uncoupled modal model's upper modes came out
   0.2-1.5 % low (ERA 0.05-0.6 %). Phase two now runs on the mode's own band (columns and force
   high-passed at 0.3 f_i, :func:`eddi.mdof.equations.own_band`). Own two-mass chain 2 / 0.15 kg
   (2.17 / 21.3 Hz, 2048 Hz, driven at the light mass, 45 dB): mode 2 -0.29 % before, +0.01 % after.
2. A weak low mode that fills Welch's first two bins falling was skipped by ``find_peaks`` (an
   edge is no peak) and the drift cut-off went to a quarter of the second mode, above the first
   (bench_mdof_fast h2-lin: 3.66 Hz on a 2.6 Hz mode, 200x of its displacement removed; the
   delivered model's mode 1 20 % low). Own chain 30 / 1.5 / 1 kg at 5 kHz (diagnosed at 1667 Hz),
   driven at mass 2: cut-off 3.26 Hz on a 2.16 Hz mode before, 0.83 Hz after.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from bench_mdof_leak import chain, records  # noqa: E402


def test_a_weak_fast_mode_keeps_its_frequency_on_its_own_band():
    from eddi.mdof.identify import identify_mdof

    system = chain("own-band", (2.0, 0.15), (400.0, 2500.0), 1.5e-3, 0.0, rate=2048.0, record_s=5.0, drive=2,
                   impacts=(30.0, 60.0, 90.0))
    recs = records(system, 45.0)
    ident = identify_mdof(recs, system.channels, "acc2", coordinates="modal", coupling=False)
    truth = np.sort(system.model().natural_frequencies_hz())
    f_id = np.sort(ident.model.natural_frequencies_hz())
    assert f_id.size == 2
    assert np.all(np.abs(f_id / truth - 1) < 0.001), (f_id, truth)  # before: mode 2 -0.29 %


def test_a_low_mode_in_the_first_welch_bins_sets_the_drift_cut_off(tmp_path):
    from station.mdof_commands import _read
    from station.mdof_data import condition_all, reduce_rate

    masses, ks = (30.0, 1.5, 1.0), (6000.0, 20000.0, 15000.0)
    system = chain("own-low", masses, ks, 2 * 0.01 / (2 * np.pi * 13.05), 0.0, rate=5000.0, record_s=6.0, drive=2,
                   impacts=(8.0, 10.0, 12.0), pre=0.1)
    from simulated_rig.mdof_systems import mdof_impact_test

    files = [str(mdof_impact_test(system, p, snr_db=45.0, seed=77 + k).write_csv(tmp_path / f"{k}.csv"))
             for k, p in enumerate(system.impacts_n)]
    meas, _note = reduce_rate(_read(files))
    recs, _names, _dp = condition_all(meas, "acc2")
    f1 = float(np.min(system.model().natural_frequencies_hz()))
    assert abs(f1 - 2.16) < 0.01
    for r in recs:
        assert r.highpass_hz <= 0.4 * f1, r.highpass_hz  # the record's floor 0.83 Hz; before: 3.26 Hz, above the mode
