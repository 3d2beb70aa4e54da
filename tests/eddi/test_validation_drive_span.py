"""The driven validation forms its drive over the simulated span only (session 18): the same
numbers bit for bit as the whole record's drive sliced, with and without the DAQ kernel's
correction, fused or the force sensor alone, scaled or not; and simulate_dense's end of the blow."""

from __future__ import annotations

import importlib
from dataclasses import replace

import numpy as np
import pytest

from eddi.driven_validation import fused_impact_force, unsharpened, validate_conditioned
from eddi.fit_record import Pipeline
from eddi.validate import validate
from simulated_rig.bench import impact_test

sim_mod = importlib.import_module("eddi.simulate")


@pytest.fixture(scope="module")
def record():
    rec = impact_test("duffing-smooth", 600.0, snr_db=45.0, seed=3, rate_hz=4000.0, record_s=6.0)
    pipe = Pipeline.create("v,x^2*v,v^3", "x,x^2,x^3")
    cond = pipe.condition(rec.t, acc=rec.acc_m_s2, force=rec.force_n, pretrigger_samples=rec.pretrigger_samples)
    model = pipe.fit(cond, 0.815).model.eom
    return cond, model


def _whole_drive_validation(eom, cond, fused=True, drive_scale=1.0):
    """validate_conditioned's driven branch as it was: the whole record's drive, then sliced."""
    s, e = cond.impact_start, cond.free_stop
    drive = fused_impact_force(cond, eom) if (cond.acc_measured and fused) else cond.impact_force
    if cond.sample_kernel_var > 0:
        drive = unsharpened(drive, cond.sample_kernel_var)
        s = max(0, s - 1)
    if drive_scale != 1.0:
        drive = drive * drive_scale
    return validate(eom, cond.t[s:e], cond.x[s:e], v=cond.v[s:e], force=drive[s:e],
                    window=(cond.free_start - s, cond.free_stop - s))


@pytest.mark.parametrize("kernel_var", [0.0, 0.25])
@pytest.mark.parametrize("fused", [True, False])
@pytest.mark.parametrize("scale", [1.0, 1.03])
def test_the_span_drive_validates_as_the_whole_drive(record, kernel_var, fused, scale):
    cond, eom = record
    cond = replace(cond, sample_kernel_var=kernel_var)
    got, by_force = validate_conditioned(eom, cond, fused, drive_scale=scale)
    want = _whole_drive_validation(eom, cond, fused, scale)
    assert by_force
    assert got.nrmse == want.nrmse and got.nmte == want.nmte and got.warnings == want.warnings
    assert np.array_equal(got.x_simulated, want.x_simulated) and np.array_equal(got.v_simulated, want.v_simulated)


@pytest.mark.parametrize("span", [(0, None), (5, 40), ("start", "stop"), ("mid", None), (0, 3)])
def test_fused_force_over_a_span_is_the_whole_arrays_slice(record, span):
    cond, eom = record
    whole = fused_impact_force(cond, eom)
    n = whole.size
    named = {"start": cond.impact_start, "stop": cond.free_stop, "mid": (cond.impact_start + cond.impact_end) // 2}
    lo = named.get(span[0], span[0])
    hi = n if span[1] is None else named.get(span[1], span[1])
    part = fused_impact_force(cond, eom, span=(lo, hi))
    assert part.shape == (hi - lo,) and np.array_equal(part, whole[lo:hi])


def test_end_of_force():
    end = sim_mod._end_of_force
    assert end(np.zeros(0)) == 0
    assert end(np.zeros(7)) == 0
    f = np.zeros(10)
    f[3] = 2.0
    assert end(f) == 4
    f[9] = -1.0
    assert end(f) == 10
    f[9], f[6] = 0.0, np.nan  # as np.flatnonzero(f != 0) did: NaN counts as non-zero
    assert end(f) == 7
