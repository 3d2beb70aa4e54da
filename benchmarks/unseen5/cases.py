"""The cases of the fifth blind scorecard (parameters fixed here; random draws from --seed and the id).

Single-DOF systems are given at a reference amplitude ``A`` [m]: ``k1 = m (2 pi fn)^2``,
``c1 = 2 zeta m 2 pi fn``; ``eps_p`` sets the stiffness term ``x^p`` so that its force at ``A`` is
``eps_p k1 A``; ``d2`` (``x^2*v``) and ``d3`` (``v^3``) so that their force at ``A`` and
``V = 2 pi fn A`` is ``d c1 V``. Hammer tips: (p, q) of the pulse ``s^p (1 - s)^q``; ``width`` is the
pulse length as a fraction of the (lowest) natural period; the force is scaled by a linear pilot so
that the free response peaks near ``A`` at level 1.
"""

from __future__ import annotations

import zlib

import numpy as np

TIPS = {"steel": (1.0, 1.0), "plastic": (2.0, 2.0), "rubber": (1.5, 3.5)}
NULL_LEVELS = [0.45, 0.65, 0.8, 0.95, 1.1, 1.3]  # 6 captures, two DAQ sessions interleaved
EFFECT_LEVELS = [0.55, 0.8, 1.05, 1.35]
MDOF_TRAIN = [0.5, 0.9, 1.3]
MDOF_HELD = 1.1


def rng(seed, cid):
    """The case's own generator: the same draws for a seed whatever else is generated."""
    return np.random.default_rng([int(seed), zlib.crc32(cid.encode())])


def sdof(m, fn, zeta, A, eps=None, d2=0.0, d3=0.0):
    """Truth of a single-DOF system: mass, damping and stiffness coefficients (SI)."""
    w = 2 * np.pi * fn
    k1, c1 = m * w * w, 2 * zeta * m * w
    V = w * A
    stiff = {"x": k1}
    for p, e in sorted((eps or {}).items()):
        stiff[f"x^{p}"] = e * k1 / A ** (p - 1)
    damp = {"v": c1}
    if d2:
        damp["x^2*v"] = d2 * c1 / A ** 2
    if d3:
        damp["v^3"] = d3 * c1 / V ** 2
    return {"mass": m, "fn": fn, "zeta": zeta, "A": A, "damping": damp, "stiffness": stiff}


def _case(sys_, fs, snr, bits, tip, width, pre, dur, adc, quick, **kw):
    return dict(sys=sys_, fs=fs, snr=snr, bits=bits, tip=tip, width=width, pre=pre, dur=dur,
                adc=adc, quick=quick, **kw)


# (a) diagnosis: nulls (every term inside the default libraries) -> `none`
NULLS = {
    "null-gram": _case(sdof(0.002, 150.0, 0.004, 20e-6, {3: 0.30}), 40000, 52, 24, "steel", 0.08,
                       0.04, 1.6, "avg", True),
    "null-heavy": _case(sdof(200.0, 3.0, 0.018, 6e-3, {3: -0.10}, d3=0.25), 2000, 38, 16, "rubber",
                        0.25, 0.6, 14.0, "point", True),
    "null-asym": _case(sdof(0.05, 75.0, 0.008, 0.1e-3, {2: 0.12, 3: 0.15, 4: 0.05}, d2=0.30), 12000,
                       31, 24, "plastic", 0.18, 0.008, 1.2, "point", True),
    "null-quintic": _case(sdof(8.0, 18.0, 0.005, 1e-3, {3: -0.20, 5: 0.08}), 5000, 60, 24, "rubber",
                          0.30, 0.2, 6.0, "avg", True),
    "null-fast": _case(sdof(0.4, 140.0, 0.025, 0.15e-3, {3: 0.40}, d2=0.15), 25600, 45, 24, "steel",
                       0.06, 0.05, 1.0, "avg", True),
    "null-long": _case(sdof(1.1, 6.5, 0.0015, 2e-3, {3: 0.06}), 2000, 48, 24, "plastic", 0.10, 1.0,
                       20.0, "point", False),
}

