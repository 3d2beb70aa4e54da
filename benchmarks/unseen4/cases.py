"""The cases of the fourth blind scorecard, as physical parameters (see README.md).

Single-DOF systems are given nondimensionally at a reference displacement amplitude A [m]:
``k1 = m (2 pi fn)^2``, ``c1 = 2 zeta m 2 pi fn``, ``k2 = eps2 k1 / A``, ``k3 = eps3 k1 / A^2``;
damping extras as the ratio of their force to ``c1 V`` at ``V = 2 pi fn A`` (``x^2*v``: ``d2``, ``v^3``:
``d3``). Every random draw (pulse start within a sample, noise, clock, gain, offset, range, phase)
comes from ``rng(seed, case_id)``.
"""

from __future__ import annotations

import zlib

import numpy as np


def rng(seed, case_id, salt=""):
    return np.random.default_rng([int(seed), zlib.crc32((case_id + "/" + salt).encode())])


def sdof(m, fn, zeta, A, eps2=0.0, eps3=0.0, d2=0.0, d3=0.0):
    """Truth of a single-DOF system: dict with mass, damping and stiffness coefficients (SI)."""
    w = 2 * np.pi * fn
    k1, c1 = m * w * w, 2 * zeta * m * w
    V = w * A
    stiff = {"x": k1}
    if eps2:
        stiff["x^2"] = eps2 * k1 / A
    if eps3:
        stiff["x^3"] = eps3 * k1 / A ** 2
    damp = {"v": c1}
    if d2:
        damp["x^2*v"] = d2 * c1 * V / (A * A * V)
    if d3:
        damp["v^3"] = d3 * c1 * V / V ** 3
    return {"mass": m, "fn": fn, "A": A, "damping": damp, "stiffness": stiff}


# (b) identification on one blow (true library), validated on a held-out blow at 60 %
IDENT = {
    "id-gram": dict(sys=sdof(0.005, 850.0, 0.004, 25e-6, eps3=0.25), fs=50000, snr=44, bits=24,
                    width=0.12, dur=0.30, pre=0.03, quick=True),
    "id-tonne": dict(sys=sdof(500.0, 3.2, 0.015, 4e-3, eps3=-0.12, d3=0.30), fs=1000, snr=40, bits=16,
                     width=0.05, dur=16.0, pre=1.0, quick=True),
    "id-asym": dict(sys=sdof(0.35, 120.0, 0.006, 0.2e-3, eps2=0.15, eps3=0.20, d2=0.25), fs=6000,
                    snr=38, bits=16, width=0.15, dur=1.2, pre=0.1, quick=True, order="acc,force,t"),
    "id-soft": dict(sys=sdof(2.8, 41.0, 0.009, 1.5e-3, eps3=-0.18, d3=0.20), fs=1500, snr=48, bits=24,
                    width=0.15, dur=3.0, pre=0.2, quick=False),
    "id-hard20k": dict(sys=sdof(0.09, 310.0, 0.0025, 0.1e-3, eps3=0.45), fs=20000, snr=52, bits=24,
                       width=0.12, dur=1.4, pre=0.05, quick=False),
}

