#!/usr/bin/env python3
"""Generate the blind held-out scorecard data: CSV captures + a ground-truth manifest.

Own physics (``physics.py``: solve_ivp on its own ODE, own hammer, sensor, noise, ADC and
clock models); nothing from ``eddi`` or ``simulated_rig`` is imported. Output, in ``--out``:

    manifest.json            cases, files, masses, true coefficients, expected verdicts
    <case>/<record>.csv      t,force,acc (or t,acc) in SI units, pre-trigger included

Cases
-----
identify/*   Duffing-type oscillators (0.05-20 kg, 2-200 Hz, 2-40 kHz, 30-60 dB, soft and hard
             springs, viscous + x^2 v / v^3 damping); a training record and a held-out record at
             another impact level whose sample clock differs by 50-150 ppm. Plus stress cases
             where the model must warn (strong dry friction, few zero crossings).
nulls/*      >= 6 captures of a cubic Duffing with viscous damping only: expected cause "none".
effects/*    >= 6 captures with one hidden mechanism: catalogued ones (expected its name) and
             out-of-catalogue ones (expected "unexplained").

Usage: ``python benchmarks/unseen/generate.py --out /tmp/unseen-data --seed 1 [--quick]``
"""

from __future__ import annotations

import argparse
import zlib
import json
import math
import re
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from physics import Oscillator, impact_record, with_extras  # noqa: E402

CATALOGUE = ("coulomb_friction", "quadratic_damping", "clearance", "asymmetric_stiffness",
             "second_mode", "sensor_highpass")


SEED = [20261123]
CASE_FILTER = [None]


def wanted(case_id: str) -> bool:
    return CASE_FILTER[0] is None or re.search(CASE_FILTER[0], case_id) is not None


def case_rng(case_id: str):
    """Random stream of one case: the same data for a case whatever subset is generated."""
    return np.random.default_rng([SEED[0], zlib.crc32(case_id.encode())])


def duffing(m, fn, zeta, eps, amp, d2=0.0, d3=0.0):
    """Oscillator from ``fn`` [Hz], damping ratio, cubic ratio ``eps = k3 A^2 / k1`` at ``amp``,
    ``d2 = c2 A^2 / c`` and ``d3 = c3 (w A)^2 / c`` (nonlinear damping relative to viscous)."""
    w = 2 * math.pi * fn
    k1 = m * w * w
    c = 2 * zeta * m * w
    return Oscillator(m=m, c=c, k1=k1, k3=eps * k1 / amp ** 2, c2=d2 * c / amp ** 2,
                      c3=d3 * c / (w * amp) ** 2)


def default_amp(fn):
    """A typical displacement amplitude [m] for a structure at ``fn`` Hz."""
    return float(np.clip(2e-3 * (20.0 / fn), 2e-5, 1e-2))


def pulse_tau(fn, rate):
    period = 1.0 / fn
    return float(min(max(0.08 * period, 6.0 / rate, 3e-4), 0.3 * period, 8e-3))


def record_duration(osc, zeta, n_tau=4.0, min_cycles=30, max_samples=60000, rate=1e4):
    tau_env = 1.0 / (zeta * 2 * math.pi * osc.fn)
    d = max(n_tau * tau_env, min_cycles / osc.fn)
    return float(min(d, max_samples / rate))


def write_csv(path: Path, rec, with_force: bool) -> None:
    cols = [rec.t]
    fmt = ["%.12g"]
    head = ["t"]
    if with_force and rec.force is not None:
        cols.append(rec.force)
        fmt.append("%.9g")
        head.append("force")
    cols.append(rec.acc)
    fmt.append("%.9g")
    head.append("acc")
    np.savetxt(path, np.column_stack(cols), fmt=fmt, delimiter=",", header=",".join(head),
               comments="")


def truth_terms(osc: Oscillator):
    damping = {"v": osc.c}
    if osc.c2:
        damping["x^2*v"] = osc.c2
    if osc.c3:
        damping["v^3"] = osc.c3
    stiffness = {"x": osc.k1}
    if osc.k3:
        stiffness["x^3"] = osc.k3
    return damping, stiffness


# --------------------------------------------------------------------------------------------
# identification cases
# --------------------------------------------------------------------------------------------

