"""Diagnosis cases (d): multi-capture nulls and hidden effects, out of the catalogue and in it.

A capture set is two DAQ sessions (different noise seeds, clocks and sensor offsets) of blows at
several levels. ``expect`` lists the right verdicts; ``near`` the defensible look-alikes.
"""

from __future__ import annotations

import numpy as np

import physics
import records
import sensors
from design import amp, ring_periods, w, write

CATALOGUE = ("coulomb_friction", "quadratic_damping", "cubic_damping", "clearance", "smooth_stiffening",
             "asymmetric_stiffness", "second_mode", "sensor_highpass")


def _captures(out, rng, cid, system, *, fs, peaks, width, dur, sensor="acc", snr=(42.0, 50.0), highpass=0.0,
              sessions=2, ppm=(0.0, 0.0), digits=7, pre=0.25):
    files = []
    for s in range(sessions):
        chain = sensors.Chain(snr_db=float(rng.uniform(*snr)), bits=24, range_factor=float(rng.uniform(1.5, 3)),
                              highpass_hz=highpass, gain_error=float(rng.uniform(-0.01, 0.01)),
                              offset_frac=float(rng.uniform(-0.02, 0.02)))
        for j, p in enumerate(peaks):
            cols, _ = records.impact_record(system, p * float(rng.uniform(0.9, 1.1)), width, fs, dur, pre=pre,
                                            clock_ppm=ppm[s % len(ppm)], chains=[chain], channels=(sensor,),
                                            rng=rng)
            cols = records.name_columns(cols, {(sensor, 0): sensor})
            stamped = fs * (1 + ppm[s % len(ppm)] * 1e-6)
            files.append({"file": write(out, f"{cid}-s{s}-{j}.csv", cols, stamped, digits=digits), "session": s})
    return files


def _entry(cid, hidden, expect, near, m, f_hz, fs, files, *, given_mass=None, symptom=None, note=""):
    return {"id": cid, "kind": "diagnose", "hidden": hidden, "expect": expect, "near": near,
            "catalogued": hidden is None or hidden in CATALOGUE, "mass": given_mass or m, "true_mass": m,
            "f1_hz": f_hz, "fs": fs, "captures": files, "symptom": symptom, "note": note}


def _poly(m, f_hz, zeta, a, r3=0.0, r2=0.0, rc3=0.0):
    k = m * w(f_hz) ** 2
    c = 2 * zeta * np.sqrt(k * m)
    v = a * w(f_hz)
    return records.sdof(m, k=k, k3=r3 * k / a ** 2, k2=r2 * k / a, c=c, c3=rc3 * c / v ** 2)


# ---- nulls: the default libraries hold the truth ----------------------------------------------------

NULLS = [
    # id, m [kg], f [Hz], zeta, fs [Hz], sensor, r3, r2, rc3, ppm per session, peak [N], width [s]
    ("null-duff10k", 0.3, 60.0, 0.006, 10000, "acc", 0.15, 0.0, 0.0, (0.0, 0.0), 35.0, 0.8e-3),
    ("null-spc24", 0.5, 125.0, 0.004, 3000, "acc", 0.1, 0.0, 0.0, (0.0, 0.0), 30.0, 0.6e-3),
    ("null-vel", 4.0, 12.0, 0.01, 2000, "vel", -0.06, 0.0, 0.5, (0.0, 0.0), 300.0, 2.5e-3),
    ("null-light40k", 0.020, 300.0, 0.004, 40000, "acc", 0.05, 0.05, 0.0, (0.0, 0.0), 5.0, 0.2e-3),
    ("null-heavy", 200.0, 5.0, 0.012, 2000, "acc", 0.08, 0.0, 0.0, (0.0, 0.0), 5000.0, 6e-3),
    ("null-ppm150", 1.0, 30.0, 0.007, 6000, "acc", 0.12, 0.0, 0.0, (0.0, 150.0), 80.0, 1.2e-3),
]


def make_null(out, rng, spec):
    cid, m, f_hz, zeta, fs, sensor, r3, r2, rc3, ppm, peak, width = spec
    a = amp(m, f_hz, peak, width)
    system = _poly(m, f_hz, zeta, a, r3=r3, r2=r2, rc3=rc3)
    dur = min(ring_periods(f_hz, zeta), 8.0)
    files = _captures(out, rng, cid, system, fs=fs, peaks=(0.5 * peak, peak, 0.75 * peak), width=width, dur=dur,
                      sensor=sensor, ppm=ppm)
    return _entry(cid, None, ["none"], [], m, f_hz, fs, files,
                  note=f"{m} kg, {f_hz} Hz, {fs} Hz ({fs / f_hz:.0f} samples/cycle), {sensor}, 6 captures")


# ---- hidden effects -----------------------------------------------------------------------------------

def make_backlash(out, rng, cid="hid-backlash"):
    """Preloaded spring pair: full stiffness inside +-d, 45 % of it beyond (a softening knee)."""
    m, f_hz, zeta, fs, peak, width = 1.0, 25.0, 0.006, 5000, 90.0, 1.2e-3
    a = amp(m, f_hz, peak, width)
    k = m * w(f_hz) ** 2
    c = 2 * zeta * np.sqrt(k * m)
    system = physics.System((m,), (physics.add(physics.preloaded_backlash(k, 0.45 * k, 0.4 * a),
                                                physics.poly_spring(c=c)),))
    files = _captures(out, rng, cid, system, fs=fs, peaks=(0.6 * peak, peak), width=width,
                      dur=ring_periods(f_hz, zeta))
    return _entry(cid, "preloaded_backlash", ["unexplained"], [], m, f_hz, fs, files,
                  note="stiffness drops to 45 % beyond 40 % of the peak amplitude (preload lost)")