# (a) diagnosis: nulls (6 captures, two DAQ sessions) and hidden effects (4 captures)
NULL_LEVELS = [0.5, 0.7, 0.85, 1.0, 1.15, 1.3]
EFFECT_LEVELS = [0.6, 0.85, 1.0, 1.25]
DIAG = {
    "null-asym55": dict(sys=sdof(0.6, 55.0, 0.005, 0.5e-3, eps2=0.10, eps3=0.25), fs=16000, snr=42,
                        bits=24, width=0.15, dur=1.6, pre=0.1, quick=True, hidden=None,
                        expect=["none"]),
    "null-soft9": dict(sys=sdof(12.0, 9.0, 0.02, 3e-3, eps3=-0.15, d2=0.20), fs=2500, snr=50, bits=24,
                       width=0.10, dur=5.0, pre=0.5, quick=True, hidden=None, expect=["none"]),
    "null-30g": dict(sys=sdof(0.03, 420.0, 0.003, 40e-6, eps3=0.35, d3=0.15), fs=25000, snr=36,
                     bits=16, width=0.12, dur=0.8, pre=0.04, quick=False, hidden=None,
                     expect=["none"]),
    "hid-gap": dict(sys=sdof(1.8, 24.0, 0.006, 1.2e-3, eps3=0.05), fs=4000, snr=45, bits=24, width=0.12,
                    dur=3.5, pre=0.2, quick=True, hidden=("gap", 0.8, 0.35),
                    expect=["unexplained"], near=["clearance", "asymmetric_stiffness"]),
    "hid-kmod": dict(sys=sdof(0.22, 68.0, 0.004, 0.3e-3, eps3=0.15), fs=8000, snr=46, bits=24,
                     width=0.12, dur=1.8, pre=0.1, quick=True, hidden=("kmod", 0.05, 1.7),
                     expect=["unexplained"], near=[]),
    "hid-mass": dict(sys=sdof(1.4, 16.0, 0.01, 2e-3, eps3=-0.10), fs=2000, snr=44, bits=24,
                     width=0.12, dur=3.5, pre=0.3, quick=True, hidden=("mass", 2.0),
                     expect=["unexplained"], near=[], symptom="impulse_mass"),
    "cat-iepe": dict(sys=sdof(7.0, 19.0, 0.007, 1.5e-3, eps3=0.12), fs=8000, snr=45, bits=24,
                     width=0.12, dur=3.5, pre=0.3, quick=True, hidden=("iepe", 2.7),
                     expect=["sensor_highpass"], near=[]),
    "hid-zener": dict(sys=sdof(0.8, 35.0, 0.003, 0.8e-3, eps3=0.20), fs=5000, snr=45, bits=24,
                      width=0.12, dur=3.0, pre=0.2, quick=False, hidden=("maxwell", 0.08, 0.5),
                      expect=["unexplained"], near=[]),
    "hid-mount": dict(sys=sdof(0.5, 48.0, 0.004, 0.6e-3, eps3=0.15), fs=10000, snr=42, bits=24,
                      width=0.08, dur=2.2, pre=0.1, quick=False, hidden=("mount", 3.1, 0.04),
                      expect=["unexplained"], near=["second_mode"]),
    "cat-iepe2": dict(sys=sdof(60.0, 3.3, 0.012, 5e-3, eps3=-0.08), fs=1000, snr=48, bits=24,
                      width=0.06, dur=14.0, pre=1.0, quick=False, hidden=("iepe", 0.45),
                      expect=["sensor_highpass"], near=[]),
}

# (c) multi-DOF, acc channels only, no mass given: 3 training blows, one held out at 80 %
MDOF_TRAIN = [0.6, 1.0, 1.3]
MDOF_HELD = 0.8
MDOF = {
    "mdof-chain3": dict(kind="chain3", fs=2500, snr=45, bits=24, width=0.10, dur=4.0, pre=0.2,
                        quick=True, columns=["acc1", "acc2", "acc3"], driving=None),
    "mdof-12": dict(kind="ratio12", fs=3200, snr=45, bits=24, width=0.08, dur=5.0, pre=0.2,
                    quick=True, columns=["acc_base", "acc_top"], driving="acc_top"),
    "mdof-cant": dict(kind="cantilever", fs=4000, snr=45, bits=24, width=0.05, dur=4.0, pre=0.2,
                      quick=False, columns=["acc1", "acc2", "acc3"], driving="acc3"),
}


