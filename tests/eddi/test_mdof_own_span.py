"""A low, large mode leaking into heavily damped modal coordinates: each equation on its own span.

Session 17 (helper s17leak, issue 14). A blind three-accelerometer set (2.5 / 15.6 / 22.5 Hz, no
mass) gave the uncoupled modal fits 2.52 / 8.89 / 10.80 Hz. Own case of that kind
(``bench_mdof_leak.py``'s t3d: 12 / 1 / 0.8 kg, m3 held to ground too, stiffness-proportional
dashpots, upper modes 7-10 % damped, a cubic spring under the heavy mass, 2048 Hz, 45 dB): the
22.5 Hz mode rings down within ~0.3 s of a 6 s window that the 2.5 Hz mode fills; over the rest
its coordinate holds noise and leaks, and phase two pulled its stiffness 8.7 % low (damping
ratio 0.001 for 0.10). Fails on the old code (8.7 % off; no ``own_span``).
"""

from __future__ import annotations

import numpy as np

from eddi.mdof.coordinates import choose_coordinates, linear_modes
from eddi.mdof.equations import fit_all, own_span
from eddi.mdof.terms import monomial
from simulated_rig.mdof_systems import MdofSystem
from station.mdof_data import condition_multichannel
from tests.eddi.mdof_target_cases import leak_system, system_measurements


def _system() -> MdofSystem:
    return leak_system("t3d")  # benchmarks/bench_mdof_leak.py's case


def _records(system: MdofSystem) -> list:
    return [condition_multichannel(m) for m in system_measurements(system, seed=700)]


def test_heavily_damped_modes_keep_their_frequency_under_a_low_large_mode():
    system = _system()
    recs = _records(system)
    truth = np.sort(system.model().natural_frequencies_hz())
    modes = linear_modes(recs, tail_fraction=0.2, driving_point=1)
    _kind, tmat, _span = choose_coordinates(recs, modes, coordinates="modal")
    fits = fit_all(recs, tmat, False, 3e-3)
    n = tmat.shape[1]
    assert n == 3
    f_id = np.array([np.sqrt(f.stiffness[monomial({i: 1}, n)]) / (2 * np.pi) for i, f in enumerate(fits)])
    err = np.abs(f_id - truth) / truth
    assert np.all(err < 0.03), (f_id, truth)
    zeta3 = fits[2].damping[monomial({2: 1}, n, rate=True)] / (2 * 2 * np.pi * f_id[2])
    assert 0.07 < zeta3 < 0.13  # true 0.099 (was 0.001)


def test_own_span_cuts_where_the_coordinate_dies_and_keeps_a_live_one():
    rate = 1000.0
    t = np.arange(4000) / rate
    live = np.exp(-0.1 * t) * np.sin(2 * np.pi * 5 * t)
    dying = np.exp(-20.0 * t) * np.sin(2 * np.pi * 40 * t) + 1e-4 * np.random.default_rng(1).standard_normal(t.size)
    q = np.vstack([live, dying])
    out = own_span(1, [(t, q, q, q)])[0]
    assert 0.2 < out[0][-1] < 0.6  # 20 dB over the floor: exp(-20 t) >= 10 * 1e-4 / 0.7 until ~0.33 s
    assert own_span(0, [(t, q, q, q)])[0][0].size == t.size