#: (name, m, fn, rate, snr, zeta, eps, d2, d3, with_force, quick)
IDENT = [
    ("light-hard-40k", 0.05, 150.0, 40000, 50, 0.010, 0.20, 1.0, 0.0, True, True),
    ("heavy-soft-2k", 20.0, 2.0, 2000, 40, 0.020, -0.10, 0.0, 0.0, True, True),
    ("25spc-hard-v3", 1.0, 200.0, 5000, 45, 0.008, 0.25, 0.0, 1.0, True, True),
    ("41spc-hard", 0.5, 50.0, 2048, 45, 0.010, 0.30, 0.0, 0.0, True, True),
    ("mid-soft-30dB", 5.0, 20.0, 10000, 30, 0.015, -0.12, 0.0, 0.0, True, True),
    ("both-nl-damping-60dB", 0.2, 80.0, 20000, 60, 0.006, 0.15, 1.5, 1.0, True, True),
    ("acc-only-no-force", 2.0, 10.0, 4000, 45, 0.012, 0.20, 0.0, 0.0, False, True),
    ("30spc-soft-35dB", 0.1, 100.0, 3000, 35, 0.010, -0.15, 0.5, 0.0, True, False),
    ("slow-3hz-hard-8k", 8.0, 3.0, 8000, 50, 0.010, 0.25, 0.0, 0.5, True, False),
    ("fast-180hz-24k", 0.3, 180.0, 24000, 40, 0.004, 0.10, 0.0, 0.0, True, False),
    ("mid-x2v-12k", 1.5, 35.0, 12000, 55, 0.020, 0.30, 2.0, 0.0, True, False),
    ("20spc-linearish", 0.8, 100.0, 2000, 45, 0.010, 0.05, 0.0, 0.0, True, False),
]


def make_identify(root: Path, rng, quick: bool):
    cases = []
    for name, m, fn, rate, snr, zeta, eps, d2, d3, with_force, is_quick in IDENT:
        if (quick and not is_quick) or not wanted(f"identify/{name}"):
            continue
        rng = case_rng(f"identify/{name}")
        amp = default_amp(fn)
        osc = duffing(m, fn, zeta, eps, amp, d2, d3)
        dur = record_duration(osc, zeta, rate=rate, max_samples=120000)
        pre = min(0.25, 0.1 * dur) if True else 0.0
        tau = pulse_tau(fn, rate)
        ppm = float(rng.uniform(50, 150)) * (1 if rng.uniform() < 0.5 else -1)
        d = root / "identify" / name
        d.mkdir(parents=True, exist_ok=True)
        files = []
        for k, (level, rppm) in enumerate(((1.0, 0.0), (0.8, ppm))):
            rec = impact_record(osc, rate_nominal=rate, ppm=rppm, duration=dur, pretrigger=pre,
                                amp=amp * level, tau=tau, snr_db=snr, rng=rng,
                                with_force=with_force)
            f = d / ("train.csv" if k == 0 else "heldout.csv")
            write_csv(f, rec, with_force)
            files.append(str(f.relative_to(root)))
        damping, stiffness = truth_terms(osc)
        cases.append({
            "id": f"identify/{name}", "kind": "identify", "group": _ident_group(fn, rate, snr),
            "quick": is_quick, "files": files, "mass": m, "truth": {"damping": damping, "stiffness": stiffness},
            "params": {"fn_hz": fn, "rate_hz": rate, "samples_per_cycle": rate / fn, "snr_db": snr,
                       "zeta": zeta, "cubic_ratio_at_amp": eps, "amp_m": amp, "pulse_s": tau,
                       "heldout_rate_ppm": ppm, "heldout_level": 0.8, "with_force": with_force,
                       "pretrigger_s": pre},
            "expect_poor": False,
        })
    # stress: the model the default library can give is poor -> a warning is expected
    stress = [
        ("strong-friction", dict(coulomb=0.04), 0.5, 15.0, 5000, 45, 0.004, 0.1, True),
        ("few-crossings-heavy-damping", {}, 1.0, 30.0, 10000, 45, 0.08, 0.1, True),
    ]
    for name, ex, m, fn, rate, snr, zeta, eps, is_quick in stress:
        if (quick and not is_quick) or not wanted(f"identify/{name}"):
            continue
        rng = case_rng(f"identify/{name}")
        amp = default_amp(fn)
        osc = duffing(m, fn, zeta, eps, amp)
        if "coulomb" in ex:
            osc = with_extras(osc, coulomb={"fc": ex["coulomb"] * osc.k1 * amp})
        dur = max(record_duration(osc, zeta, rate=rate), 2.0)
        tau = pulse_tau(fn, rate)
        d = root / "identify" / name
        d.mkdir(parents=True, exist_ok=True)
        files = []
        for k, level in enumerate((1.0, 0.8)):
            rec = impact_record(osc, rate_nominal=rate, ppm=0.0 if k == 0 else 80.0, duration=dur,
                                pretrigger=0.2, amp=amp * level, tau=tau, snr_db=snr, rng=rng)
            f = d / ("train.csv" if k == 0 else "heldout.csv")
            write_csv(f, rec, True)
            files.append(str(f.relative_to(root)))
        damping, stiffness = truth_terms(osc)
        truth = {"damping": damping, "stiffness": stiffness}
        if "coulomb" in ex:
            truth["coulomb_force_n"] = osc.extras["coulomb"]["fc"]
        cases.append({
            "id": f"identify/{name}", "kind": "identify", "group": "stress", "quick": is_quick,
            "files": files, "mass": m, "truth": truth,
            "params": {"fn_hz": fn, "rate_hz": rate, "samples_per_cycle": rate / fn, "snr_db": snr,
                       "zeta": zeta, "amp_m": amp, "extras": ex},
            # strong friction: a smooth library cannot hold it -> must warn (or fit well anyway);
            # heavy damping: few crossings -> must still answer (item 4 of issue 10)
            "expect_poor": "coulomb" in ex,
        })
    return cases


