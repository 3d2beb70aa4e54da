"""The acceleration-only chain: from t, force, acc alone to a validated equation of motion.

Impact records: half-sine 1 ms hammer pulse, force and accelerometer with white noise at
45 dB SNR and 24-bit quantisation (``tests/eddi/impact_cases.py``), several systems.
Requirements (engine issue): k1 and k3 within 3 %, b1 within 10 %, nrmse <= 0.05.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi import EquationOfMotion
from eddi.conditioning import condition
from eddi.pipeline import identify_measurement
from simulated_rig.bench import impact_test
from tests.eddi.impact_cases import SYSTEMS, impact_record


def _check(eom: EquationOfMotion, truth: dict, nrmse: float) -> None:
    assert eom.stiffness["x"] == pytest.approx(truth["stiffness"]["x"], rel=0.03)
    assert eom.stiffness["x^3"] == pytest.approx(truth["stiffness"]["x^3"], rel=0.03)
    assert eom.damping["v"] == pytest.approx(truth["damping"]["v"], rel=0.10)
    assert nrmse <= 0.05


@pytest.mark.parametrize("system", sorted(SYSTEMS))
@pytest.mark.parametrize("seed", [1, 2])
def test_force_and_acc_only_45db(system: str, seed: int) -> None:
    spec = SYSTEMS[system]
    r = impact_record(system, snr_db=45.0, seed=seed)
    cond = condition(r.t, acc=r.acc, force=r.force)  # no pre-trigger length given: detected
    res = identify_measurement(cond, spec["mass"], damping=tuple(spec["damping"]),
                               stiffness=tuple(spec["stiffness"]))
    assert res.driven_by_force
    _check(res.model.eom, spec, res.validation.nrmse)


def test_on_the_simulated_rigs_bench_with_an_unseen_system() -> None:
    # another noise model (simulated_rig: SNR over the 99 %-energy window, 24-bit ADC,
    # 19.2 kHz, t starting at -1 s) and a system the conditioning was not tuned on
    truth = dict(mass=0.4, damping={"v": 0.9}, stiffness={"x": 3000.0, "x^3": 4.0e8})
    eom = EquationOfMotion.create(**truth)
    rec = impact_test(eom, 300.0, record_s=3.0, snr_db=45.0, force_snr_db=45.0, seed=11)
    cond = condition(rec.t, acc=rec.acc_m_s2, force=rec.force_n,
                     pretrigger_samples=rec.pretrigger_samples)
    res = identify_measurement(cond, truth["mass"], damping="v", stiffness="x,x^3")
    _check(res.model.eom, truth, res.validation.nrmse)
    w0, w1 = cond.window
    err = np.linalg.norm(cond.x[w0:w1] - rec.truth_x[w0:w1]) / np.linalg.norm(rec.truth_x[w0:w1])
    assert err < 0.01
