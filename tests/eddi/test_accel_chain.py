"""The acceleration-only chain: from t, force, acc alone to a validated equation of motion.

Impact records: half-sine 1 ms hammer pulse, force and accelerometer with white noise at
45 dB SNR and 24-bit quantisation (``tests/eddi/impact_cases.py``), several systems.
Requirements (engine issue): k1 and k3 within 3 %, b1 within 10 %, nrmse <= 0.05.
With the output-error refinement (``refine=True``) the same records give k1, k3 within
0.1 %, b1 within 0.5 %, and errors well below half of SINDy's on the same signals.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi import EquationOfMotion
from eddi.conditioning import condition
from eddi.identify import identify
from eddi.fit_record import identify_measurement
from eddi.sindy import sindy_identify
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
                               stiffness=tuple(spec["stiffness"]), refine=False)
    assert res.driven_by_force
    _check(res.model.eom, spec, res.validation.nrmse)
    assert res.model.unrefined is None and res.model.refinement is None
    ref = identify_measurement(cond, spec["mass"], damping=tuple(spec["damping"]),
                               stiffness=tuple(spec["stiffness"]), refine=True)
    # the EDDI estimate that seeded the refinement is kept beside the refined one; since session 13
    # (s13ident) it is the Lagrangian route's on a coarser grid, no longer bit for bit the scored
    # pipeline's (docs/speed.md), and as accurate as EDDI is
    seed_eom = ref.model.unrefined
    assert seed_eom is not None
    _check(seed_eom, spec, 0.0)
    eom = ref.model.eom
    assert eom.stiffness["x"] == pytest.approx(spec["stiffness"]["x"], rel=1e-3)
    assert eom.stiffness["x^3"] == pytest.approx(spec["stiffness"]["x^3"], rel=1e-3)
    assert eom.damping["v"] == pytest.approx(spec["damping"]["v"], rel=5e-3)
    assert ref.validation.nrmse <= 0.01
    assert ref.model.refinement.channel == "a"
    assert ref.model.refinement.nrmse_after <= ref.model.refinement.nrmse_before
    # the refined model is kept unless it fits the measured acceleration measurably worse
    # (eddi.judge): here it never does. Judged on the nominal drive with no margin, paper_do
    # seed 1's refinement was rejected (EDDI then at the noise floor, 9e-5)
    assert ref.choices.refinement == "kept"
    assert ref.choices.nrmse_refined <= 1.01 * ref.choices.nrmse_eddi


def _coef_error(eom: EquationOfMotion, truth: dict) -> float:
    return float(np.mean([abs(getattr(eom, g)[term] / c - 1)
                          for g in ("damping", "stiffness") for term, c in truth[g].items()]))


def test_refined_eddi_error_is_below_half_of_sindys_at_30db() -> None:
    # benchmarks/bench_accel_chain.py in small: same conditioned signals, same terms, the
    # paper's SINDy threshold 0.05 (paper Sec. 3.3.1)
    errs: dict[str, list[float]] = {"eddi": [], "refined": [], "sindy_paper": [], "sindy_a": []}
    for system, spec in sorted(SYSTEMS.items()):
        r = impact_record(system, snr_db=30.0, seed=1)
        cond = condition(r.t, acc=r.acc, force=r.force)
        w0, w1 = cond.window
        tw, xw, vw, aw = cond.t[w0:w1], cond.x[w0:w1], cond.v[w0:w1], cond.a[w0:w1]
        d, k, m = tuple(spec["damping"]), tuple(spec["stiffness"]), spec["mass"]
        model = identify(tw, xw, vw, m, damping=d, stiffness=k, a=aw, refine=True)
        errs["eddi"].append(_coef_error(model.unrefined, spec))
        errs["refined"].append(_coef_error(model.eom, spec))
        errs["sindy_paper"].append(_coef_error(sindy_identify(tw, xw, vw, None, m, d, k, 0.05), spec))
        errs["sindy_a"].append(_coef_error(sindy_identify(tw, xw, vw, aw, m, d, k, 0.05), spec))
    total = {key: sum(v) for key, v in errs.items()}
    assert total["refined"] <= 0.5 * total["sindy_a"]
    assert total["refined"] <= 0.5 * total["sindy_paper"]
    assert all(e < s for e, s in zip(errs["refined"], errs["sindy_a"]))
    # refinement helps on every record (unrefined EDDI is ~2x worse than SINDy here: see
    # docs/eddi-method.md)
    assert all(e < u for e, u in zip(errs["refined"], errs["eddi"]))


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
