"""The linear modal step (ERA with a stabilisation diagram) on noisy multi-channel free decays.

Cases of their own (not the rig's systems): a three-mass chain with a cubic spring at 30 dB,
synthetic decays with a mode left out, and a sink-like channel no linear mode describes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddi.errors import IdentificationError
from eddi.mdof.identify import ChannelRecord, linear_modes, modal_evidence
from eddi.mdof.modal import era


def _decays(freqs, zetas, shapes, amps, rate, n, snr_db, seed):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    y = np.zeros((shapes.shape[0], n))
    for f, z, a, k in zip(freqs, zetas, amps, range(len(freqs))):
        wn = 2 * math.pi * f
        y += a * shapes[:, k:k + 1] * (np.exp(-z * wn * t) * np.cos(wn * math.sqrt(1 - z * z) * t + 0.3 * k))[None, :]
    noise = np.max(np.abs(y)) * 10 ** (-snr_db / 20)
    return y + noise * rng.standard_normal(y.shape)


SHAPES3 = np.array([[0.33, 0.74, 0.59], [0.59, 0.33, -0.74], [0.74, -0.59, 0.33]])


@pytest.mark.parametrize("snr_db", [30.0, 60.0])
def test_three_modes_of_three_channels_at_30_and_60_db(snr_db):
    freqs, zetas = [13.0, 37.0, 54.0], [0.01, 0.006, 0.004]
    segs = [_decays(freqs, zetas, SHAPES3, [1.0, 0.5, 0.2], 2048.0, 3000, snr_db, s) for s in (1, 2, 3)]
    modes = era(segs, 2048.0)
    assert modes.frequencies_hz.size == 3
    assert np.allclose(modes.frequencies_hz, freqs, rtol=0.005)
    for k in range(3):
        mac = (modes.shapes[:, k] @ SHAPES3[:, k]) ** 2 / (modes.shapes[:, k] @ modes.shapes[:, k])
        assert mac > 0.99
    assert modal_evidence(modes, 3) == "basis"


def test_a_mode_the_records_do_not_hold_is_unresolved_not_missing():
    # three channels, only two modes excited: fewer modes than channels, tail explained
    segs = [_decays([13.0, 37.0], [0.01, 0.006], SHAPES3[:, :2], [1.0, 0.5], 2048.0, 3000, 35.0, s) for s in (4, 5)]
    modes = era(segs, 2048.0)
    assert modes.frequencies_hz.size == 2
    assert float(np.max(modes.unexplained)) < 0.1
    assert modal_evidence(modes, 3) == "unresolved"


def test_a_channel_no_linear_mode_describes_is_missing_mode():
    # channel 2 carries a chirp (amplitude-dependent frequency, as an essentially nonlinear sink)
    rate, n = 2048.0, 3000
    t = np.arange(n) / rate
    segs = []
    for s in (6, 7):
        y = _decays([20.0, 45.0], [0.01, 0.01], np.array([[1.0, 0.4], [0.5, -1.0]]), [1.0, 0.3], rate, n, 60.0, s)
        y[1] += 2.0 * np.exp(-t) * np.cos(2 * math.pi * (60.0 * t - 12.0 * t**2))
        segs.append(y)
    modes = era(segs, rate)
    assert modal_evidence(modes, 2) == "missing_mode"


def test_pure_noise_is_refused_in_one_sentence():
    rng = np.random.default_rng(0)
    with pytest.raises(IdentificationError, match="no oscillating mode"):
        era([rng.standard_normal((2, 3000)) for _ in range(2)], 2048.0)


def test_rig_three_mass_chain_at_30_db_resolves_every_mode():
    from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test
    from station.mdof_data import condition_multichannel
    from station.readers import Measurement

    system = MdofSystem(name="own", masses_kg=(2.0, 1.0, 0.3), impacts_n=(150.0, 300.0), elements=(
        Element(between=(0, 1), k=6e4, c=6.0), Element(between=(1, 2), k=2e4, c=2.0),
        Element(between=(2, 3), k=1e4, c=1.0, k3=2e9)))
    recs: list[ChannelRecord] = []
    for k, peak in enumerate(system.impacts_n):
        r = mdof_impact_test(system, peak, seed=20 + k, snr_db=30.0)
        recs.append(condition_multichannel(Measurement(t=r.t, channels=r.columns(), rate_hz=r.rate_hz,
                                                       pretrigger_samples=r.pretrigger_samples, mass=None,
                                                       source="rig", metadata={})))
    modes = linear_modes(recs)
    truth = system.model().natural_frequencies_hz()
    assert modes.frequencies_hz.size == 3
    assert np.allclose(modes.frequencies_hz, truth, rtol=0.01)
    assert modal_evidence(modes, 3) == "basis"


def _pair(m1, m2, f1, ratio, zeta1, zeta_ratio, k3_share, rate):
    """Ground-m1-m2 chain with linear modes f1, ratio*f1 and modal damping ratios zeta1, zeta_ratio*zeta1
    (dashpots solved in the light-damping approximation), a cubic spring from m1 to ground."""
    from simulated_rig.mdof_systems import Element, MdofSystem, mdof_impact_test

    w1, w2 = 2 * math.pi * f1, 2 * math.pi * f1 * ratio
    s, p, mu = w1**2 + w2**2, (w1 * w2) ** 2, 1 / m1 + 1 / m2
    k2 = (s + math.sqrt(s * s - 4 * mu * p * m2)) / (2 * mu)
    k1 = m1 * (s - k2 * mu)
    m = np.diag([m1, m2])
    lam, v = np.linalg.eig(np.linalg.solve(m, np.array([[k1 + k2, -k2], [-k2, k2]])))
    o = np.argsort(lam.real)
    w, v = np.sqrt(lam.real[o]), v[:, o].real
    a = np.array([[v[0, i] ** 2, (v[0, i] - v[1, i]) ** 2] for i in range(2)])
    c = np.linalg.solve(a, 2 * np.array([zeta1, zeta_ratio * zeta1]) * w * np.diag(v.T @ m @ v))
    els = [Element(between=(0, 1), k=k1, c=c[0]), Element(between=(1, 2), k=k2, c=c[1])]
    lin = MdofSystem(name="pair", masses_kg=(m1, m2), elements=tuple(els), rate_hz=rate, impacts_n=(60.0, 150.0, 300.0))
    x = mdof_impact_test(lin, 300.0, snr_db=None).truth_x
    els[0] = els[0].model_copy(update={"k3": k3_share * k1 / float(np.max(np.abs(x[0]))) ** 2})
    shapes = v / v[np.argmax(np.abs(v), axis=0), [0, 1]]
    shapes *= np.sign(shapes[0])
    return lin.model_copy(update={"elements": tuple(els)}), w / (2 * math.pi), np.diag(shapes.T @ m @ shapes)


@pytest.mark.parametrize("case", [
    # m1, m2 [kg], f1 [Hz], f2/f1, zeta1, zeta2/zeta1, cubic share at the largest blow, rate [Hz], SNR [dB]
    (1.2, 0.35, 17.0, 2.6, 0.004, 6.0, 0.15, 2048.0, 40.0),
    (0.9, 0.3, 22.0, 4.0, 0.005, 5.0, 0.1, 1024.0, 45.0),
])
def test_a_fast_decaying_upper_mode_gone_from_the_tail_is_found_earlier(case):
    from eddi.mdof.modal import tail_segments
    from simulated_rig.mdof_systems import mdof_impact_test
    from station.mdof_data import condition_multichannel
    from station.readers import Measurement

    *spec, snr = case
    system, truth, modal_mass = _pair(*spec)
    recs = []
    for k, peak in enumerate(system.impacts_n):
        r = mdof_impact_test(system, peak, seed=40 + k, snr_db=snr)
        recs.append(condition_multichannel(Measurement(t=r.t, channels=r.columns(), rate_hz=r.rate_hz,
                                                       pretrigger_samples=r.pretrigger_samples, mass=None,
                                                       source="rig", metadata={})))
    tails = [tail_segments(r.a, r.window[0], r.window[1], 0.2) for r in recs]
    assert era(tails, system.rate_hz, max_freq_hz=0.2 * system.rate_hz).frequencies_hz.size == 1  # hidden
    modes = linear_modes(recs)
    assert modes.frequencies_hz.size == 2
    assert np.allclose(modes.frequencies_hz, truth, rtol=0.03)
    assert np.allclose(modes.modal_masses, modal_mass, rtol=0.1)  # from the driving-point residue
    assert modal_evidence(modes, 2) == "basis"  # the early mode does not count as motion beyond the channels
