"""A three-mass chain with a hidden nonlinear coupling spring: found, from acc only, no mass given.

The rig (numba RK4 of the coupled equations, sensor and ADC models, 45 dB per channel) strikes a
3 / 0.4 / 1.2 kg chain (modes 14, 37, 60 Hz) whose cubic coupling spring sits between masses 1-2
or 2-3 (which one, and its constant, hidden from the identification). The lumped-element fit
(:func:`eddi.mdof.physical.identify_lumped`, EDDI alone: no output-error polish) must put the
cubic spring between the right masses and nowhere else, within 4 %, the masses within 2 %, and
predict a fourth blow on every channel within 0.08 nrmse (the issue's 0.05 is met by the polished
model that ``station diagnose`` saves, not by EDDI alone on the 1-2 coupling: 0.063-0.067). Session 10: with the slow band
restored only to the cut-off, the doubly integrated accelerometer noise biased the cubic springs
low (errors in the variables; -8.4 % and a held-out 0.12 on this chain with two cubic springs);
the wider slow basis (:data:`eddi.mdof.physical.SLOW_KNOTS`) is what passes.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.mdof.physical import identify_lumped
from eddi.mdof.validate import validate_mdof
from simulated_rig.mdof_systems import MdofSystem, mdof_impact_test
from station.mdof_data import condition_multichannel
from station.readers import Measurement

CHANNELS = ("acc1", "acc2", "acc3")


def _system(pair: tuple[int, int], k3: float) -> MdofSystem:
    springs = {(0, 1): (1.5e5, 8.0), (1, 2): (2e4, 1.0), (2, 3): (3e4, 1.5)}
    return MdofSystem.model_validate({
        "name": "hidden-chain", "masses_kg": [3.0, 0.4, 1.2], "driving_point": 1, "rate_hz": 2000.0,
        "record_s": 3.0, "impacts_n": [60.0, 160.0, 320.0],
        "elements": [{"between": list(b), "k": k, "c": c, "k3": k3 if b == pair else 0.0}
                     for b, (k, c) in springs.items()]})


def _conditioned(system: MdofSystem, peak: float, seed: int):
    rec = mdof_impact_test(system, peak, seed=seed, snr_db=45.0)
    meas = Measurement(t=rec.t, channels=rec.columns(), rate_hz=rec.rate_hz,
                       pretrigger_samples=rec.pretrigger_samples, mass=None, source=f"{peak} N", metadata={})
    return condition_multichannel(meas)


@pytest.mark.parametrize("draw", [0, 1])
def test_a_hidden_cubic_coupling_in_a_three_mass_chain_is_found_where_it_is(draw):
    rng = np.random.default_rng(1410 + draw)
    pair = [(1, 2), (2, 3)][draw]  # which coupling is nonlinear, and how strong: hidden
    k3 = float(rng.uniform(4e9, 9e9))
    system = _system(pair, k3)
    records = [_conditioned(system, p, seed=3 + k) for k, p in enumerate(system.impacts_n)]
    ident = identify_lumped(records, CHANNELS, "acc1")
    cubic = {(e.a, e.b): c for e, c in ident.lumped.constants.items() if e.kind == "k3"}
    assert cubic.get(pair) == pytest.approx(k3, rel=0.04)
    # nowhere else: a spurious cubic spring would carry part of the coupling's force
    assert all(abs(c) < 0.03 * k3 for b, c in cubic.items() if b != pair)
    assert ident.model.mass == pytest.approx((3.0, 0.4, 1.2), rel=0.02)
    held = validate_mdof(ident.model, _conditioned(system, 200.0, seed=50))
    assert not held.diverged
    # EDDI alone (the polish takes it to the true model's level); 0.12 with the old slow band
    assert max(held.channel_nrmse.values()) <= 0.08


def test_a_struck_mass_on_a_stiff_ground_spring_keeps_the_lumped_chain_by_instrumental_variables():
    # session 11: 1 / 0.6 / 1.4 kg, the struck mass on a stiff ground spring (its displacement's
    # noise floor 1.8x the others'), a soft middle spring with a cubic at 25 % of its force at the
    # largest blow. Least squares on the noisy displacement (errors in the variables) scaled the
    # chain beyond the struck mass by about -1 % and left a training nrmse of 0.12 (4x the floor;
    # modal coordinates then won); refitted with instruments from the simulated model, 0.024
    system = MdofSystem.model_validate({
        "name": "stiff-ground", "masses_kg": [1.0, 0.6, 1.4], "driving_point": 1, "rate_hz": 4000.0,
        "record_s": 3.0, "impacts_n": [50.0, 140.0, 300.0],
        "elements": [{"between": [0, 1], "k": 6e4, "c": 4.0}, {"between": [1, 2], "k": 1.2e4, "c": 0.8, "k3": 5.807e8},
                     {"between": [2, 3], "k": 2.5e4, "c": 1.5, "k3": 3.007e8}]})
    from eddi.mdof.candidates import records_floor, training_error

    records = [_conditioned(system, p, seed=7 + k) for k, p in enumerate(system.impacts_n)]
    ident = identify_lumped(records, CHANNELS, "acc1")
    assert training_error(ident.model, records) <= 2.0 * records_floor(records)  # 0.122 without
    assert "instrumental variables from the simulated model" in ident.notes[0]  # the fit kept
    assert ident.model.mass == pytest.approx((1.0, 0.6, 1.4), rel=0.006)
    # the soft middle spring's cubic scatters with the noise (-9 .. +2 % over seeds 3 / 7 / 11 by
    # the CSV path; least squares -6 .. -1 %): placed right, not to 3 %
    cubic = {(e.a, e.b): c for e, c in ident.lumped.constants.items() if e.kind == "k3"}
    assert set(cubic) == {(1, 2), (2, 3)}
    assert cubic[(1, 2)] == pytest.approx(5.807e8, rel=0.1) and cubic[(2, 3)] == pytest.approx(3.007e8, rel=0.03)
