"""An essentially nonlinear attachment (no linear stiffness, no linear mode) from accelerometers.

The rig (real numba RK4, sensor and ADC models, 45 dB) runs an energy sink of our own (other
masses, mass ratio and frequency than the built-in ``nes`` the method was measured on) whose
cubic constant is hidden from the identification. The conditioned relative displacement lacks
its slow band (the drift high-pass); the slow-band restoration (:mod:`eddi.mdof.slowband`)
must bring the attachment back as a purely cubic spring within 3 %, no mass given, and the
lumped output-error polish must predict a held-out blow on both channels within 0.05.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.mdof.lumped import Element, candidate_elements
from eddi.mdof.physical import identify_lumped
from eddi.mdof.refine import refine_identified
from eddi.mdof.slowband import slow_basis
from eddi.mdof.validate import validate_mdof
from simulated_rig.mdof_systems import MdofSystem, mdof_impact_test
from station.mdof_data import condition_multichannel
from station.readers import Measurement


def _sink(k3: float) -> MdofSystem:
    return MdofSystem.model_validate({
        "name": "hidden-sink", "masses_kg": [0.7, 0.056], "driving_point": 1, "record_s": 2.5,
        "impacts_n": [50.0, 120.0, 240.0],
        "elements": [{"between": [0, 1], "k": 30000.0, "c": 4.0},
                     {"between": [1, 2], "k3": k3, "c": 0.3}]})


def _record(system: MdofSystem, peak: float, seed: int):
    rec = mdof_impact_test(system, peak, seed=seed, snr_db=45.0)
    meas = Measurement(t=rec.t, channels=rec.columns(), rate_hz=rec.rate_hz,
                       pretrigger_samples=rec.pretrigger_samples, mass=None, source=f"{peak} N", metadata={})
    return condition_multichannel(meas)


def test_slow_basis_spans_the_band_to_the_cutoff_and_not_the_modes():
    rate, fc = 2048.0, 6.0
    b, bd = slow_basis(4096, rate, fc)
    t = np.arange(4096) / rate
    for f, tol in ((0.5 * fc, 1e-3), (fc, 2e-2)):
        y = np.sin(2 * np.pi * f * t)
        coef, *_ = np.linalg.lstsq(b, y, rcond=None)
        assert np.std(b @ coef - y) < tol * np.std(y)
        yd = 2 * np.pi * f * np.cos(2 * np.pi * f * t)
        assert np.std((bd @ coef - yd)[8:-8]) < 5 * tol * np.std(yd)
    y = np.sin(2 * np.pi * 2 * fc * t)  # the modes' band (from 4 f_c up) is not in it
    coef, *_ = np.linalg.lstsq(b, y, rcond=None)
    assert np.std(b @ coef - y) > 0.9 * np.std(y)


def test_a_hidden_energy_sink_is_found_and_predicted_with_no_mass_given():
    k3 = float(np.random.default_rng(1414).uniform(1.0e9, 3.0e9))  # hidden from the identification
    system = _sink(k3)
    train = [_record(system, p, 20 + k) for k, p in enumerate(system.impacts_n)]
    ident = identify_lumped(train, ("acc1", "acc2"), "acc1")
    consts = {(e.kind, e.a, e.b): c for e, c in ident.lumped.constants.items()}
    assert consts[("k3", 1, 2)] == pytest.approx(k3, rel=0.03)
    assert ident.model.mass == pytest.approx((0.7, 0.056), rel=0.02)
    assert consts[("k", 0, 1)] == pytest.approx(30000.0, rel=0.01)
    # the attachment has no linear spring: one, if kept, is no more than 1 % of the cubic
    # spring's force at the records' relative displacement
    z = max(float(np.max(np.abs(r.x[1] - r.x[0]))) for r in train)
    assert abs(consts.get(("k", 1, 2), 0.0)) * z < 0.01 * k3 * z**3
    assert "slow band restored" in ident.notes[0]
    held = _record(system, 170.0, 99)
    model, before, after = refine_identified(ident, train)
    assert after < before
    val = validate_mdof(model, held)
    assert max(val.channel_nrmse.values()) < 0.05, val.channel_nrmse
    assert set(candidate_elements(2)) >= set(ident.lumped.constants) and Element("k3", 1, 2) in ident.lumped.constants
