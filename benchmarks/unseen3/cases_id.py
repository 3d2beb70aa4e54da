"""Identification-side cases: cross-command consistency (a), multi-channel (b), record quirks (c).

Each ``make_*`` simulates its records into ``out`` and returns its manifest entry. Every random
draw comes from the ``rng`` it is handed (seeded per case by ``generate.py``).
"""

from __future__ import annotations

import numpy as np

import physics
import records
import sensors
from design import amp, blow_series, law_terms, ring_periods, w, write


def _sdof_case(m, f_hz, zeta, *, r3=0.0, r2=0.0, rxa=0.0, rc3=0.0, rq=0.0, peak, width, a_ref=None):
    """A one-mass system from ratios at the reference amplitude ``a_ref`` (default: the blow's).

    ``r3``: k3 A^2 / k; ``r2``: k2 A / k; ``rxa``: kxa A / k; ``rc3``: c3 V^2 / c; ``rq``: cq V / c."""
    k = m * w(f_hz) ** 2
    c = 2 * zeta * np.sqrt(k * m)
    a = a_ref or amp(m, f_hz, peak, width)
    vel = a * w(f_hz)
    law = dict(k=k, k2=r2 * k / a, k3=r3 * k / a ** 2, kxa=rxa * k / a, c=c, c3=rc3 * c / vel ** 2,
               cq=rq * c / vel)
    return records.sdof(m, **law), law, a


# ---- (a) the same capture through every command -------------------------------------------------

def make_consistency(out, rng, cid, *, m, f_hz, zeta, r3, fs, peaks, width, snr=45.0, rc3=0.0):
    system, law, a = _sdof_case(m, f_hz, zeta, r3=r3, rc3=rc3, peak=peaks[1], width=width)
    dur = min(ring_periods(f_hz, zeta), 6.0)
    chains = [sensors.Chain(snr_db=snr, bits=24, range_factor=2.5)]
    recs = blow_series(system, peaks, width, fs, dur, rng, chains=chains)
    files, reordered = [], []
    for j, (cols, _) in enumerate(recs):
        files.append(write(out, f"{cid}-r{j}.csv", cols, fs, digits=6))
        reordered.append(write(out, f"{cid}-o{j}.csv", cols, fs, digits=6, order=["acc", "force", "t"]))
    damping, stiffness = law_terms(**law)
    return {"id": cid, "kind": "consistency", "mass": m, "f1_hz": f_hz, "fs": fs, "files": files,
            "reordered": reordered, "truth": {"damping": damping, "stiffness": stiffness}, "amp_m": a}


# ---- (b) several sensors -------------------------------------------------------------------------

def _mdof_records(out, rng, cid, system, peaks, held_peak, width, fs, dur, names, *, snr=45.0, pre=0.2):
    chans = [("acc", i) for i in range(system.n)]
    chains = [sensors.Chain(snr_db=snr, bits=24, range_factor=2.0) for _ in chans]
    files = []
    for j, p in enumerate([*peaks, held_peak]):
        cols, _ = records.impact_record(system, p, width, fs, dur, pre=pre, channels=chans, chains=chains, rng=rng)
        cols = records.name_columns(cols, {("acc", i): names[i] for i in range(system.n)})
        order = ["t", "force", *names]
        files.append(write(out, f"{cid}-{'h' if j == len(peaks) else 'r'}{j}.csv", cols, fs, digits=7, order=order))
    return files[:-1], files[-1]


def _cubic_coupling_truth(k3, i, j, n):
    """Monomials of ``k3 (x_i - x_j)^3`` in equations i and j (physical coordinates, N/m^3)."""
    xi, xj = f"x{i + 1}", f"x{j + 1}"
    terms = {f"{xi}^3": 1, f"{xi}^2*{xj}": -3, f"{xi}*{xj}^2": 3, f"{xj}^3": -1}
    eq = [dict() for _ in range(n)]
    for name, s in terms.items():
        eq[i][_canon(name)] = s * k3
        eq[j][_canon(name)] = -s * k3
    return eq


def _canon(term):
    """``x2*x1^2`` and ``x1^2*x2`` the same way: factors sorted by coordinate."""
    return "*".join(sorted(term.split("*"), key=lambda f: f.split("^")[0]))


