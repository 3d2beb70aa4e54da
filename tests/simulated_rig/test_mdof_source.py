"""The live multi-DOF rig source: force + one accelerometer per mass, in sample time."""

from __future__ import annotations

import json

import numpy as np
import pytest

from eddi.mdof.simulate import simulate_mdof
from simulated_rig.errors import ScenarioError
from simulated_rig.hammer import hammer_force
from simulated_rig.mdof_source import IMPACT_DELAY_S, MdofRigSource
from simulated_rig.serve import build_firmware


@pytest.fixture(scope="module")
def source() -> MdofRigSource:
    return MdofRigSource.from_system("two-mass-cubic", seed=4)


def test_a_blow_streams_the_coupled_ring_down_of_every_mass(source):
    src = MdofRigSource(source.system, source.sensors, seed=4)
    rate = src.rate_hz
    rest = src.read(300)
    src.deliver_impact(200.0)
    counts = src.read(int(3.5 * rate))  # across three 1-s simulation chunks
    si = np.column_stack([c.to_si(counts[:, j]) for j, c in enumerate(src.channels)])
    start = 300 + int(round(IMPACT_DELAY_S * rate))
    n = counts.shape[0] - (start - 300) + 1
    t = (np.arange(n) - 1) / rate
    force = hammer_force(t, 200.0, src.hammer)
    truth = simulate_mdof(src.model, t, force, x_scale=np.full(2, 1e-3))
    noise = np.array([src.noise_rms[c.name] for c in src.channels])
    got = si[start - 300 - 1:]
    assert [c.name for c in src.channels] == ["force", "acc1", "acc2"]
    for j in (1, 2):  # every accelerometer follows the coupled truth to its noise
        resid = got[:, j] - truth.a[j - 1]
        assert np.std(resid) < 1.2 * noise[j]
        assert np.max(np.abs(truth.a[j - 1])) > 100 * noise[j]
    assert np.std(got[:, 0] - force) < 1.5 * noise[0] + src.channels[0].scale  # the pulse, sample by sample
    at_rest = rest[:, 1:] * np.array([c.scale for c in src.channels[1:]])
    assert np.all(np.abs(np.std(at_rest, axis=0) / noise[1:] - 1) < 0.15)  # before the blow: sensor noise


def test_rest_after_the_ring_down_and_only_the_system_rate(source):
    src = MdofRigSource(source.system, source.sensors, seed=5)
    src.deliver_impact(50.0)
    src.read(int(40 * src.rate_hz))  # the ring-down ends: the source snaps to rest
    tail = src.read(2048)
    noise = np.array([src.noise_rms[c.name] for c in src.channels[1:]])
    assert np.all(np.std(tail[:, 1:] * [c.scale for c in src.channels[1:]], axis=0) < 1.2 * noise)
    with pytest.raises(ScenarioError):
        src.configure(rate_hz=1000.0)
    with pytest.raises(ScenarioError):
        src.deliver_impact(-1.0)


def test_firmware_of_an_mdof_system_reports_its_channels_and_driving_point():
    fw = build_firmware("internal-1-3", seed=1)
    info = fw.info()
    assert [c["name"] for c in info["channels"]] == ["force", "acc1", "acc2"]
    scen = json.loads(info["scenario"])
    assert scen["driving_point"] == "acc1" and scen["impacts"] == [40.0, 120.0, 250.0]
    with pytest.raises(ScenarioError, match="known: .*two-mass-cubic"):
        build_firmware("no-such-system")
