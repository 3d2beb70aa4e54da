"""An energy sink whose tails leave ERA no stable pole: the primary's mode from the struck channel.

Session 16 (issue 14 item 5). nes-5-6 of ``bench_mdof_target.py --seed 5`` (29.4 kg primary at
15.1 Hz, a 1.87 kg sink on a purely cubic spring, 20 kHz diagnosed at 4 kHz, 45 dB): the sink's
channel has no linear mode (no linear stiffness), and ERA on both channels of the three captures'
tails found no pole stable over four orders, so ``station diagnose`` stopped with exit 2 after its
folds (each fold's two captures had succeeded; old code the same). Now the poles come from the
driving-point channel alone when every channel together gives none (shapes from every channel's
residues), and the lumped fit identifies the sink: masses and cubic within 0.1 %. Fails on the
old code: IdentificationError ("ERA found no oscillating mode stable over 4 model orders").
"""

from __future__ import annotations


import numpy as np

from eddi.mdof.coordinates import linear_modes  # noqa: E402
from eddi.mdof.identify import identify_mdof  # noqa: E402
from station.mdof_data import condition_all, reduce_rate  # noqa: E402
from tests.eddi.mdof_target_cases import target_measurements  # noqa: E402


def test_the_sinks_primary_mode_comes_from_the_struck_channel():
    case, meas = target_measurements(6, 5, "nes-5-6")
    s = case.system
    records, names, dp = condition_all(reduce_rate(meas)[0], "acc1")
    modes = linear_modes(records)
    assert modes.pole_channels == (0,)
    assert abs(modes.frequencies_hz[0] / 15.10 - 1) < 0.05  # 15.64 Hz: the primary, the sink engaged a little
    final = identify_mdof(records, names, dp, coupling=True)
    assert any("from acc1 alone" in n for n in final.notes)
    m = final.model
    assert m.coordinates == "physical"
    assert np.allclose(m.mass, s.masses_kg, rtol=0.005)  # 29.368 / 1.8728 kg (29.370 / 1.8724)
    k3 = next(e.k3 for e in s.elements if e.k3)
    assert abs(m.stiffness[1]["x2^3"] / k3 - 1) < 0.01  # 6.1241e12 (6.124e12)


def test_no_pole_anywhere_is_one_line_naming_both_tries():
    import pytest

    from eddi.errors import IdentificationError
    from eddi.mdof.early import era_windows

    rng = np.random.default_rng(0)
    recs = [(rng.standard_normal((2, 3000)), 0, 3000) for _ in range(2)]
    with pytest.raises(IdentificationError, match="on every channel and on the driving-point channel alone") as err:
        era_windows(recs, 2048.0)
    assert "\n" not in str(err.value)
