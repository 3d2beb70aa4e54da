"""Multi-channel captures sampled far above their modes are diagnosed at a working rate
(:mod:`eddi.mdof.rate`, :func:`station.mdof_data.reduce_rate`), and the MDOF folds give the
same JSON in forked workers as in turn."""

from __future__ import annotations

import json

import numpy as np

from eddi.mdof.rate import SAMPLES_PER_PERIOD, block_mean, highest_mode_hz, reduction_factor
from simulated_rig.mdof_systems import load_mdof_system, mdof_impact_test
from station.cli import main
from station.mdof_data import reduce_rate
from station.readers import Measurement


def _measurement(rec) -> Measurement:
    return Measurement(t=rec.t, channels=rec.columns(), rate_hz=rec.rate_hz, pretrigger_samples=rec.pretrigger_samples,
                       mass=None, source=f"rig {rec.peak_force_n:g} N", metadata={})


def test_fast_captures_are_reduced_by_block_means_and_native_ones_are_kept():
    chain = load_mdof_system("two-mass-cubic")  # linear modes 23.4 / 49.4 Hz
    fast = [mdof_impact_test(chain, p, seed=3 + k, record_s=1.0, rate_hz=16384.0) for k, p in enumerate((60.0, 200.0))]
    top = highest_mode_hz(fast[1].acc_m_s2[:, fast[1].pretrigger_samples:], 16384.0, "acc")
    assert 49.0 <= top <= 56.0  # the upper mode (stiffened a little by the cubic at 200 N)
    d = reduction_factor(16384.0, top)
    assert d == int(16384.0 // (SAMPLES_PER_PERIOD * top)) and d >= 5
    meas = [_measurement(r) for r in fast]
    out, note = reduce_rate(meas)
    assert note is not None and "16384 Hz" in note and f"means of {d} samples" in note
    for m, r in zip(out, meas):
        assert m.rate_hz == r.rate_hz / d and m.pretrigger_samples == r.pretrigger_samples // d
        n = (r.t.size // d) * d
        assert np.allclose(m.t, r.t[:n].reshape(-1, d).mean(axis=1), rtol=0, atol=1e-12)  # blocks' centres
        # the hammer's impulse is kept (the pulse lies well inside the record)
        assert np.isclose(np.sum(m.channels["force"]) / m.rate_hz, np.sum(r.channels["force"][:n]) / r.rate_hz,
                          rtol=1e-12)
        assert np.allclose(m.channels["acc2"], block_mean(r.channels["acc2"], d))
    native = [_measurement(mdof_impact_test(chain, 150.0, seed=1, record_s=1.0))]  # 2048 Hz: 41 per period
    kept, none = reduce_rate(native)
    assert none is None and kept[0] is native[0]
    assert reduction_factor(2048.0, 0.0) == 1 and reduction_factor(1000.0, 400.0) == 1


def test_a_fast_sampled_chain_is_diagnosed_at_the_working_rate_the_same_in_forked_workers(tmp_path, capsys,
                                                                                         monkeypatch):
    chain = load_mdof_system("two-mass-cubic")
    files = [str(mdof_impact_test(chain, p, seed=20 + k, record_s=1.5, rate_hz=12288.0)
                 .write_csv(tmp_path / f"c{k}.csv")) for k, p in enumerate(chain.impacts_n)]
    runs = []
    for env in ({"STATION_SERIAL": "1"}, {"STATION_JOBS": "2"}):
        monkeypatch.delenv("STATION_SERIAL", raising=False)
        monkeypatch.delenv("STATION_JOBS", raising=False)
        for k, v in env.items():
            monkeypatch.setenv(k, v)
        assert main(["diagnose", *files, "--json", "--no-refine"]) == 0
        runs.append(json.loads(capsys.readouterr().out))
    serial, forked = runs
    assert serial == forked
    assert serial["cause"] == "modal_coupling"
    assert any("captures at 12288 Hz diagnosed at" in n and "samples per period" in n for n in serial["notes"])
    # held out at the working rate: every channel within 0.05 (the figure)
    assert max(serial["coupled"]["channel_nrmse"].values()) < 0.05


def test_the_reduction_leaves_the_pre_trigger_enough_samples_of_rest():
    """Session 11: a short pre-trigger at a high rate (5 ms at 16384 Hz: 82 samples) under block
    means of 19 or more kept 4 samples of rest or fewer (a 2 Hz chain at 10 kHz, 50 samples under
    means of 43, kept one), and the conditioning then read the noise from the record's still-ringing
    end (that chain was refused "free decays too short for ERA"). The factor is now capped so that
    at least REST_KEPT (9) samples of rest remain; fails without."""
    from dataclasses import replace

    from station.mdof_data import REST_KEPT

    chain = load_mdof_system("two-mass-cubic").model_copy(update={"pretrigger_s": 0.005})
    rec = mdof_impact_test(chain, 150.0, seed=5, record_s=1.0, rate_hz=16384.0)
    meas = _measurement(rec)
    assert meas.pretrigger_samples == 82
    # the factor the modes alone would ask, at the budget's floor (as a long record would)
    top = highest_mode_hz(rec.acc_m_s2[:, rec.pretrigger_samples:], 16384.0, "acc")
    want = reduction_factor(16384.0, top, 16.0)
    assert want >= 19
    out, note = reduce_rate([meas], samples_per_period=16.0)
    assert out[0].pretrigger_samples >= REST_KEPT
    assert out[0].rate_hz == 16384.0 / (82 // REST_KEPT)
    assert "samples of rest" in note and f"means of {want} wanted" in note
    # a capture without a pre-trigger (the blow at the first sample) is reduced as before
    bare = replace(meas, t=meas.t[82:] - meas.t[82], channels={k: v[82:] for k, v in meas.channels.items()},
                   pretrigger_samples=0)
    out, note = reduce_rate([bare], samples_per_period=16.0)
    assert out[0].rate_hz == 16384.0 / want and "samples of rest" not in note