def make_chain(out, rng, cid, *, via_h5=False):
    m1, m2, k1, k12 = 1.1, 0.6, 2.6e4, 1.6e4
    kmat = np.array([[k1 + k12, -k12], [-k12, k12]])
    freqs = physics.free_mode_frequencies([m1, m2], kmat)
    peaks, width = (50.0, 140.0, 90.0), 1.1e-3
    a = amp(m1, freqs[0], peaks[1], width)
    k3 = 0.25 * k12 / a ** 2
    system = physics.System((m1, m2), (physics.poly_spring(k=k1, c=7.0), physics.poly_spring()),
                            {(0, 1): physics.poly_spring(k=k12, k3=k3, c=3.0)})
    train, held = _mdof_records(out, rng, cid, system, peaks, 0.7 * peaks[1], width, 4096, 3.5, ["acc1", "acc2"])
    return {"id": cid, "kind": "mdof", "system": "two-mass chain, cubic coupling spring", "files": train,
            "heldout": held, "freqs_hz": list(map(float, freqs)), "masses": [m1, m2], "via_h5": via_h5,
            "driving_point": None, "expect": ["modal_coupling"],
            "coupling": _cubic_coupling_truth(k3, 0, 1, 2), "fs": 4096}


def make_internal13(out, rng, cid):
    """Two masses whose linear modes sit near 1:3; a cubic spring to ground on the root mass.
    Named sensor columns ``acc_root, acc_tip``; the hammer hits the tip (second column)."""
    m1, m2, k1 = 0.9, 0.3, 3.2e4
    k12 = _tune_ratio(m1, m2, k1, 3.02)
    kmat = np.array([[k1 + k12, -k12], [-k12, k12]])
    freqs = physics.free_mode_frequencies([m1, m2], kmat)
    peaks, width = (30.0, 80.0, 55.0), 0.8e-3
    a = amp(m2, freqs[0], peaks[1], width) * 0.6
    k3 = 0.2 * k1 / a ** 2
    system = physics.System((m1, m2), (physics.poly_spring(k=k1, k3=k3, c=5.0), physics.poly_spring()),
                            {(0, 1): physics.poly_spring(k=k12, c=1.5)}, struck=1)
    train, held = _mdof_records(out, rng, cid, system, peaks, 0.7 * peaks[1], width, 8192, 3.0,
                                ["acc_root", "acc_tip"])
    coupling = [{"x1^3": k3}, {}]
    return {"id": cid, "kind": "mdof", "system": "modes near 1:3, cubic spring to ground", "files": train,
            "heldout": held, "freqs_hz": list(map(float, freqs)), "masses": [m1, m2], "via_h5": False,
            "driving_point": "acc_tip", "expect": ["modal_coupling"], "coupling": coupling, "fs": 8192}


def _tune_ratio(m1, m2, k1, ratio):
    lo, hi = 1.0, 1e7
    for _ in range(200):
        k12 = np.sqrt(lo * hi)
        f = physics.free_mode_frequencies([m1, m2], np.array([[k1 + k12, -k12], [-k12, k12]]))
        if f[1] / f[0] > ratio:
            lo = k12
        else:
            hi = k12
    return float(k12)


def make_nes(out, rng, cid, *, via_h5=True):
    """A linear oscillator with a nonlinear energy sink (4 % mass on a purely cubic spring)."""
    m1, m2, k1 = 2.0, 0.08, 2.0 * w(18.0) ** 2
    peaks, width = (60.0, 160.0, 110.0), 1.5e-3
    a = amp(m1, 18.0, peaks[1], width)
    knl = 0.3 * m2 * w(18.0) ** 2 / (0.5 * a) ** 2
    system = physics.System((m1, m2), (physics.poly_spring(k=k1, c=2.0), physics.poly_spring()),
                            {(0, 1): physics.poly_spring(k3=knl, c=0.4)})
    train, held = _mdof_records(out, rng, cid, system, peaks, 0.7 * peaks[1], width, 2048, 4.0, ["acc1", "acc2"])
    return {"id": cid, "kind": "mdof", "system": "linear oscillator + nonlinear energy sink", "files": train,
            "heldout": held, "freqs_hz": [18.0], "masses": [m1, m2], "via_h5": via_h5, "driving_point": None,
            "expect": ["modal_coupling", "missing_mode"], "coupling": None, "fs": 2048}


# ---- (c) real-record quirks ------------------------------------------------------------------------