def _ident_group(fn, rate, snr):
    spc = rate / fn
    if spc < 50:
        return "low-spc(<50)"
    if snr <= 40:
        return "noisy(<=40dB)"
    return "nominal"


# --------------------------------------------------------------------------------------------
# diagnosis sets
# --------------------------------------------------------------------------------------------

#: base systems: (name, m, fn, rate, snr, zeta, eps)
BASES = {
    "B1": ("B1", 0.4, 9.0, 4000, 45, 0.010, 0.15),
    "B2": ("B2", 3.0, 25.0, 10000, 35, 0.008, -0.10),
    "B3": ("B3", 0.08, 60.0, 20000, 55, 0.012, 0.25),
    "B4": ("B4", 12.0, 4.0, 2000, 30, 0.015, 0.10),
    "B5": ("B5", 1.2, 80.0, 40000, 60, 0.010, 0.20),
    "B6": ("B6", 0.15, 120.0, 6000, 40, 0.010, -0.08),
}


def base_osc(key):
    name, m, fn, rate, snr, zeta, eps = BASES[key]
    amp = default_amp(fn)
    return duffing(m, fn, zeta, eps, amp), amp, rate, snr, zeta


def _second_mode(osc, ratio, m2_frac, kc_frac, zeta2=0.01):
    """A mode coupled by ``kc``; ``k2`` chosen so the coupled pair's frequency ratio is ``ratio``."""
    m1, k1 = osc.m, osc.k1
    m2 = m2_frac * m1
    kc = kc_frac * k1

    def ratio_of(k2):
        kk = np.array([[k1 + kc, -kc], [-kc, k2 + kc]])
        mm = np.diag([m1, m2])
        ev = np.sort(np.linalg.eigvals(np.linalg.solve(mm, kk)).real)
        return math.sqrt(ev[1] / ev[0]), ev

    lo, hi = 1e-6 * k1, 1e4 * k1
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        r, _ = ratio_of(mid)
        lo, hi = (mid, hi) if r < ratio else (lo, mid)
    k2 = math.sqrt(lo * hi)
    _, ev = ratio_of(k2)
    w2 = math.sqrt(ev[1])
    return {"m2": m2, "k2": k2, "kc": kc, "c2": 2 * zeta2 * m2 * w2}, math.sqrt(ev[0]) / (2 * math.pi), w2 / (2 * math.pi)


