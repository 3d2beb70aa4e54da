"""The driving point read from the records: every modal constant is positive at the collocated
channel, and some mode's is negative elsewhere (eddi.mdof.collocation).

Own chains (not the rig's): a 1.1 / 0.4 kg pair at 18 / 50 Hz struck at either mass, 45 dB,
and three equal 0.1 kg masses at 30 dB struck in the middle.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.mdof.collocation import DEFAULTED, Collocation, collocation, driving_point_warning
from eddi.mdof.identify import linear_modes
from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test


def _records(system: MdofSystem, snr_db: float):
    from station.mdof_data import condition_multichannel
    from station.readers import Measurement

    out = []
    for k, peak in enumerate(system.impacts_n):
        r = mdof_impact_test(system, peak, seed=70 + k, snr_db=snr_db, record_s=2.0)
        out.append(condition_multichannel(Measurement(t=r.t, channels=r.columns(), rate_hz=r.rate_hz,
                                                      pretrigger_samples=r.pretrigger_samples, mass=None,
                                                      source="rig", metadata={}), "acc1"))
    return out


def _pair(drive: int) -> MdofSystem:
    k1, k2 = 2.0e4, 1.6e4
    return MdofSystem(name="pair", masses_kg=(1.1, 0.4), driving_point=drive,
                      elements=(Element(between=(0, 1), k=k1, c=1.2), Element(between=(1, 2), k=k2, c=0.6)),
                      impacts_n=(60.0, 150.0, 300.0))


@pytest.mark.parametrize("drive", [1, 2])
def test_only_the_struck_channel_has_every_modal_constant_positive(drive):
    system = _pair(drive)
    recs = _records(system, 45.0)
    modes = linear_modes(recs, driving_point=0)  # the declaration does not enter the signs
    col = collocation(modes, recs)
    assert col.collocated == tuple(c == drive - 1 for c in range(2))
    other = 2 - drive  # 0-based index of the unstruck channel
    assert col.negative[other] == (1,) and col.negative[drive - 1] == ()  # mode 2: opposite entries
    assert col.lead[drive - 1] > 5 * col.lead[other]  # the struck mass moves with the force at once
    true, wrong = system.channels[drive - 1], system.channels[other]
    assert driving_point_warning(col, system.channels, true) is None  # silence when right
    w = driving_point_warning(col, system.channels, wrong, DEFAULTED)
    assert w is not None and w.startswith(f"the records point to {true} as the driving point")
    assert f"{wrong}, the default" in w and "mode 2" in w


def test_a_three_mass_chain_struck_in_the_middle_points_to_the_middle():
    k = 4.0e3
    els = (Element(between=(0, 1), k=k, c=0.2), Element(between=(1, 2), k=1.5 * k, c=0.2),
           Element(between=(2, 3), k=0.8 * k, c=0.2))
    system = MdofSystem(name="three", masses_kg=(0.1, 0.1, 0.1), elements=els, driving_point=2,
                        impacts_n=(5.0, 12.0, 25.0))
    recs = _records(system, 30.0)
    col = collocation(linear_modes(recs, driving_point=0), recs)
    assert col.collocated == (False, True, False)
    for declared in ("acc1", "acc3"):
        w = driving_point_warning(col, system.channels, declared)
        assert w is not None and "point to acc2" in w and f"{declared}, declared," in w
    assert driving_point_warning(col, system.channels, "acc2") is None


def test_no_warning_unless_exactly_one_other_channel_is_collocated():
    base = dict(constants=np.array([[1.0, -0.5], [0.5, 0.5], [0.4, 0.3]]), frequencies_hz=np.array([10.0, 30.0]))
    ambiguous = Collocation(negative=((1,), (), ()), collocated=(False, True, True), **base)
    assert driving_point_warning(ambiguous, ("a", "b", "c"), "a") is None
    single = Collocation(negative=((1,), (), (1,)), collocated=(False, True, False), **base)
    assert "point to b" in driving_point_warning(single, ("a", "b", "c"), "a")
    uncontradicted = Collocation(negative=((), (), (1,)), collocated=(False, True, False), **base)
    assert driving_point_warning(uncontradicted, ("a", "b", "c"), "a") is None
    assert driving_point_warning(None, ("a", "b"), "a") is None
    # the blow's start must agree: the pointed channel moves with the force more than the declared one
    led = Collocation(negative=((1,), (), (1,)), collocated=(False, True, False), lead=np.array([0.9, 1.1, 0.1]),
                      **base)
    assert "moves with the force during the blow" in driving_point_warning(led, ("a", "b", "c"), "a")
    lagging = Collocation(negative=((1,), (), (1,)), collocated=(False, True, False), lead=np.array([0.9, 0.05, 0.1]),
                          **base)
    assert driving_point_warning(lagging, ("a", "b", "c"), "a") is None
