"""Three-mass chains on short captures: a hidden cubic coupling named, a linear chain silent.

Session 13 (issue 14, s13three). Three coordinates give every equation 14 energy terms in the
half-cycle balance (3 dashpots, 2 linear and 9 cubic coupling monomials); a slow first mode on
one 1 s training capture has 8-10 half cycles, and the whole diagnosis was refused ("coordinate 1:
8 half cycles for 14 terms"). Such an equation is now fitted on the force balance sample by
sample (``eddi.mdof.equations.fit_equation``). Both tests fail without it (InputFileError).
"""

from __future__ import annotations

import numpy as np

from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test
from station.mdof_commands import diagnose_mdof_object

MASSES = (2.0, 1.0, 1.5)  # kg; springs 1 : 0.7 : 1.3 ground - m1 - m2 - m3, modes 8 / 20.5 / 36.7 Hz


def _chain(share: float, record_s: float) -> MdofSystem:
    """The chain with 1 % Rayleigh damping on modes 1 and 3 and a cubic spring between masses 1 and 2
    worth ``share`` of the linear spring's force at the 200 N blow."""
    ks = np.array([1.0, 0.7, 1.3]) * 19422.46
    kmat = np.diag([ks[0] + ks[1], ks[1] + ks[2], ks[2]]) - np.diag([ks[1], ks[2]], 1) - np.diag([ks[1], ks[2]], -1)
    mi = np.diag(1 / np.sqrt(MASSES))
    w = np.sqrt(np.linalg.eigvalsh(mi @ kmat @ mi))
    beta = 2 * 0.01 * (w[2] - w[0]) / (w[2] ** 2 - w[0] ** 2)
    alpha = 2 * 0.01 * w[0] - beta * w[0] ** 2
    els = [Element(between=(i, i + 1), k=float(k), c=float(beta * k)) for i, k in enumerate(ks)]
    els += [Element(between=(0, i + 1), c=float(alpha * m)) for i, m in enumerate(MASSES)]
    chain = MdofSystem(name="three", masses_kg=MASSES, elements=tuple(els), driving_point=1, rate_hz=1000.0,
                       pretrigger_s=0.02, record_s=record_s, impacts_n=(200.0, 120.0), tip="rubber")
    if share:
        x = mdof_impact_test(chain, 200.0, snr_db=None).truth_x
        k3 = share * ks[1] / float(np.max(np.abs(x[0] - x[1]))) ** 2
        els[1] = Element(between=(1, 2), k=float(ks[1]), c=els[1].c, k3=float(k3))
        chain = chain.model_copy(update={"elements": tuple(els)})
    return chain


def _diagnose(chain: MdofSystem, tmp_path) -> dict:
    files = [str(mdof_impact_test(chain, p, snr_db=45.0, seed=11 + k).write_csv(tmp_path / f"c{k}.csv"))
             for k, p in enumerate(chain.impacts_n)]
    return diagnose_mdof_object(files, driving_point="acc1", margin=0.5)


def test_a_cubic_between_masses_1_and_2_of_three_is_named_on_two_short_captures(tmp_path):
    obj = _diagnose(_chain(0.2, 1.0), tmp_path)
    assert obj["cause"] == "modal_coupling"
    assert obj["gain"] > 0.7
    # the nonlinear coupling sits between coordinates 1 and 2 only
    cubic = {t for terms in obj["coupling_terms"] for t in terms if "^" in t or "*" in t}
    assert cubic and all("3" not in t.replace("^3", "") for t in cubic), cubic
    assert max(obj["coupled"]["channel_nrmse"].values()) < 0.05


def test_the_linear_three_mass_chain_stays_none(tmp_path):
    obj = _diagnose(_chain(0.0, 1.5), tmp_path)
    assert obj["cause"] == "none"
    assert max(obj["baseline"]["channel_nrmse"].values()) < 3.5 * max(obj["noise_floor"].values())