# (a) diagnosis: hidden effects -> the catalogued name, or `unexplained` outside the catalogue.
# hidden: (kind, params...). Strengths are relative to k1 A (forces) or c1 V (damping).
EFFECTS = {
    "cat-drag": _case(sdof(0.9, 22.0, 0.004, 1.5e-3, {3: 0.10}), 5000, 46, 24, "plastic", 0.10,
                      0.1, 4.0, "avg", True, hidden=("drag", 0.8), expect=["quadratic_damping"]),
    "cat-coulomb": _case(sdof(3.5, 9.0, 0.003, 2e-3, {3: -0.05}), 2500, 44, 24, "steel", 0.05, 0.3,
                         5.0, "point", True, hidden=("coulomb", 0.012, 0.005),
                         expect=["coulomb_friction"]),
    "cat-highpass": _case(sdof(25.0, 7.0, 0.009, 3e-3, {3: 0.15}, d3=0.20), 2000, 50, 24, "steel",
                          0.03, 0.3, 8.0, "point", True, hidden=("highpass", 0.8),
                          expect=["sensor_highpass"]),
    "hid-rattle": _case(sdof(0.6, 40.0, 0.003, 0.5e-3, {3: 0.10}), 10000, 45, 24, "plastic", 0.08,
                        0.05, 2.5, "avg", True, hidden=("rattle", 0.07, 0.25, 40.0, 0.10),
                        expect=["unexplained"]),
    "hid-thermal": _case(sdof(1.5, 30.0, 0.0035, 0.8e-3, {3: 0.20}), 6000, 48, 24, "plastic", 0.10,
                         0.1, 3.0, "point", True,
                         hidden=("thermal", [0.016, -0.012, 0.004, -0.020]),
                         expect=["unexplained"]),
    "cat-clearance": _case(sdof(0.15, 45.0, 0.005, 0.4e-3), 8000, 42, 24, "steel", 0.06, 0.05, 2.0,
                           "avg", True, hidden=("clearance", 1.2, 0.45), expect=["clearance"]),
    "cat-joint": _case(sdof(4.0, 16.0, 0.002, 1e-3, {3: 0.05}), 3200, 47, 24, "plastic", 0.12, 0.2,
                       4.0, "point", False,
                       hidden=("joint", [(0.04, 0.10), (0.04, 0.30), (0.03, 0.70)], 0.65, 0.35),
                       expect=["hysteresis"]),
    "cat-mode2": _case(sdof(0.8, 25.0, 0.004, 0.6e-3, {3: 0.12}), 6000, 46, 24, "steel", 0.05, 0.1,
                       3.0, "avg", False, hidden=("mode2", 0.12, 2.7, 0.01, 0.35),
                       expect=["second_mode"]),
    "hid-sensornl": _case(sdof(2.2, 12.0, 0.006, 1.5e-3, {3: 0.08}), 3000, 50, 24, "plastic", 0.10,
                          0.2, 5.0, "point", True, hidden=("sensornl", 0.06),
                          expect=["unexplained"]),
    "hid-twodaq": _case(sdof(0.12, 110.0, 0.002, 0.1e-3, {3: 0.15}), 20000, 50, 24, "steel", 0.07,
                        0.03, 3.0, "avg", False, hidden=("twodaq", 150.0), expect=["unexplained"]),
    "hid-gaindrift": _case(sdof(0.3, 60.0, 0.005, 0.3e-3, {3: 0.12}), 8000, 48, 24, "steel", 0.07,
                           0.05, 2.0, "avg", False, hidden=("gain", [1.0, 0.93, 1.07, 0.96]),
                           expect=["unexplained"]),
}