def mdof_spec(kind):
    """M, K, C, hammer vector b, and the nonlinear laws with unit coefficients scaled later.

    Returns (spec, scale): scale says how eps maps onto the nonlinear coefficients:
    a list of (law index, relative coordinate (i, j), linear stiffness it is relative to, eps, power).
    """
    if kind == "chain3":
        M = np.diag([0.9, 0.6, 0.4])
        k01, k12, k23 = 1.2e4, 8e3, 5e3
        K = np.array([[k01 + k12, -k12, 0], [-k12, k12 + k23, -k23], [0, -k23, k23]])
        C = rayleigh(M, K, 0.006, 0.010)
        nl = [("poly", 2, 1, 1.0, 2, 0), ("poly", 2, 1, 1.0, 3, 0)]
        scale = [(0, (2, 1), k23, 0.12, 2), (1, (2, 1), k23, 0.30, 3)]
        b = [1.0, 0.0, 0.0]
    elif kind == "ratio12":
        M = np.diag([1.6, 0.7])
        K = two_dof_ratio(M, 2.05, 27.0)
        C = modal_damping(M, K, [0.004, 0.020])
        nl = [("poly", 1, -1, 1.0, 3, 0)]
        scale = [(0, (1, -1), K[1, 1] + K[0, 1], 0.25, 3)]
        b = [0.0, 1.0]
    elif kind == "cantilever":
        M = np.diag([0.5, 0.5, 0.25])
        xs = np.array([1.0, 2.0, 3.0]) / 3
        Fl = np.array([[min(a, c) ** 2 * (3 * max(a, c) - min(a, c)) / 6 for c in xs] for a in xs])
        K = np.linalg.inv(Fl)
        w1 = np.sqrt(np.min(np.linalg.eigvals(np.linalg.inv(M) @ K).real))
        K *= (2 * np.pi * 11.0 / w1) ** 2
        C = rayleigh(M, K, 0.008, 0.012)
        nl = [("poly", 2, -1, 1.0, 3, 0)]
        kt = 1.0 / np.linalg.inv(K)[2, 2]  # the tip's static stiffness
        scale = [(0, (2, -1), kt, 0.30, 3)]
        b = [0.0, 0.0, 1.0]
    else:
        raise ValueError(kind)
    return {"M": M, "K": K, "C": C, "b": b, "nl": nl}, scale


def rayleigh(M, K, z1, z2):
    """C = a M + b K with damping ratio z1 on the lowest mode and z2 on the highest."""
    w = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.inv(M) @ K).real))
    w1, w2 = w[0], w[-1]
    A = np.array([[1 / (2 * w1), w1 / 2], [1 / (2 * w2), w2 / 2]])
    a, b = np.linalg.solve(A, [z1, z2])
    return a * M + b * K


def modal_damping(M, K, zetas):
    """C with the given modal damping ratios (mass-normalised modes)."""
    w2, phi = np.linalg.eig(np.linalg.inv(M) @ K)
    order = np.argsort(w2.real)
    w = np.sqrt(w2.real[order])
    phi = phi.real[:, order]
    phi = phi / np.sqrt(np.einsum("ij,ik,kj->j", phi, M, phi))
    Cm = np.diag(2 * np.array(zetas) * w)
    return M @ phi @ Cm @ phi.T @ M


def two_dof_ratio(M, ratio, f1):
    """K of a grounded two-mass chain (k_g1 to mass 1, k_c between, k_g2 = 0.5 k_c at mass 2)
    whose modes are at f1 and ratio * f1."""
    from scipy.optimize import brentq

    def mk(kg1, kc):
        kg2 = 0.5 * kc
        return np.array([[kg1 + kc, -kc], [-kc, kc + kg2]])

    def r(kg1):
        w = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.inv(M) @ mk(kg1, 1.0)).real))
        return w[1] / w[0] - ratio

    kg1 = brentq(r, 1e-3, 3.0)  # the soft-ground branch (the ratio has a minimum near kg1 = 3 kc)
    K = mk(kg1, 1.0)
    w1 = np.sqrt(np.min(np.linalg.eigvals(np.linalg.inv(M) @ K).real))
    return K * (2 * np.pi * f1 / w1) ** 2


# (d) bad inputs: see robust.py
