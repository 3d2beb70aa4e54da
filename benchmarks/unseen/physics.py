"""Held-out physics for the blind scorecard: its own ODE, hammer and sensors.

Nothing here imports ``eddi`` or ``simulated_rig``: the point is a second, independent
implementation of an impact test, so that the station is judged on data it was not built
around. Units are SI throughout (m, m/s, m/s^2, N, kg, s).

The oscillator is

    m x'' + c v + c2 x^2 v + c3 v^3 + k1(t) x + k3 x^3 + f_extra(state) = F(t)

with optional extras: exact Coulomb friction (stick-slip by events, no regularisation), a
contact spring beyond a gap, quadratic drag, even (asymmetric) stiffness, ``x |x|`` stiffness,
Bouc-Wen hysteresis (extra state ``z``), a second mode coupled by a spring (extra states
``y, w``) and a slowly drifting linear stiffness. Integration: ``scipy.integrate.solve_ivp``
(DOP853, dense output), restarted at the end of the hammer pulse and, with friction, at every
velocity zero.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.integrate import solve_ivp
from scipy.signal import lfilter


@dataclass(frozen=True)
class Oscillator:
    """Physical parameters (SI). ``extras`` holds the hidden mechanisms."""

    m: float
    c: float
    k1: float
    k3: float = 0.0
    c2: float = 0.0  # x^2 v  [N s/m^3]
    c3: float = 0.0  # v^3    [N s^3/m^3]
    extras: dict = field(default_factory=dict)

    @property
    def fn(self) -> float:
        return math.sqrt(self.k1 / self.m) / (2 * math.pi)


@dataclass(frozen=True)
class Hammer:
    """Half-sine-like pulse ``F0 sin(pi s)^p``, s in [0, 1] over ``tau`` seconds from ``t0``."""

    f0: float
    tau: float
    t0: float
    p: float = 1.0

    def __call__(self, t):
        s = (np.asarray(t, dtype=float) - self.t0) / self.tau
        inside = (s > 0) & (s < 1)
        return np.where(inside, self.f0 * np.abs(np.sin(np.pi * np.clip(s, 0, 1))) ** self.p, 0.0)

    @property
    def impulse(self) -> float:
        # integral of sin^p over [0, pi] / pi
        p = self.p
        frac = math.gamma((p + 1) / 2) / (math.sqrt(math.pi) * math.gamma(p / 2 + 1))
        return self.f0 * self.tau * frac


def _n_states(osc: Oscillator) -> int:
    n = 2
    if "bouc_wen" in osc.extras:
        n += 1
    if "second_mode" in osc.extras:
        n += 2
    return n


def _forces(osc: Oscillator, t, y, slip):
    """Internal force on the main mass (everything but m x'' and F), and extra-state rates."""
    x, v = y[0], y[1]
    ex = osc.extras
    k1 = osc.k1
    if "drift" in ex:  # linear stiffness drifting in time (thermal): k1 (1 + offset + rate t)
        k1 = k1 * (1.0 + ex["drift"]["offset"] + ex["drift"]["rate_per_s"] * t)
    f = osc.c * v + osc.c2 * x * x * v + osc.c3 * v ** 3 + k1 * x + osc.k3 * x ** 3
    rates = []
    i = 2
    if "bouc_wen" in ex:
        bw = ex["bouc_wen"]
        z = y[i]
        a = bw["alpha"]
        f = f - (1 - a) * k1 * x + (1 - a) * k1 * z  # hysteretic share replaces part of k1 x
        zd = v - bw["beta"] * np.abs(v) * np.abs(z) ** (bw["n"] - 1) * z - bw["gamma"] * v * np.abs(z) ** bw["n"]
        rates.append(zd)
        i += 1
    if "second_mode" in ex:
        sm = ex["second_mode"]
        ym, wm = y[i], y[i + 1]
        f = f + sm["kc"] * (x - ym)
        wd = -(sm["c2"] * wm + sm["k2"] * ym + sm["kc"] * (ym - x)) / sm["m2"]
        rates.extend([wm, wd])
        i += 2
    if "clearance" in ex:
        cl = ex["clearance"]
        f = f + cl["k"] * np.sign(x) * np.maximum(np.abs(x) - cl["gap"], 0.0)
    if "quadratic_drag" in ex:
        f = f + ex["quadratic_drag"]["cq"] * np.abs(v) * v
    if "even_stiffness" in ex:
        f = f + ex["even_stiffness"]["k2"] * x * x
    if "xabsx" in ex:
        f = f + ex["xabsx"]["kq"] * x * np.abs(x)
    if "coulomb" in ex:
        f = f + ex["coulomb"]["fc"] * slip
    return f, rates


def _rhs(osc: Oscillator, hammer: Hammer, slip: float):
    def rhs(t, y):
        f, rates = _forces(osc, t, y, slip)
        a = (hammer(t) - f) / osc.m
        return np.concatenate(([y[1], a], rates)) if rates else np.array([y[1], a])
    return rhs


def simulate(osc: Oscillator, hammer: Hammer, t_samples: np.ndarray, rtol: float = 1e-10):
    """Sampled response ``x, v, a`` [m, m/s, m/s^2] at ``t_samples`` (rest before the hit).

    Parameters
    ----------
    osc : Oscillator
    hammer : Hammer
    t_samples : ndarray, shape (n,), [s]
        Increasing sample times (true device clock).
    """
    n = t_samples.size
    x = np.zeros(n)
    v = np.zeros(n)
    a = np.zeros(n)
    t_end = float(t_samples[-1]) + 1e-9
    y = np.zeros(_n_states(osc))
    fc = osc.extras.get("coulomb", {}).get("fc", 0.0)
    t = hammer.t0
    if fc > 0:  # motion starts only when the hammer beats static friction
        if hammer.f0 <= fc:
            return x, v, a
        t = hammer.t0 + hammer.tau / math.pi * math.asin((fc / hammer.f0) ** (1 / hammer.p))
    scale_x = max(hammer.impulse / (osc.m * 2 * math.pi * osc.fn), 1e-12)
    atol = np.full(y.size, 1e-9 * scale_x)
    atol[1] = 1e-9 * scale_x * 2 * math.pi * osc.fn
    period = 1.0 / osc.fn
    if "second_mode" in osc.extras:
        sm = osc.extras["second_mode"]
        period = min(period, 2 * math.pi / math.sqrt((sm["k2"] + sm["kc"]) / sm["m2"]))
    slip = 1.0
    stuck = False
    breaks = [hammer.t0 + hammer.tau]
    while t < t_end and not stuck:
        t_stop = next((b for b in breaks if b > t + 1e-15), t_end)
        t_stop = min(t_stop, t_end)
        in_pulse = t < hammer.t0 + hammer.tau
        max_step = hammer.tau / 40 if in_pulse else period / 30
        events = None
        if fc > 0:
            def ev(tt, yy):
                return yy[1]
            ev.terminal = True
            ev.direction = -slip  # leaves zero in the slip direction; fires on the reversal
            events = ev
        sol = solve_ivp(_rhs(osc, hammer, slip), (t, t_stop), y, method="DOP853", rtol=rtol,
                        atol=atol, max_step=max_step, dense_output=True, events=events)
        if not sol.success:
            raise RuntimeError(f"ODE failed: {sol.message}")
        t_hit = sol.t[-1]
        sel = (t_samples >= t) & (t_samples <= t_hit)
        if sel.any():
            ys = sol.sol(t_samples[sel])
            x[sel], v[sel] = ys[0], ys[1]
            f, _ = _forces(osc, t_samples[sel], ys, slip)
            a[sel] = (hammer(t_samples[sel]) - f) / osc.m
        y = sol.y[:, -1].copy()
        t = t_hit
        if fc > 0 and sol.status == 1:  # velocity reversal: slip the other way, or stick
            y[1] = 0.0
            f_other, _ = _forces(osc, t, y, 0.0)
            net = float(hammer(t)) - f_other
            if abs(net) <= fc and t >= hammer.t0 + hammer.tau:
                stuck = True
                rest = t_samples > t
                x[rest] = y[0]
            elif abs(net) > fc:
                slip = math.copysign(1.0, net)
            else:  # still in the pulse and held: stay, re-check shortly after
                slip = -slip
    return x, v, a


def highpass(sig: np.ndarray, rate: float, corner_hz: float) -> np.ndarray:
    """First-order analogue high-pass ``s / (s + wc)`` (bilinear, prewarped), from rest."""
    wc = 2 * rate * math.tan(math.pi * corner_hz / rate)
    k = 2 * rate
    b = np.array([k, -k]) / (k + wc)
    a = np.array([1.0, (wc - k) / (k + wc)])
    return lfilter(b, a, sig)


def quantise(sig: np.ndarray, full_scale: float, bits: int = 24) -> np.ndarray:
    lsb = 2 * full_scale / 2 ** bits
    return np.round(sig / lsb) * lsb


@dataclass(frozen=True)
class Record:
    t: np.ndarray
    force: np.ndarray | None
    acc: np.ndarray
    x_true: np.ndarray
    rate_hz: float


def impact_record(osc: Oscillator, *, rate_nominal: float, ppm: float, duration: float,
                  pretrigger: float, amp: float, tau: float, snr_db: float, rng,
                  force_snr_db: float = 60.0, with_force: bool = True,
                  hp_corner: float | None = None, pulse_p: float = 1.0) -> Record:
    """One impact capture as a DAQ gives it: force + accelerometer, noise, 24-bit, offset.

    ``amp`` is the displacement amplitude a linear oscillator would reach [m]; the hammer's
    impulse is ``m w amp``. Noise: ``sigma = peak / sqrt(2) * 10^(-snr/20)`` per channel.
    """
    rate = rate_nominal * (1 + ppm * 1e-6)
    n_pre = int(round(pretrigger * rate_nominal))
    n = n_pre + int(round(duration * rate_nominal))
    t = (np.arange(n) - n_pre) / rate
    w = 2 * math.pi * osc.fn
    p = pulse_p
    frac = math.gamma((p + 1) / 2) / (math.sqrt(math.pi) * math.gamma(p / 2 + 1))
    f0 = osc.m * w * amp / (tau * frac)
    t0 = rng.uniform(0, 1) / rate  # the hit does not start on a sample
    ham = Hammer(f0=f0, tau=tau, t0=t0, p=p)
    x, _v, a = simulate(osc, ham, t)
    acc = a.copy()
    if hp_corner:
        acc = highpass(acc, rate, hp_corner)
    peak = np.max(np.abs(acc))
    free_peak = np.max(np.abs(acc[t > t0 + tau])) if np.any(t > t0 + tau) else peak
    # SNR against the free response's peak, not the hammer's acceleration spike
    acc = acc + rng.normal(0, free_peak / math.sqrt(2) * 10 ** (-snr_db / 20), n)
    acc = acc + rng.uniform(-1, 1) * 1e-3 * peak  # sensor/ADC offset
    acc = quantise(acc, 4 * peak)
    force = None
    if with_force:
        force = ham(t)
        force = force + rng.normal(0, f0 / math.sqrt(2) * 10 ** (-force_snr_db / 20), n)
        force = quantise(force, 4 * f0)
    return Record(t=t, force=force, acc=acc, x_true=x, rate_hz=rate)


def with_extras(osc: Oscillator, **extras) -> Oscillator:
    ex = dict(osc.extras)
    ex.update(extras)
    return replace(osc, extras=ex)