def make_thermal(out, rng, cid="hid-thermal"):
    """Stiffness drifting -1.2 %/s through every record (a warming spring), 4 s records."""
    m, f_hz, zeta, fs, peak, width = 0.5, 40.0, 0.003, 5000, 40.0, 0.9e-3
    k = m * w(f_hz) ** 2
    c = 2 * zeta * np.sqrt(k * m)
    system = physics.System((m,), (physics.drifting_spring(k, -0.012, c),))
    files = _captures(out, rng, cid, system, fs=fs, peaks=(0.6 * peak, peak), width=width, dur=4.0, pre=0.25)
    return _entry(cid, "stiffness_drift_in_time", ["unexplained"], [], m, f_hz, fs, files,
                  note="k falls 1.2 % per second of record (5 % over a record)")


def make_massload(out, rng, cid="hid-massload"):
    """A 10 g oscillator carrying a 2.5 g accelerometer the user forgot: true mass 12.5 g, given 10 g."""
    m_true, f_hz, zeta, fs, peak, width = 0.0125, 220.0, 0.004, 20000, 3.0, 0.2e-3
    a = amp(m_true, f_hz, peak, width)
    system = _poly(m_true, f_hz, zeta, a, r3=0.1)
    files = _captures(out, rng, cid, system, fs=fs, peaks=(0.6 * peak, peak), width=width,
                      dur=ring_periods(f_hz, zeta))
    e = _entry(cid, "mass_loading", ["unexplained"], [], m_true, f_hz, fs, files, given_mass=0.010,
               symptom="impulse_mass", note="given mass 10 g, true 12.5 g (accelerometer mass)")
    return e


def make_rattle(out, rng, cid="hid-rattle"):
    """A loose 40 g part rattling in a +-0.1 A gap on a 1 kg oscillator (Hertz contacts, lossy)."""
    m, m2, f_hz, zeta, fs, peak, width = 1.0, 0.04, 30.0, 0.005, 10000, 100.0, 1.2e-3
    a = amp(m, f_hz, peak, width)
    k = m * w(f_hz) ** 2
    c = 2 * zeta * np.sqrt(k * m)
    gap = 0.1 * a
    k_c = 2.0 * k / np.sqrt(gap)                          # 2 k gap of force at an indentation of one gap
    system = physics.System((m, m2), (physics.poly_spring(k=k, c=c), physics.poly_spring(c=0.02)),
                            {(0, 1): physics.contact(k_c, gap, 0.5 / (a * w(f_hz)))})
    files = _captures(out, rng, cid, system, fs=fs, peaks=(0.6 * peak, peak), width=width,
                      dur=ring_periods(f_hz, zeta))
    return _entry(cid, "rattling_contact", ["unexplained"], [], m, f_hz, fs, files,
                  note="40 g part loose in a gap of 10 % of the amplitude")


def make_iepe(out, rng, cid="cat-iepe"):
    """IEPE accelerometer, 1.5 Hz corner, on a 5 kg, 7 Hz oscillator (catalogued: sensor_highpass)."""
    m, f_hz, zeta, fs, peak, width = 5.0, 7.0, 0.008, 2000, 400.0, 3e-3
    a = amp(m, f_hz, peak, width)
    system = _poly(m, f_hz, zeta, a, r3=0.08)
    files = _captures(out, rng, cid, system, fs=fs, peaks=(0.6 * peak, peak), width=width,
                      dur=min(ring_periods(f_hz, zeta), 8.0), highpass=1.5)
    return _entry(cid, "sensor_highpass", ["sensor_highpass"], [], m, f_hz, fs, files,
                  note="first-order AC coupling at 1.5 Hz")


def make_drag(out, rng, cid="cat-drag"):
    """Quadratic air drag dominating a 50 g, 200 Hz oscillator at 40 kHz (catalogued)."""
    m, f_hz, zeta, fs, peak, width = 0.05, 200.0, 0.0015, 40000, 8.0, 0.25e-3
    a = amp(m, f_hz, peak, width)
    k = m * w(f_hz) ** 2
    c = 2 * zeta * np.sqrt(k * m)
    cq = 3.0 * c / (a * w(f_hz))
    system = records.sdof(m, k=k, c=c, cq=cq)
    files = _captures(out, rng, cid, system, fs=fs, peaks=(0.6 * peak, peak), width=width, dur=0.8)
    return _entry(cid, "quadratic_damping", ["quadratic_damping"], ["cubic_damping"], m, f_hz, fs, files,
                  note="drag force 3x the viscous one at the peak velocity")


def make_friction(out, rng, cid="cat-friction"):
    m, f_hz, zeta, fs, peak, width = 2.0, 20.0, 0.002, 5000, 120.0, 1.5e-3
    a = amp(m, f_hz, peak, width)
    k = m * w(f_hz) ** 2
    c = 2 * zeta * np.sqrt(k * m)
    system = physics.System((m,), (physics.add(physics.poly_spring(k=k, c=c),
                                                physics.friction(0.01 * k * a, 0.002 * a * w(f_hz))),))
    files = _captures(out, rng, cid, system, fs=fs, peaks=(0.6 * peak, peak), width=width, dur=2.5)
    return _entry(cid, "coulomb_friction", ["coulomb_friction"], [], m, f_hz, fs, files,
                  note="dry friction 1 % of the peak spring force")


def diag_cases(out, rng_for, quick):
    nulls = NULLS[:2] if quick else NULLS
    cases = [make_null(out, rng_for(s[0]), s) for s in nulls]
    hidden = [make_backlash, make_thermal, make_rattle, make_massload]
    if not quick:
        hidden += [make_iepe, make_drag, make_friction]
    return cases + [fn(out, rng_for(fn.__name__)) for fn in hidden]