# (b) identification with the true library; the model validated on a held-out blow at 0.65
IDENT = {
    "id-micro": _case(sdof(0.004, 130.0, 0.005, 30e-6, {3: 0.30}), 40000, 50, 24, "steel", 0.07,
                      0.02, 1.2, "avg", True),
    "id-heavy": _case(sdof(120.0, 4.5, 0.012, 5e-3, {3: -0.15}, d2=0.40), 2000, 42, 24, "rubber",
                      0.20, 0.5, 12.0, "point", True),
    "id-asym": _case(sdof(0.7, 33.0, 0.006, 0.8e-3, {2: -0.20, 3: 0.10}, d3=0.30), 6000, 36, 16,
                     "plastic", 0.12, 0.1, 3.0, "avg", True),
    "id-quintic": _case(sdof(12.0, 12.0, 0.004, 2e-3, {3: 0.20, 5: 0.10}), 3000, 55, 24, "plastic",
                        0.15, 0.3, 7.0, "point", True),
    "id-light": _case(sdof(0.25, 95.0, 0.0012, 0.2e-3), 20000, 46, 24, "steel", 0.05, 0.05, 8.0,
                      "avg", False),
}


def mdof_spec(kind):
    """(spec, scale): spec for physics.System without the nonlinear coefficient's value, and
    (nl index, (i, j), k_lin, eps, power, D) to set it: coef = eps k_lin / D^(p - 1)."""
    if kind == "tmd":  # a main mass with a nonlinear tuned absorber (cubic spring between)
        m1, m2 = 2.0, 0.16
        w1, w2 = 2 * np.pi * 14.0, 2 * np.pi * 14.0 * 0.93
        k1, k2 = m1 * w1 ** 2, m2 * w2 ** 2
        c1, c2 = 2 * 0.005 * m1 * w1, 2 * 0.02 * m2 * w2
        M = np.diag([m1, m2])
        K = np.array([[k1 + k2, -k2], [-k2, k2]])
        C = np.array([[c1 + c2, -c2], [-c2, c2]])
        spec = {"M": M, "K": K, "C": C, "b": [1.0, 0.0], "nl": [("poly", 1, 0, 0.0, 3, 0)]}
        return spec, [(0, (1, 0), k2, 0.30, 3, 1.5e-3)]
    if kind == "star":  # a hub with two arms of different tuning, cubic spring on the second arm
        m = [1.0, 0.3, 0.2]
        kg = 1.0 * (2 * np.pi * 11.0) ** 2
        ka, kb = 0.3 * (2 * np.pi * 23.0) ** 2, 0.2 * (2 * np.pi * 36.0) ** 2
        M = np.diag(m)
        K = np.array([[kg + ka + kb, -ka, -kb], [-ka, ka, 0.0], [-kb, 0.0, kb]])
        w2 = np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real)
        wa, wb = np.sqrt(w2[0]), np.sqrt(w2[-1])
        za, zb = 0.006, 0.012
        beta = 2 * (zb * wb - za * wa) / (wb ** 2 - wa ** 2)  # Rayleigh: zeta = a/(2w) + b w/2
        alpha = 2 * za * wa - beta * wa ** 2
        C = alpha * M + beta * K
        spec = {"M": M, "K": K, "C": C, "b": [1.0, 0.0, 0.0], "nl": [("poly", 2, 0, 0.0, 3, 0)]}
        return spec, [(0, (2, 0), kb, 0.25, 3, 0.8e-3)]
    raise ValueError(kind)


# (d) multi-DOF: acc only, no mass; columns in the CSV order; the driving point named
MDOF = {
    "mdof-tmd": dict(kind="tmd", fs=3200, snr=45, bits=24, tip="plastic", width=0.08, pre=0.1,
                     dur=5.0, adc="avg", columns=["acc_main", "acc_tmd"], driving="acc_main",
                     quick=True),
    "mdof-star": dict(kind="star", fs=2500, snr=45, bits=24, tip="steel", width=0.06, pre=0.1,
                      dur=6.0, adc="point", columns=["acc_arm1", "acc_hub", "acc_arm2"],
                      driving="acc_hub", quick=True),
}
