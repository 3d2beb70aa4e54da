"""From a system and a blow to CSV records (mechanics -> sensors -> file). No project code."""

from __future__ import annotations

import numpy as np

import physics
import sensors

OVERSAMPLE = 8


def impact_record(system, peak, width, fs, duration, *, pre=0.2, clock_ppm=0.0, chains=None,
                  channels=("acc",), rng, force_chain=None, cut_before=None, y0=None):
    """Simulate one blow and measure it.

    ``channels``: per response channel, ``(quantity, mass index)`` or just a quantity (mass 0);
    ``chains``: a :class:`sensors.Chain` per channel; ``pre`` [s]: time before the blow;
    ``clock_ppm``: the DAQ's true rate is ``fs (1 + ppm 1e-6)`` while it stamps ``fs``;
    ``cut_before`` [s after the blow's start]: drop every sample before it (a record without
    pre-trigger, starting in motion). Returns ``(columns, truth)``: columns name -> samples (SI),
    truth with the fine-grid displacement of every mass and the true sample rate.
    """
    fs_true = fs * (1 + clock_ppm * 1e-6)
    dt = 1.0 / (fs_true * OVERSAMPLE)
    t0 = pre + rng.uniform(0, 1) / fs_true                    # the blow starts between samples
    pulse = physics.Pulse(peak, width, t0)
    t, x, v, a, f = physics.simulate(system, pulse, pre + duration, dt, y0=y0)
    chans = [(c, 0) if isinstance(c, str) else tuple(c) for c in channels]
    chains = chains or [sensors.Chain() for _ in chans]
    force_chain = force_chain or sensors.Chain(snr_db=60.0, bits=24, range_factor=1.6)
    cols = {"force": sensors.measure(f, OVERSAMPLE, fs_true, force_chain, rng)}
    quantity = {"acc": a, "vel": v, "disp": x}
    peaks = {}
    for (q, i), ch in zip(chans, chains):
        sig = quantity[q][i]
        peaks[(q, i)] = float(np.max(np.abs(sig[t >= t0 + width])))
        cols[(q, i)] = sensors.measure(sig, OVERSAMPLE, fs_true, ch, rng, peak_ref=peaks[(q, i)],
                                       range_ref=float(np.max(np.abs(sig))))
    if cut_before is not None:
        k = int(np.ceil((t0 + cut_before) * fs_true))
        cols = {key: val[k:] for key, val in cols.items()}
    truth = {"fs_true": fs_true, "t0": t0, "x_peak": [float(np.max(np.abs(xi))) for xi in x]}
    return cols, truth


def name_columns(cols, names):
    """Rename ``(quantity, mass)`` keys by ``names`` (dict key -> column name); 'force' stays."""
    return {("force" if k == "force" else names[k]): v for k, v in cols.items()}


def samples_per_cycle(fs, f_hz):
    return fs / f_hz


def sdof(m, **law):
    """One mass on a polynomial spring/damper (see physics.poly_spring)."""
    return physics.System((m,), (physics.poly_spring(**law),))


def linear_freq(m, k):
    return float(np.sqrt(k / m) / (2 * np.pi))
