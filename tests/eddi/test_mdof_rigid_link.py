"""A coupling the records do not determine is not kept (a nearly rigid link).

Held-out case c2-3 of ``bench_mdof_wide.py --seed 2`` (session 12): 7.1 + 1.0 kg, the link 5x
stiffer than the ground spring, a cubic spring to the ground on mass 1; the diagnosis named
``modal_coupling`` on a cubic spring between the masses that is not there. The relative
displacement ``x1 - x2`` is 3 % of ``x1`` (RMS), so a cubic spring across the link has a column
~1e-5 of the ground cubic's, made of the displacements' noise; with rows from 0.6 periods after
the blow it came out at -1.2e14 +- 3.4e15 N/m^3 (interval 28x the value) beside the true k3(0-1)
and a second mass of 1e-5 kg. Now the fit drops a nonlinear element between masses whose 95 %
interval holds zero (``eddi.mdof.lumped.undetermined_couplings``). Fails before the rule (on
these records, rows from 1.0 periods keep k3(1-2)).
"""

from __future__ import annotations

import numpy as np

from eddi.mdof.lumped import fit_lumped
from eddi.mdof.physical import _pulses, _rows
from simulated_rig.mdof_systems import MdofSystem, mdof_impact_test
from station.mdof_data import condition_multichannel
from station.readers import Measurement


def _records() -> list:
    # c2-3's system (rounded), fewer and shorter records
    system = MdofSystem.model_validate({
        "name": "rigid-link", "masses_kg": [7.127, 0.9852], "driving_point": 1, "rate_hz": 10000.0,
        "record_s": 1.0, "pretrigger_s": 0.01, "impacts_n": [160.0, 200.0, 293.0], "tip": "plastic",
        "elements": [{"between": [0, 1], "k": 3.84e5, "k3": 7.9e12, "c": 51.0},
                     {"between": [1, 2], "k": 2.04e6, "c": 272.0}]})
    out = []
    for k, peak in enumerate(system.impacts_n):
        rec = mdof_impact_test(system, peak, seed=100 + k, snr_db=48.6)
        meas = Measurement(t=rec.t, channels=rec.columns(), rate_hz=rec.rate_hz,
                           pretrigger_samples=rec.pretrigger_samples, mass=None, source=f"{peak} N", metadata={})
        out.append(condition_multichannel(meas))
    return out


def test_no_undetermined_coupling_is_kept_on_a_nearly_rigid_link():
    records = _records()
    for settle in (0.0, 0.6, 1.0):
        fit = fit_lumped(_rows(records, settle), _pulses(records), 2, 0)
        loose = [e.label for e, c in fit.constants.items()
                 if e.a > 0 and e.kind != "c" and e.kind != "k" and not abs(c) > fit.ci95[e]]
        assert loose == [], (settle, {e.label: (c, fit.ci95[e]) for e, c in fit.constants.items()})
        # the true cubic to the ground is kept and determined
        ground = {e.label: (c, fit.ci95[e]) for e, c in fit.constants.items()}["k3(0-1)"]
        assert abs(ground[0]) > 10 * ground[1] and np.isfinite(ground[1])
