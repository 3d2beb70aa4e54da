"""Small helpers shared by the case modules: amplitudes, truths in the station's term names, files."""

from __future__ import annotations

import os

import numpy as np

import records
import sensors


def w(f_hz):
    return 2 * np.pi * f_hz


def amp(m, f_hz, peak, width):
    """Peak displacement of a lightly damped linear oscillator after a short haversine blow [m]."""
    impulse = peak * width / 2
    wn = w(f_hz)
    # the haversine's spectrum at wn reduces the short-pulse impulse a little
    shape = abs(np.sinc(wn * width / (2 * np.pi)) / (1 - (wn * width / (2 * np.pi)) ** 2 + 1e-12))
    return impulse * min(shape, 1.0) / (m * wn)


def law_terms(k=0.0, k2=0.0, k3=0.0, kxa=0.0, c=0.0, c3=0.0, cq=0.0):
    """The truth in the station's term names (only the nonzero terms)."""
    damping = {n: v for n, v in (("v", c), ("v^3", c3), ("abs(v)*v", cq)) if v}
    stiffness = {n: v for n, v in (("x", k), ("x^2", k2), ("x^3", k3), ("abs(x)*x", kxa)) if v}
    return damping, stiffness


def write(out, name, cols, fs_stamped, *, digits=7, order=None, t0=0.0):
    sensors.write_csv(os.path.join(out, name), fs_stamped, cols, time_digits=digits, order=order, t0=t0)
    return name


def blow_series(system, peaks, width, fs, duration, rng, *, channels=("acc",), chains=None, pre=0.2,
                clock_ppm=0.0, names=None, cut_before=None):
    """Several blows of one system -> list of (columns, truth)."""
    out = []
    for p in peaks:
        cols, truth = records.impact_record(system, p, width, fs, duration, pre=pre, clock_ppm=clock_ppm,
                                            chains=chains, channels=channels, rng=rng, cut_before=cut_before)
        chans = [(c, 0) if isinstance(c, str) else tuple(c) for c in channels]
        names = names or {ch: ch[0] if len(chans) == 1 else f"{ch[0]}{ch[1] + 1}" for ch in chans}
        out.append((records.name_columns(cols, names), truth))
    return out


def ring_periods(f_hz, zeta, fraction=0.03):
    """Time for a ring-down to fall to ``fraction`` of its start [s]."""
    return float(np.log(1 / fraction) / (zeta * w(f_hz)))