def effect_sets(quick: bool):
    """(id, base, extras-builder, expected causes, diagnose args, quick, note)."""
    E = []
    E.append(("coulomb_friction", "B1", lambda o, A: dict(coulomb={"fc": 0.008 * o.k1 * A}),
              ["coulomb_friction"], [], True, "exact stick-slip Coulomb, F_c = 0.8 % of k1 A"))
    E.append(("clearance", "B2", lambda o, A: dict(clearance={"gap": 0.4 * A, "k": 0.6 * o.k1}),
              ["clearance"], [], True, "contact spring 0.6 k1 beyond a gap 0.4 A"))
    E.append(("quadratic_drag", "B3", lambda o, A: dict(quadratic_drag={"cq": 0.15 * o.k1 * A / (2 * math.pi * o.fn * A) ** 2}),
              ["quadratic_damping", "quadratic_drag"], [], True, "|v| v drag at 15 % of k1 A at the typical velocity"))
    E.append(("asymmetric_stiffness", "B1", lambda o, A: dict(even_stiffness={"k2": 0.12 * o.k1 / A}),
              ["asymmetric_stiffness"], ["--stiffness", "x,x^3"], True, "k2 x^2 at 12 % of k1 A (library x,x^3 as docs/effects.md says)"))
    E.append(("second_mode", "B2", "second_mode:2.43:0.15:0.25",
              ["second_mode"], [], True, "coupled 2nd mode at 2.43 f1 (m2 0.15 m, kc 0.25 k1)"))
    E.append(("sensor_highpass", "B4", "highpass:1.5",
              ["sensor_highpass"], [], True, "AC-coupled accelerometer, first-order high-pass at 1.5 Hz (fn 4 Hz)"))
    E.append(("bouc_wen", "B3", lambda o, A: dict(bouc_wen={"alpha": 0.6, "beta": 0.5 / (0.5 * A), "gamma": 0.5 / (0.5 * A), "n": 1}),
              ["unexplained"], [], True, "Bouc-Wen hysteresis, 40 % of k1 hysteretic, yield at 0.5 A (out of catalogue)"))
    E.append(("x_abs_x", "B5", lambda o, A: dict(xabsx={"kq": 0.3 * o.k1 / A}),
              ["unexplained", "smooth_stiffening"], [], True, "smooth x|x| stiffening at 30 % of k1 A (out of catalogue)"))
    E.append(("thermal_drift", "B2", "drift",
              ["unexplained"], [], True, "k1 drifts +2 % per capture and within each record (out of catalogue)"))
    E.append(("mode_1to3", "B1", "second_mode:3.0:0.2:0.3",
              ["unexplained", "second_mode"], [], True, "second mode at exactly 3 f1 (1:3, on the cubic harmonic)"))
    # full set only: other bases / strengths
    E.append(("coulomb_friction-b6", "B6", lambda o, A: dict(coulomb={"fc": 0.01 * o.k1 * A}),
              ["coulomb_friction"], [], False, "Coulomb 1 % of k1 A on a soft 120 Hz system"))
    E.append(("clearance-b5", "B5", lambda o, A: dict(clearance={"gap": 0.5 * A, "k": 1.0 * o.k1}),
              ["clearance"], [], False, "contact 1.0 k1 beyond 0.5 A"))
    E.append(("quadratic_drag-b4", "B4", lambda o, A: dict(quadratic_drag={"cq": 0.2 * o.k1 * A / (2 * math.pi * o.fn * A) ** 2}),
              ["quadratic_damping", "quadratic_drag"], [], False, "drag 20 % on the 4 Hz 30 dB base"))
    E.append(("sensor_highpass-b1", "B1", "highpass:3.0",
              ["sensor_highpass"], [], False, "high-pass 3 Hz on a 9 Hz base"))
    E.append(("second_mode-b5", "B5", "second_mode:2.7:0.1:0.4",
              ["second_mode"], [], False, "2nd mode at 2.7 f1"))
    E.append(("bouc_wen-b1", "B1", lambda o, A: dict(bouc_wen={"alpha": 0.7, "beta": 0.5 / (0.7 * A), "gamma": 0.5 / (0.7 * A), "n": 1}),
              ["unexplained"], [], False, "Bouc-Wen 30 % hysteretic"))
    E.append(("x_abs_x-b6", "B6", lambda o, A: dict(xabsx={"kq": -0.2 * o.k1 / A}),
              ["unexplained", "smooth_stiffening"], [], False, "softening x|x| 20 %"))
    return [e for e in E if e[5] or not quick]


