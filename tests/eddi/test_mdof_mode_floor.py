"""Per-mode noise floors and the coupling earned in one mode (:mod:`eddi.mdof.modefloor`): exact cuts."""

import numpy as np

from eddi.mdof.modefloor import (BASE_OVER, COUPLED_WITHIN, MODE_MIN_FLOOR, ModeFold, judge_modes, mode_errors,
                                 mode_floor, projector)
from eddi.mdof.records import ChannelRecord
from eddi.mdof.validate import noise_floor


def _fold(b, c, fl=(0.012, 0.02, 0.02), ablated=None):
    """One fold; ``ablated`` (the coupled model without its coupling terms) as bad as the baseline
    unless given."""
    return ModeFold(tuple(b), tuple(c), tuple(fl), (1e-7,) * len(fl), (10.0, 30.0, 60.0)[:len(fl)],
                    tuple(b if ablated is None else ablated))


def _m2_like(q3c=(0.040, 0.036, 0.038)):
    """The blind M2 profile: mode 1 at its floor for both, modes 2-3 0.060 -> 0.036 and 0.109 -> 0.038."""
    return [_fold((0.014, 0.058, 0.105), (0.0135, 0.036, q3c[0])),
            _fold((0.015, 0.062, 0.112), (0.0140, 0.035, q3c[1])),
            _fold((0.013, 0.060, 0.110), (0.0130, 0.037, q3c[2]))]


def test_m2_profile_is_earned_in_mode_3():
    j = judge_modes(_m2_like(), 0.5)
    assert j.earned and j.mode == 2
    assert j.better_folds == (2, 3, 3)  # mode 1: a ratio of errors at the floor (not judged as a gain)
    assert round(j.excess_gain[2], 3) == 0.699
    assert 0.4 < j.excess_gain[1] < 0.5  # mode 2 alone would not do
    assert abs(j.excess_gain[0]) < 0.2 and j.baseline[0] < BASE_OVER * j.floor[0]  # mode 1 at its floor: not judged


def test_each_cut_alone_refuses():
    # the coupled model worse on mode 3 in one fold
    assert not judge_modes(_m2_like(q3c=(0.040, 0.120, 0.038)), 0.5).earned
    # the baseline within BASE_OVER of the mode's floor: every mode at the floor (a null)
    null = [_fold((0.9 * BASE_OVER * 0.012, 0.025, 0.028), (0.012, 0.02, 0.02)) for _ in range(3)]
    assert not judge_modes(null, 0.5).earned
    # the coupled model above COUPLED_WITHIN x the mode's floor
    high = 1.01 * COUPLED_WITHIN * 0.02
    far = [_fold((0.014, 0.06, 0.3), (0.0135, 0.036, high)) for _ in range(3)]
    assert not judge_modes(far, 0.5).earned
    # another mode made worse (excess gain below -margin)
    worse = [_fold((0.014, 0.06, 0.105), (0.05, 0.036, 0.038)) for _ in range(3)]
    assert not judge_modes(worse, 0.5).earned
    # the gain is not the coupling's: without its coupling terms the coupled model does as well on mode 3
    # (a better linear part than the baseline's, as the tuning null t2-nulln of bench_mdof_nulls.py)
    lin = [_fold(f.baseline, f.coupled, ablated=(f.coupled[0], f.coupled[1], 1.1 * f.coupled[2])) for f in _m2_like()]
    assert not judge_modes(lin, 0.5).earned
    assert judge_modes(lin, 0.5).coupling_gain[2] < 0.5
    # a fold whose prediction diverged
    div = _m2_like()
    div[1] = _fold((0.015, 0.062, 0.112), (np.inf, np.inf, np.inf))
    assert not judge_modes(div, 0.5).earned


def test_a_weak_mode_sees_the_channels_noise_through_the_inverse_shapes():
    """Two channels, mode 1 strong (in phase), mode 2 weak (antiphase, 1/20 of the motion): the
    floor of mode 2 is the channels' noise through P's second row against mode 2's small motion."""
    rate, n = 2000.0, 4000
    t = np.arange(n) / rate
    psi = np.array([[1.0, 1.0], [0.8, -0.9]])
    q = np.vstack([np.sin(2 * np.pi * 10 * t), 0.05 * np.sin(2 * np.pi * 37 * t)])
    x = psi @ q
    a = -psi @ (q * np.array([[(2 * np.pi * 10) ** 2], [(2 * np.pi * 37) ** 2]]))
    rec = ChannelRecord(t=t, x=x, v=np.zeros_like(x), a=a, force=None, impact=(0, 0), window=(0, n),
                        noise=np.array([1e-3, 1e-3]), highpass_hz=2.5)
    proj = projector(psi)
    fl, s = mode_floor(rec, proj)
    s_c = noise_floor(rec) * np.sqrt(np.mean(x**2, axis=1))
    expect = np.sqrt((proj**2) @ s_c**2) / np.sqrt(np.mean(q**2, axis=1))
    assert np.allclose(s, np.sqrt((proj**2) @ s_c**2))
    assert np.allclose(fl, np.maximum(expect, MODE_MIN_FLOOR))
    assert fl[1] > 5 * np.max(noise_floor(rec))  # the weak mode's floor is far above any channel's


def test_mode_errors_in_one_basis():
    psi = np.array([[1.0, 1.0], [0.8, -0.9]])
    t = np.linspace(0, 1, 500)
    q = np.vstack([np.sin(2 * np.pi * 5 * t), 0.1 * np.cos(2 * np.pi * 17 * t)])
    meas = psi @ q
    sim = psi @ (q * np.array([[1.0], [0.9]]))  # mode 2 10 % low, mode 1 exact
    e = mode_errors(meas, sim, projector(psi))
    assert np.allclose(e, [0.0, 0.1], atol=1e-12)
    assert np.all(np.isinf(mode_errors(meas, sim, projector(psi), diverged=True)))


def test_without_coupling_drops_the_nonlinear_terms_between_coordinates_only():
    from eddi.mdof.model import MdofModel
    from eddi.mdof.modefloor import without_coupling

    m = MdofModel(coordinates="physical", mass=(1.0, 0.2), input=(1.0, 0.0),
                  damping=({"v1": 0.5, "v2": -0.1}, {"v2": 0.2, "v1": -0.1}),
                  stiffness=({"x1": 4e4, "x2": -1e4, "x1^3": 1e9, "x1^2*x2": -3e9},
                             {"x2": 5e4, "x1": -5e4, "x1*x2^2": 1.5e10, "x2^3": -5e9}),
                  channels=("acc1", "acc2"), shapes=((1.0, 0.0), (0.0, 1.0)), driving_point="acc1")
    w = without_coupling(m)
    assert w.stiffness == ({"x1": 4e4, "x2": -1e4, "x1^3": 1e9}, {"x2": 5e4, "x1": -5e4, "x2^3": -5e9})
    assert w.damping == m.damping and w.stiffness_ci95 == ()
