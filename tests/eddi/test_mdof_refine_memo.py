"""The polish's simulation memo (eddi.mdof.refine): the same residuals, one simulation per parameter vector."""

from __future__ import annotations

import numpy as np

from eddi.mdof.refine import _residual_function, _with
from simulated_rig.mdof_systems import MdofSystem, mdof_impact_test
from station.mdof_data import condition_multichannel
from station.readers import Measurement


def _records() -> tuple[MdofSystem, list]:
    system = MdofSystem.model_validate({
        "name": "memo", "masses_kg": [0.8, 0.3], "driving_point": 1, "record_s": 1.0,
        "impacts_n": [60.0, 200.0],
        "elements": [{"between": [0, 1], "k": 35000.0, "c": 5.0},
                     {"between": [1, 2], "k": 15000.0, "k3": 1.3e10, "c": 1.5}]})
    out = []
    for k, peak in enumerate(system.impacts_n):
        rec = mdof_impact_test(system, peak, seed=3 + k, snr_db=45.0)
        meas = Measurement(t=rec.t, channels=rec.columns(), rate_hz=rec.rate_hz,
                           pretrigger_samples=rec.pretrigger_samples, mass=None, source=f"{peak} N", metadata={})
        out.append(condition_multichannel(meas))
    return system, out


def test_memoised_residuals_equal_fresh_ones_across_horizons_with_one_simulation_per_vector():
    system, records = _records()
    model = system.model()
    n_par = sum(len(d) + len(s) for d, s in zip(model.damping, model.stiffness))
    builds: list[bytes] = []

    def build(p: np.ndarray):
        builds.append(np.asarray(p).tobytes())
        return _with(model, p)

    memo: dict = {}
    rng = np.random.default_rng(0)
    vectors = [np.zeros(n_par), 0.02 * rng.standard_normal(n_par)]
    for horizon in (0.2, 1.0):
        cached, sizes = _residual_function(records, build, horizon, memo)
        fresh, sizes_fresh = _residual_function(records, lambda p: _with(model, p), horizon)
        assert sizes == sizes_fresh
        for p in vectors:
            got, want = cached(p.copy()), fresh(p)
            assert got.shape == want.shape and np.array_equal(got, want)
            assert np.max(np.abs(want)) > 0
    # two vectors, two horizons: each vector simulated once, the second horizon from the memo
    assert len(builds) == 2 and len(set(builds)) == 2
    assert len(memo) == 2