def make_set(root: Path, rng, set_id: str, base: str, extras, n_capt: int, note: str,
             expected, diag_args, is_quick: bool, kind: str, ppm_spread: float = 0.0):
    if not wanted(set_id):
        return None
    rng = case_rng(set_id)
    osc, amp, rate, snr, zeta = base_osc(base)
    hp = None
    drift = False
    info = {}
    if isinstance(extras, str):
        if extras.startswith("second_mode"):
            _, ratio, m2f, kcf = extras.split(":")
            sm, f1, f2 = _second_mode(osc, float(ratio), float(m2f), float(kcf))
            osc = with_extras(osc, second_mode=sm)
            info = {"coupled_f1_hz": f1, "coupled_f2_hz": f2, **sm}
        elif extras.startswith("highpass"):
            hp = float(extras.split(":")[1])
            info = {"highpass_corner_hz": hp}
        elif extras == "drift":
            drift = True
            info = {"k1_offset_per_capture": 0.02, "k1_rate_per_s": 0.004}
    elif extras is not None:
        ex = extras(osc, amp)
        osc = with_extras(osc, **ex)
        info = {k: v for k, v in ex.items()}
    dur = record_duration(osc, zeta, n_tau=3.5, rate=rate, max_samples=30000)
    if hp:  # a low-frequency sensor artefact needs the low-frequency tail
        dur = max(dur, 6.0)
    tau = pulse_tau(osc.fn, rate)
    d = root / set_id
    d.mkdir(parents=True, exist_ok=True)
    levels = np.linspace(0.55, 1.15, n_capt) * rng.uniform(0.95, 1.05, n_capt)
    rng.shuffle(levels)
    ppms = np.zeros(n_capt)
    if ppm_spread:  # clocks 50-150 ppm apart from the first record's
        ppms[1:] = rng.uniform(50, ppm_spread, n_capt - 1) * rng.choice([-1, 1])
    files = []
    for j in range(n_capt):
        o = osc
        if drift:
            o = with_extras(osc, drift={"offset": 0.02 * j, "rate_per_s": 0.004})
        rec = impact_record(o, rate_nominal=rate, ppm=float(ppms[j]), duration=dur, pretrigger=0.1,
                            amp=amp * float(levels[j]), tau=tau, snr_db=snr, rng=rng,
                            hp_corner=hp)
        f = d / f"capture-{j}.csv"
        write_csv(f, rec, True)
        files.append(str(f.relative_to(root)))
    damping, stiffness = truth_terms(osc)
    name, m, fn, _, _, _, eps = BASES[base]
    return {
        "id": set_id, "kind": "diagnose", "group": kind, "quick": is_quick, "files": files,
        "mass": osc.m, "expected": expected, "diagnose_args": diag_args, "note": note,
        "truth": {"damping": damping, "stiffness": stiffness, "hidden": _jsonable(info)},
        "params": {"base": base, "fn_hz": fn, "rate_hz": rate, "snr_db": snr, "zeta": zeta,
                   "cubic_ratio_at_amp": eps, "amp_m": amp, "levels": levels.tolist(),
                   "rate_ppm": ppms.tolist(), "duration_s": dur, "pulse_s": tau},
    }


def _jsonable(d):
    return json.loads(json.dumps(d, default=float))


def make_diagnose(root: Path, rng, quick: bool, n_capt: int):
    cases = []
    null_bases = ["B1", "B2", "B3", "B4"] if quick else ["B1", "B2", "B3", "B4", "B5", "B6"] * 2
    for i, b in enumerate(null_bases):
        cases.append(make_set(root, rng, f"nulls/{b}-{i}", b, None, n_capt,
                              "cubic Duffing + viscous only", ["none"], [], i < 4, "null"))
    cases.append(make_set(root, rng, "nulls/B6-ppm", "B6", None, n_capt,
                          "null whose captures' clocks differ by 50-150 ppm (issue 9 item 4: accept <= 200 ppm)",
                          ["none"], [], True, "null-ppm", ppm_spread=150.0))
    for name, base, builder, expected, args, is_quick, note in effect_sets(quick):
        kind = "catalogue" if any(e in CATALOGUE or e == "quadratic_drag" for e in expected if e != "unexplained") and expected[0] != "unexplained" else "out-of-catalogue"
        cases.append(make_set(root, rng, f"effects/{name}", base, builder, n_capt, note, expected,
                              args, is_quick, kind))
    return cases


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, type=Path, help="output directory")
    ap.add_argument("--seed", type=int, default=20261123, help="random seed (noise, levels, clocks)")
    ap.add_argument("--quick", action="store_true", help="the small set (about 9 identify + 14 diagnose cases)")
    ap.add_argument("--captures", type=int, default=6, help="captures per diagnosis set (>= 6 for nulls)")
    ap.add_argument("--only", choices=("identify", "diagnose"), help="generate one kind only")
    ap.add_argument("--cases", default=None, help="regex on case ids: generate only those (same data as in the whole set)")
    args = ap.parse_args(argv)
    SEED[0] = args.seed
    rng = None  # every case draws from case_rng(its id)
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    CASE_FILTER[0] = args.cases
    cases = []
    if args.only in (None, "identify"):
        cases += make_identify(args.out, rng, args.quick)
    if args.only in (None, "diagnose"):
        cases += make_diagnose(args.out, rng, args.quick, args.captures)
    cases = [c for c in cases if c is not None]
    manifest = {"generator": "benchmarks/unseen/generate.py", "seed": args.seed, "quick": args.quick,
                "captures_per_set": args.captures, "catalogue": list(CATALOGUE),
                "noise_definition": "acc: sigma = max|free-response acc| / sqrt(2) * 10^(-snr_db/20), white; force: 60 dB of the peak force; 24-bit ADC; acc offset 0.1 % of peak",
                "cases": cases}
    (args.out / "manifest.json").write_text(json.dumps(manifest, indent=1, default=float))
    print(f"{len(cases)} cases in {args.out} ({time.time() - t0:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