def make_quirk(out, rng, cid, *, m, f_hz, zeta, fs, peak, width, what, library, sensor="acc", snr=45.0,
               bits=24, r3=0.0, r2=0.0, rc3=0.0, rq=0.0, ppm=(0.0, 0.0), cut_before=None, force=True,
               n_train=1, digits=7, dur=None):
    """One identification case: ``n_train`` training blows and one held-out blow at 70 %."""
    system, law, a = _sdof_case(m, f_hz, zeta, r3=r3, r2=r2, rc3=rc3, rq=rq, peak=peak, width=width)
    dur = dur or min(ring_periods(f_hz, zeta), 8.0)
    chains = [sensors.Chain(snr_db=snr, bits=bits, range_factor=2.0, offset_frac=0.01)]
    levels = [peak * s for s in (0.6, 1.0, 1.4)[:n_train]] if n_train > 1 else [peak]
    clocks = list(ppm) + [0.0] * (n_train + 1)
    files = []
    for j, p in enumerate([*levels, 0.7 * peak]):
        cols, _ = records.impact_record(system, p, width, fs, dur, pre=0.0 if cut_before is not None else 0.25,
                                        clock_ppm=clocks[j], chains=chains, channels=(sensor,), rng=rng,
                                        cut_before=cut_before)
        cols = records.name_columns(cols, {(sensor, 0): sensor})
        if not force:
            cols.pop("force")
        stamped = fs * (1 + clocks[j] * 1e-6) if any(ppm) else fs  # each DAQ stamps its calibrated rate
        tag = "h" if j == len(levels) else "r"
        files.append(write(out, f"{cid}-{tag}{j}.csv", cols, stamped, digits=digits))
    damping, stiffness = law_terms(**law)
    return {"id": cid, "kind": "quirk", "what": what, "mass": m, "f1_hz": f_hz, "fs": fs,
            "samples_per_cycle": fs / f_hz, "files": files[:-1], "heldout": files[-1],
            "truth": {"damping": damping, "stiffness": stiffness}, "library": library, "amp_m": a,
            "vel_ms": a * w(f_hz), "ppm": list(ppm)}


def quirk_specs(quick):
    """(id, kwargs) of the quirk cases; the quick set first."""
    lib = {"damping": ["v"], "stiffness": ["x", "x^3"]}
    specs = [
        ("q-ppm", dict(m=0.8, f_hz=35.0, zeta=0.006, fs=10000, peak=70, width=1.0e-3, r3=0.2, n_train=3,
                       ppm=(60.0, -90.0, 140.0, -40.0), what="records' rates differ by 50-230 ppm", library=lib)),
        ("q-spc25", dict(m=0.4, f_hz=80.0, zeta=0.005, fs=2000, peak=40, width=0.7e-3, r3=0.15,
                         what="2 kHz, 25 samples per cycle", library=lib)),
        ("q-nopre", dict(m=1.2, f_hz=30.0, zeta=0.008, fs=8000, peak=90, width=1.2e-3, r3=0.2,
                         cut_before=0.3e-3, what="record starts at the trigger, mid-blow (no pre-trigger)",
                         library=lib)),
        ("q-vel", dict(m=3.0, f_hz=15.0, zeta=0.007, fs=5000, peak=250, width=2.0e-3, r3=-0.08, sensor="vel",
                       snr=50.0, what="laser vibrometer (velocity only), softening", library=lib)),
        ("q-light", dict(m=0.010, f_hz=400.0, zeta=0.004, fs=40000, peak=4.0, width=0.15e-3, r3=0.15,
                         what="10 g at 400 Hz, 40 kHz", library=lib)),
        ("q-heavy", dict(m=200.0, f_hz=6.0, zeta=0.012, fs=2000, peak=6000, width=6e-3, r3=-0.06,
                         what="200 kg at 6 Hz, sledge hammer, 2 kHz", library=lib)),
        ("q-spc20", dict(m=0.05, f_hz=250.0, zeta=0.004, fs=5000, peak=8, width=0.3e-3, r3=0.1, r2=0.05,
                         what="20 samples per cycle, asymmetric", library={"damping": ["v"],
                                                                          "stiffness": ["x", "x^2", "x^3"]})),
        ("q-disp", dict(m=2.0, f_hz=25.0, zeta=0.004, fs=2000, peak=150, width=1.5e-3, r3=0.1, rq=1.0,
                        sensor="disp", snr=48.0, bits=16, what="eddy-current displacement probe, 16 bit, drag",
                        library={"damping": ["v", "abs(v)*v"], "stiffness": ["x", "x^3"]})),
        ("q-free", dict(m=0.6, f_hz=45.0, zeta=0.004, fs=10000, peak=60, width=1.0e-3, r3=0.15, rc3=1.0,
                        force=False, cut_before=0.02, what="free ring-down starting in motion, no force column",
                        library={"damping": ["v", "v^3"], "stiffness": ["x", "x^3"]})),
    ]
    return specs[:6] if quick else specs
