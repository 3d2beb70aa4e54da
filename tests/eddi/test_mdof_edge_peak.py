"""The lowest mode in Welch's first bin sets the drift cut-off; a sink's slow motion there does not
(session 20, issue 14; :func:`eddi.mdof.signals.lowest_mode_hz`, ``EDGE_REACH``).

Before: ``find_peaks`` never counts a maximum in the first bin, so a slow mode that falls there (the
reduced rate's long bins) was skipped and the drift cut-off went to a quarter of the next mode, above
the slow one (bench_mdof_fast's h2-lin: 3.66 Hz on a 2.6 Hz mode, its fit 20 % low). Counting every
first-bin maximum also counted the 1/f^2-weighted slow content of the rig ``nes`` sink (2.6 % of the
largest on one capture's sink channel; cut-off 7.25 -> 1.83 Hz, the true model's held-out error
0.0055 -> 0.0153, session 19). The edge counts only when longer segments resolve a peak within two
of the first bins.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test, load_mdof_system  # noqa: E402
from station.mdof_data import condition_all, reduce_rate  # noqa: E402
from station.readers import Measurement  # noqa: E402
from tests.eddi.mdof_target_cases import system_measurements  # noqa: E402


def _slow_chain() -> MdofSystem:
    """20 kg on a soft spring (1.8 Hz), 2 kg on it (12.6 Hz), struck at the light mass, 6 s at 2048 Hz:
    the station's reduced rate (683 Hz) gives 0.67 Hz Welch bins, where the 1.8 Hz mode fills bin 1
    falling on the light mass' channel."""
    k1, k2 = 20.0 * (2 * np.pi * 1.9) ** 2, 2.0 * (2 * np.pi * 12) ** 2
    els = (Element(between=(0, 1), k=k1, c=2e-4 * k1), Element(between=(1, 2), k=k2, c=2e-4 * k2))
    return MdofSystem(name="slow", masses_kg=(20.0, 2.0), elements=els, driving_point=2, rate_hz=2048.0,
                      record_s=6.0, impacts_n=(60.0,), pretrigger_s=0.1)


def test_a_slow_mode_in_the_first_bin_sets_the_cut_off_below_it() -> None:
    s = _slow_chain()
    f1 = float(np.min(s.model().natural_frequencies_hz()))
    r = mdof_impact_test(s, s.impacts_n[0], snr_db=42.0, seed=500)
    meas, _ = reduce_rate([Measurement(t=r.t, channels=r.columns(), rate_hz=r.rate_hz, mass=None,
                                       pretrigger_samples=r.pretrigger_samples, source="slow", metadata={})])
    rec = condition_all(meas, "acc2")[0][0]
    assert abs(f1 - 1.81) < 0.01
    assert rec.highpass_hz < 0.5 * f1  # 0.83 Hz (the record's floor); before: 3.0 Hz, above the mode


def test_the_sinks_slow_motion_in_the_first_bin_is_not_a_mode() -> None:
    ms, _ = reduce_rate(system_measurements(load_mdof_system("nes"), seed=100))
    cuts = [r.highpass_hz for r in condition_all(ms, "acc1")[0]]
    # the second capture's sink channel has a first-bin maximum at 2.6 % of its largest; longer
    # segments resolve its lowest peak at 7.3 Hz, not within two 1 Hz bins: not counted
    assert cuts[1] > 5.0 and cuts[2] > 5.0  # 7.25 / 7.5 Hz (counting the edge: 1.83 Hz)
