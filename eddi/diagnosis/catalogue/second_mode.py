"""A second linear mode coupled to the measured coordinate (hidden form)."""

from __future__ import annotations

import math

import numpy as np

from eddi.diagnosis.catalogue.base import Context, Mechanism, MechanismFit
from eddi.iir import biquad
from eddi.model import Effect

class SecondMode(Mechanism):
    """A second, linear mode coupled to the measured coordinate.

    With symmetric coupling ``k_c`` the force on ``x`` is ``k_c x - k_c y`` and
    ``y = k_c x / (m2 s^2 + c2 s + k2m + k_c)``. Writing ``w2^2 = (k2m + k_c)/m2`` and
    ``g = G x`` with the unit-gain filter ``G = w2^2 / (s^2 + 2 z2 w2 s + w2^2)``, the force is
    ``k_c x - (k_c^2 / (m2 w2^2)) g``: linear in the columns ``x`` and ``g`` once ``(w2, z2)``
    are fixed. Only ``k_c^2 / m2`` is observable from ``x``; the modal mass is set to the
    main mass (raised if needed to keep ``k2m >= 0``).
    """

    name = "second_mode"
    strength = "coupling_n_per_m"
    refine = ("frequency_hz", "damping_ratio")
    physics = ("a second linear mode (mass m2, stiffness k2, damping c2) coupled to the measured "
               "coordinate by a spring k_c")

    def shape_grid(self, ctx):
        fs = 1.0 / ctx.signals[0].dt
        f1 = ctx.base_frequency_hz
        freqs, power = _residual_spectrum(ctx, fs)
        if freqs.size == 0:
            return []
        keep = (freqs > 0.3 * f1) & (freqs < 0.45 * fs)
        # away from the baseline's own frequency, and close by its harmonics only (a band of
        # +-0.15 f1 around 2 f1 and 3 f1 hid a real mode at 3.1 f1: its grid then sat on noise)
        keep &= np.abs(freqs - f1) > 0.15 * f1
        for h in (2, 3):
            keep &= np.abs(freqs - h * f1) > 0.03 * f1
        if not np.any(keep):
            return []
        idx = np.flatnonzero(keep)
        order = idx[np.argsort(power[idx])[::-1]]
        peaks: list[float] = []
        for i in order:
            f = float(freqs[i])
            if all(abs(f - p) > 0.1 * p for p in peaks):
                peaks.append(f)
            if len(peaks) == 2:  # the strongest two: one of them may be a harmonic
                break
        grid = []
        for fp in peaks:
            for f in fp * np.linspace(0.92, 1.08, 9):
                for z in (0.005, 0.02, 0.05):
                    grid.append({"frequency_hz": float(f), "damping_ratio": z})
        return grid

    # not a single-coordinate term: the force it puts on x depends on the history of x. In
    # EDDI its power v g is nearly collinear with v^2 (g ~ x - 2 z v / w2 + ...), so phase one
    # cannot tell it from viscous damping; it is refitted jointly with the baseline terms by
    # equation error instead (``native`` stays empty)

    def columns(self, sig, shape, stiffness):
        return _mode_filter(sig.x, shape["frequency_hz"], shape["damping_ratio"], sig.dt)[:, None]

    def to_fit(self, coefs, shape, mass, stiffness):
        cg = float(coefs[0])
        if not cg < 0:
            return None
        w = 2 * math.pi * shape["frequency_hz"]
        m2 = max(mass, 4.0 * -cg / (w * w))
        kc = math.sqrt(-cg * m2 * w * w)
        k2m = m2 * w * w - kc
        c2 = 2 * shape["damping_ratio"] * w * m2
        eff = Effect(name=self.name, params={
            "mass_kg": m2, "stiffness_n_per_m": k2m, "damping_n_s_per_m": c2,
            "coupling_n_per_m": kc})
        return MechanismFit(eff, linear_stiffness_shift=kc)

    def symptom(self, fit):
        p = fit.effect.params
        f2 = math.sqrt((p["stiffness_n_per_m"] + p["coupling_n_per_m"]) / p["mass_kg"]) / (2 * math.pi)
        return (f"misses response energy at a second frequency near {f2:.4g} Hz that a single "
                "mode cannot produce: a second mode")


def _mode_filter(x: np.ndarray, frequency_hz: float, damping_ratio: float, dt: float) -> np.ndarray:
    """``g = G x`` with the unit-gain filter ``w^2 / (s^2 + 2 z w s + w^2)`` (bilinear transform)."""
    w = 2 * math.pi * frequency_hz
    z = damping_ratio
    k = 2.0 / dt
    a = np.array([k * k + 2 * z * w * k + w * w, 2 * (w * w - k * k), k * k - 2 * z * w * k + w * w])
    b = w * w * np.array([1.0, 2.0, 1.0])
    # scipy.signal.lfilter's numbers bit for bit, without importing scipy.signal (eddi.iir)
    return biquad(b / a[0], a / a[0], x)


def _residual_spectrum(ctx: Context, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Energy spectrum of the baseline's equation-error residual over the training samples.

    One FFT per record over its training samples (zeros elsewhere), power summed over
    records: a decaying second mode puts its energy in a narrow peak even when it rings for
    a small part of the record, while the measurement noise spreads evenly.
    """
    n = max(s.x.size for s in ctx.signals)
    nfft = 1 << int(math.ceil(math.log2(max(n, 64))))
    total = np.zeros(nfft // 2 + 1)
    for r in ctx.residual:
        seg = np.nan_to_num(r, nan=0.0)
        total += np.abs(np.fft.rfft(seg, nfft)) ** 2
    freqs = np.fft.rfftfreq(nfft, 1.0 / fs)
    # smooth over about 1 Hz so one noisy bin does not win
    width = max(1, int(round(1.0 / (freqs[1] - freqs[0]))))
    kernel = np.ones(width) / width
    return freqs, np.convolve(total, kernel, mode="same")
