"""ci95 coverage and bias per term at coarse sampling (8-40 samples per cycle), drawn systems.

Session 12 (s12cov): two blind scorecards found a coarse record (a MATLAB file) whose ``x^2*v``
came out +1.55 % off, outside its ci95, on two seeds. ``bench_ci_coverage_cli.py``'s coarse
family sits at 20-40 samples per cycle on fixed systems; here every record is a fresh draw:

* samples per cycle of the linear frequency 8-40 (``--spc LO:HI``), rate 200 Hz - 2 kHz, mass
  0.1-500 kg, 30-60 dB, damping ratio 0.003-0.02;
* damping law ``x^2*v``, ``v*abs(v)``, ``v^3`` or ``sign(v)`` (Coulomb) beside ``v``, its share
  at the first peak 0.3-2 (Coulomb: 0.05-0.3 of the linear damping force there); ``--laws`` also
  takes ``abs(x)*v`` and mixed laws ``A+B`` (the share split between the terms);
* stiffness linear, hardening or softening cubic (share 0.05-0.4 at the first peak);
* the simulated rig (:func:`simulated_rig.bench.impact_test`: half-sine blow of 0.1-0.3 of a
  period, force + accelerometer, 24 bits), point samples; ``--kernel mean``: both channels as
  means over each sample interval (an integrating ADC, made at 15x the rate), not told to the
  station; ``--record free-acc|free-vel|free-disp``: a free decay from a displaced rest, one
  channel, no force and no rest.

Each record is identified with its own terms by ``station identify FILE --mass M --damping ...
--stiffness ... --json`` in this process (``--via mat``: a MATLAB v5 file of ``t, force, acc``;
``--via csv``: ``t,force,acc`` at ``%.10g``) or by the pipeline on the arrays (``--via arrays``).
For every true coefficient ``z = (c - c_true) / (ci95 / 1.96)``. Printed: coverage per term
and per band of samples per cycle, mean z (the bias in standard errors), RMS z; ``--out F``
keeps one JSON row per record.

Draws are seeded: ``--draw-seed`` picks the systems (``--records N`` of them), the noise seed of
record ``i`` is ``draw_seed * 1000 + i``. Session 12 tuned on draw seeds 1 and 3 and held out
seed 5 with the laws ``x^2*v,v*abs(v),v^3,abs(x)*v`` (``docs/eddi-method.md``, "Session 12").

Session 13 (s13ci95) families: ``--family stick`` (Coulomb ``sign(v)``; a row's ``stuck`` is the
fraction of the record after the response stopped in the friction band, and the summary splits
stuck and moving records) and ``--family mixed`` (``x^2*v + v^3`` together, the split drawn;
``--library wide`` identifies with ``v,x^2*v,v^3``). Tuned on draw seeds 1 and 2, held out 7 and 8
(``docs/eddi-method.md``, "Session 13"). ``--compare BEFORE.jsonl AFTER.jsonl`` prints coverage
before/after per term and the median ratio of the half widths (the price).

Session 14 (s14ci95): ``--family sensor`` draws lab-rate records for a velocity or displacement
sensor (1-20 kHz, 0.1-50 kg, 8-60 Hz, 30-50 dB, damping ``v`` or ``v + v*abs(v)``, linear or
Duffing stiffness, at most 60,000 samples); ``--record impact-vel|impact-disp``: the rig's blow
measured by force + a velocity or displacement sensor (the true channel plus white noise at the
draw's SNR, 24 bits); ``--sensor-corner SHARE``: that sensor AC-coupled (first order, corner
SHARE of the linear frequency), told to the station (``--sensor-highpass``) unless
``--untold-corner``. Tuned on draw seeds 1 and 2, held out 5 and 6 (``docs/eddi-method.md``,
"Session 14").

Run: ``python benchmarks/bench_ci_coverage_coarse.py [--records 60] [--draw-seed 1] [--via mat|csv|arrays]
[--kernel point|mean] [--record impact|impact-vel|impact-disp|free-acc|free-vel|free-disp] [--no-refine] [--laws x^2*v,...]
[--spc 8:40] [--snr 30:60] [--family default|stick|mixed|sensor] [--library true|wide] [--jobs 2] [--out rows.jsonl]``;
``--summary F.jsonl...`` reprints stored
rows (~0.1-1 s per record).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import resource
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from eddi.model import EquationOfMotion  # noqa: E402
from simulated_rig.bench import impact_test  # noqa: E402
from simulated_rig.hammer import HammerSpec  # noqa: E402
from simulated_rig.sensors import accelerometer, force_sensor  # noqa: E402

from bench_ci_coverage import wilson  # noqa: E402

LAWS = ("x^2*v", "v*abs(v)", "v^3", "sign(v)")
STIFF = ("linear", "hardening", "softening")
Z95 = 1.959964


def draw(rng: np.random.Generator, laws: tuple[str, ...], spc: tuple[float, float],
         snr: tuple[float, float] = (30.0, 60.0)) -> dict:
    """One system and its record settings."""
    rate = float(np.exp(rng.uniform(math.log(200.0), math.log(2000.0))))
    n_cycle = float(np.exp(rng.uniform(math.log(spc[0]), math.log(spc[1]))))
    f = rate / n_cycle
    mass = float(np.exp(rng.uniform(math.log(0.1), math.log(500.0))))
    zeta = float(np.exp(rng.uniform(math.log(0.003), math.log(0.02))))
    law = str(rng.choice(laws))
    stiff = str(rng.choice(STIFF))
    share = float(rng.uniform(0.05, 0.3) if "sign(v)" in law else rng.uniform(0.3, 2.0))
    kshare = {"linear": 0.0, "hardening": float(rng.uniform(0.05, 0.4)),
              "softening": -float(rng.uniform(0.03, 0.12))}[stiff]
    return dict(rate=rate, spc=n_cycle, f=f, mass=mass, zeta=zeta, law=law, share=share, stiff=stiff,
                kshare=kshare, snr=float(rng.uniform(*snr)), width=float(rng.uniform(0.1, 0.3)) / f,
                vp=0.1)


#: ``--family``: preset laws (and for ``mixed`` the split of the share between the pair drawn).
#: ``stick``: Coulomb records, most of which stop in the friction band before the record ends
#: (the row's ``stuck``: the fraction of the record after the response stopped); ``mixed``:
#: ``x^2*v + v^3`` together (two damping terms whose loss per cycle both grows like the amplitude
#: cubed: the selection may drop one), the share of ``x^2*v`` drawn in 0.2-0.8.
FAMILIES = {"stick": ("sign(v)",), "mixed": ("x^2*v+v^3",), "sensor": ("v", "v*abs(v)")}


def draw_sensor(rng: np.random.Generator, snr: tuple[float, float]) -> dict:
    """``--family sensor`` (session 14): lab-rate records for a velocity or displacement sensor:
    rate 1-20 kHz, mass 0.1-50 kg, 8-60 Hz, damping ratio 0.005-0.03, 30-50 dB unless ``--snr``
    says otherwise; damping ``v`` alone or with ``v*abs(v)`` (share 0.3-2 at the first peak),
    stiffness linear, hardening or softening cubic (Duffing)."""
    rate = float(np.exp(rng.uniform(math.log(1000.0), math.log(20000.0))))
    f = float(np.exp(rng.uniform(math.log(8.0), math.log(60.0))))
    mass = float(np.exp(rng.uniform(math.log(0.1), math.log(50.0))))
    zeta = float(np.exp(rng.uniform(math.log(0.005), math.log(0.03))))
    law = str(rng.choice(FAMILIES["sensor"]))
    stiff = str(rng.choice(STIFF))
    share = float(rng.uniform(0.3, 2.0))
    kshare = {"linear": 0.0, "hardening": float(rng.uniform(0.05, 0.4)),
              "softening": -float(rng.uniform(0.03, 0.12))}[stiff]
    return dict(rate=rate, spc=rate / f, f=f, mass=mass, zeta=zeta, law=law, share=share, stiff=stiff,
                kshare=kshare, snr=float(rng.uniform(*snr)), width=float(rng.uniform(0.1, 0.3)) / f,
                vp=0.1, max_samples=60000)


def draw_family(rng: np.random.Generator, family: str, laws: tuple[str, ...], spc: tuple[float, float],
                snr: tuple[float, float]) -> dict:
    """One draw of ``family`` (``default``: :func:`draw` from ``laws``)."""
    if family == "sensor":
        return draw_sensor(rng, (30.0, 50.0) if snr == (30.0, 60.0) else snr)
    d = draw(rng, FAMILIES.get(family, laws), spc, snr)
    if family == "mixed":
        d["split"] = float(rng.uniform(0.2, 0.8))
    return d


def true_model(d: dict) -> EquationOfMotion:
    """The drawn system: linear part from ``f, zeta``, shares at the first peak ``v_p``."""
    m, w = d["mass"], 2.0 * math.pi * d["f"]
    k1, b1 = m * w * w, 2.0 * d["zeta"] * m * w
    vp = d["vp"]
    xp = vp / w
    stiffness = {"x": k1}
    if d["kshare"]:
        stiffness["x^3"] = d["kshare"] * k1 / xp**2
    damping = {"v": b1}
    laws = d["law"].split("+")  # a mixed law: the share split among its terms (``split``: the first's)
    parts = [d["split"], 1.0 - d["split"]] if "split" in d and len(laws) == 2 else [1.0 / len(laws)] * len(laws)
    for law, part in zip(laws, parts):
        if law == "v":  # linear damping only
            continue
        scale = {"x^2*v": xp**2, "v^3": vp**2, "v*abs(v)": vp, "sign(v)": 1.0 / vp, "abs(x)*v": xp}[law]
        damping[law] = d["share"] * part * b1 / scale
    return EquationOfMotion.create(mass=m, damping=damping, stiffness=stiffness)


#: Fine samples per output sample when the channels are interval means (``--kernel mean``; odd, so
#: that each mean is centred on its sample time).
MEAN_OSR = 15


@dataclass(frozen=True)
class Averaged:
    """A rig record whose channels are means over each sample interval (an integrating ADC)."""

    t: np.ndarray
    force_n: np.ndarray
    acc_m_s2: np.ndarray


def record(d: dict, seed: int, kernel: str = "point"):
    """The rig's record of the drawn system (force + acceleration, 24 bits): point samples of the
    acceleration (the rig's), or (``kernel="mean"``) both channels as their means over each sample
    interval, made at ``MEAN_OSR`` times the rate with the noise scaled to keep the draw's SNR."""
    if kernel == "mean":
        fine = dict(d, rate=d["rate"] * MEAN_OSR, snr=d["snr"] - 10.0 * math.log10(MEAN_OSR))
        r = record(fine, seed)
        n = (r.t.size - MEAN_OSR // 2) // MEAN_OSR
        idx = MEAN_OSR // 2 + MEAN_OSR * np.arange(n)
        sl = idx[:, None] + np.arange(-(MEAN_OSR // 2), MEAN_OSR // 2 + 1)[None, :]
        sl = sl[sl[:, 0] >= 0]
        ok = sl[:, -1] < r.t.size
        sl = sl[ok]
        return Averaged(t=r.t[sl[:, MEAN_OSR // 2]], force_n=r.force_n[sl].mean(axis=1),
                        acc_m_s2=r.acc_m_s2[sl].mean(axis=1))
    eom = true_model(d)
    hammer = HammerSpec(pulse_width_s=d["width"], double_hit_delay_s=2.0 * d["width"])
    peak = d["mass"] * d["vp"] * math.pi / (2.0 * d["width"])
    b1 = eom.damping["v"]
    span = min(30.0, max(40.0 / d["f"], 7.0 * 2.0 * d["mass"] / b1), 300.0 / d["f"],
               d.get("max_samples", math.inf) / d["rate"])
    sensors = (force_sensor(), accelerometer(snr_db=d["snr"]))
    return impact_test(eom, peak, rate_hz=d["rate"], pretrigger_s=max(0.1, 40.0 / d["rate"]), record_s=span,
                       sensors=sensors, hammer=hammer, seed=seed)


@dataclass(frozen=True)
class Free:
    """A free decay from a displaced rest (no blow, no force, no rest before it), one channel; or
    (``force`` given) the rig's blow measured by a velocity or displacement sensor."""

    t: np.ndarray
    channel: str
    values: np.ndarray
    force: np.ndarray | None = None
    truth_v: np.ndarray | None = None


def sensor_record(d: dict, seed: int, channel: str) -> Free:
    """The rig's impact record (force + ``channel``: ``vel`` or ``disp``): the true velocity or
    displacement plus white noise at the draw's SNR over the active window (as the rig's sensors
    define it), quantised at 24 bits over 1.5x its peak; the force channel as the rig's."""
    from simulated_rig.sensors import active_rms

    r = record(d, seed)
    sig = {"vel": r.truth_v, "disp": r.truth_x}[channel]
    if d.get("corner"):  # the sensor's first-order AC coupling (--sensor-corner)
        from simulated_rig.sensors import ac_couple

        sig = ac_couple(sig, d["corner"] * d["f"], d["rate"])
    sigma = active_rms(sig[r.pretrigger_samples:]) * 10.0 ** (-d["snr"] / 20.0)
    noisy = sig + sigma * np.random.default_rng(seed + 7919).standard_normal(sig.size)
    q = 1.5 * float(np.max(np.abs(sig))) / 2.0**23
    return Free(t=r.t, channel=channel, values=np.round(noisy / q) * q, force=r.force_n, truth_v=r.truth_v)


def free_record(d: dict, seed: int, channel: str) -> Free:
    """``channel`` (``acc``, ``vel``, ``disp``) of the drawn system released from ``x_p = v_p / w``,
    white noise at the draw's SNR over the first 99 % of the signal's energy."""
    from eddi.simulate import simulate
    from simulated_rig.sensors import active_rms

    eom = true_model(d)
    w = 2.0 * math.pi * d["f"]
    span = min(30.0, max(40.0 / d["f"], 7.0 * 2.0 * d["mass"] / eom.damping["v"]), 300.0 / d["f"],
               d.get("max_samples", math.inf) / d["rate"])
    n = int(round(span * d["rate"]))
    res = simulate(eom, rate_hz=d["rate"], n_samples=n, x0=d["vp"] / w, v0=0.0, substeps=None)
    sig = {"acc": res.a, "vel": res.v, "disp": res.x}[channel]
    sigma = active_rms(sig) * 10.0 ** (-d["snr"] / 20.0)
    noisy = sig + sigma * np.random.default_rng(seed).standard_normal(n)
    return Free(t=res.t, channel=channel, values=noisy)


def identify(d: dict, r, via: str, tmp: Path, refine: bool, library: str = "true") -> dict:
    """``{"damping": {...}, "stiffness": {...}, "ci95": {...}, "warnings": [...], "refinement": ...}``;
    ``library``: ``true`` (the system's own terms) or ``wide`` (``v,x^2*v,v^3`` and the stiffness's)."""
    eom = true_model(d)
    if library == "wide":
        eom = eom.model_copy(update={"damping": {"v": 1.0, "x^2*v": 1.0, "v^3": 1.0}})
    if via == "arrays":
        from eddi.fit_record import Pipeline

        pipe = Pipeline(damping=tuple(eom.damping), stiffness=tuple(eom.stiffness), refine=refine)
        if isinstance(r, Free):
            tau = 1.0 / (2.0 * math.pi * d["corner"] * d["f"]) if d.get("corner") and d.get("told", True) else None
            cond = pipe.condition(r.t, **{r.channel: r.values}, force=r.force, ac_coupling_s=tau)
        else:
            cond = pipe.condition(r.t, acc=r.acc_m_s2, force=r.force_n)
        res = pipe.fit(cond, d["mass"])
        return dict(damping=dict(res.model.eom.damping), stiffness=dict(res.model.eom.stiffness),
                    ci95={g: dict(res.ci95[g]) for g in ("damping", "stiffness")},
                    warnings=list(res.choices.warnings), refinement=res.choices.refinement,
                    dropped=list(res.choices.dropped))
    from station.cli import main as station_main

    path = tmp / f"rec.{via}"
    cols = {"t": r.t, "force": r.force_n, "acc": r.acc_m_s2} if not isinstance(r, Free) else \
        {"t": r.t, r.channel: r.values} if r.force is None else {"t": r.t, "force": r.force, r.channel: r.values}
    if via == "mat":
        import scipy.io

        scipy.io.savemat(str(path), cols)
    else:
        np.savetxt(path, np.column_stack(tuple(cols.values())), delimiter=",", header=",".join(cols),
                   comments="", fmt="%.10g")
    corner = (("--sensor-highpass", repr(d["corner"] * d["f"])) if d.get("corner") and d.get("told", True)
              else ())
    argv = ["identify", str(path), "--mass", repr(d["mass"]), *corner, "--damping", ",".join(eom.damping),
            "--stiffness", ",".join(eom.stiffness), "--json", *(() if refine else ("--no-refine",))]
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = station_main(argv)
    if code not in (0, 1):
        raise RuntimeError(f"station identify exit {code}: {err.getvalue().strip()}")
    js = json.loads(out.getvalue())
    return dict(damping=js["damping"], stiffness=js["stiffness"], ci95=js["ci95"], warnings=js["warnings"],
                refinement=js["pipeline"]["refinement"], dropped=list(js["pipeline"].get("dropped", {})))


def stuck_fraction(r) -> float | None:
    """Fraction of an impact record after its true response stopped (``|v| < 1e-4 v_p`` from there
    on: stuck in the friction band); None when the record holds no truth (interval means)."""
    v = getattr(r, "truth_v", None)
    if v is None:
        return None
    moving = np.flatnonzero(np.abs(v) > 1e-5)
    return 0.0 if moving.size == 0 else float(1.0 - (moving[-1] + 1) / v.size)


def one(args: tuple) -> dict:
    """One record: the draw, and per true term ``z``, relative error and relative half width."""
    i, d, seed, via, refine, kind, kernel, library = args
    eom = true_model(d)
    row = dict(i=i, seed=seed, kind=kind, **d, terms={})
    try:
        r = record(d, seed, kernel) if kind == "impact" else \
            sensor_record(d, seed, kind.split("-")[1]) if kind in ("impact-vel", "impact-disp") else \
            free_record(d, seed, kind.split("-")[1])
        row["stuck"] = stuck_fraction(r)
        with tempfile.TemporaryDirectory() as tmp:
            js = identify(d, r, via, Path(tmp), refine, library)
    except Exception as exc:  # a refused record is a row too, not the end of the run
        row["error"] = f"{type(exc).__name__}: {str(exc).splitlines()[0][:200] if str(exc) else ''}"
        return row
    row["refinement"] = js["refinement"]
    row["warnings"] = js["warnings"]
    for group in ("damping", "stiffness"):
        for term, c in getattr(eom, group).items():
            got = js[group].get(term)
            half = js["ci95"].get(group, {}).get(term, math.nan)
            z = math.inf if got is None or not half > 0 else (got - c) / (half / Z95)
            row["terms"][term] = dict(z=z, err=math.nan if got is None else got / c - 1.0, half=half / abs(c),
                                      dropped=got is None)
    return row


def _line(label: str, zs: list[float], errs: list[float], halfs: list[float]) -> str:
    z = np.array(zs)
    k, n = int(np.sum(np.abs(z) <= Z95)), z.size
    if n == 0:
        return f"{label:<28} -"
    lo, hi = wilson(k, n)
    fin = z[np.isfinite(z)]
    return (f"{label:<28} {k / n:5.3f} [{lo:.2f}, {hi:.2f}] n={n:<4d} mean z {np.mean(fin):+6.2f} rms z "
            f"{math.sqrt(np.mean(fin**2)):6.2f} mean err {np.nanmean(errs):+8.1e} half {np.nanmean(halfs):7.1e}")


def report(rows: list[dict]) -> None:
    """Coverage per term, per law x term, per band of samples per cycle."""
    ok = [r for r in rows if "error" not in r]
    bad = [r for r in rows if "error" in r]
    groups: dict[str, tuple[list, list, list]] = {}

    def add(key: str, t: dict) -> None:
        g = groups.setdefault(key, ([], [], []))
        g[0].append(t["z"])
        g[1].append(t["err"])
        g[2].append(t["half"])

    bands = ((8, 12), (12, 16), (16, 24), (24, 32), (32, 41))
    for r in ok:
        band = next(f"{lo}-{hi}" for lo, hi in bands if lo <= r["spc"] < hi) if r["spc"] < 41 else ">=41"
        stuck = r.get("stuck")
        for term, t in r["terms"].items():
            kind = term if term in ("v", "x", "x^3") else "law"
            if stuck is not None and "sign(v)" in r["law"]:
                add(f"{'stuck' if stuck > STUCK_MIN else 'moving'} records {term}", t)
            if not t.get("dropped"):
                add("kept terms", t)
            add("all", t)
            add(f"term {term}", t)
            add(f"spc {band} {kind}", t)
            add(f"spc {band} all", t)
    for key in sorted(groups):
        print(_line(key, *groups[key]))
    lost = sum(t.get("dropped", False) for r in ok for t in r["terms"].values())
    print(f"true terms dropped by the selection: {lost} (counted as not covered in 'all', left out of 'kept terms')")
    kept = sum(r.get("refinement") == "kept" for r in ok)
    warned = sum(any("sampl" in w for w in r.get("warnings", [])) for r in ok)
    print(f"records {len(rows)}: identified {len(ok)}, refused {len(bad)}, refinement kept {kept}, "
          f"warned of sampling {warned}")
    for r in bad:
        print(f"  refused #{r['i']} ({r['law']}, {r['spc']:.1f} a cycle, {r['snr']:.0f} dB): {r['error']}")


#: A Coulomb record counts as stuck when its response stopped before this fraction of it was left.
STUCK_MIN = 0.02


def compare(before: list[dict], after: list[dict]) -> None:
    """Same records before and after a change: coverage per group and the ratio of the half widths
    (after / before: the price of the change): the median over all, the share of intervals that
    changed by more than 5 % and the median ratio among those. A true term the selection dropped
    (in either run) counts as not covered in its group and in ``all``, and is left out of ``kept``."""
    key = {(r["seed"], r["i"]): r for r in before if "error" not in r}
    groups: dict[str, list[tuple[float, float, float]]] = {}
    for r in after:
        b = key.get((r["seed"], r["i"]))
        if b is None or "error" in r:
            continue
        stuck = r.get("stuck")
        tag = ("stuck " if stuck is not None and stuck > STUCK_MIN and "sign(v)" in r["law"] else "")
        for term, t in r["terms"].items():
            tb = b["terms"].get(term)
            if tb is None:
                continue
            ratio = t["half"] / tb["half"] if tb["half"] > 0 else math.nan
            kept = not (t.get("dropped") or tb.get("dropped") or not math.isfinite(t["z"]) or not math.isfinite(tb["z"]))
            for g in ("all", f"{tag}term {term}") + (("kept",) if kept else ()):
                groups.setdefault(g, []).append((tb["z"], t["z"], ratio))
    print(f"{'group':<22} {'before':>22} {'after':>22}   half after/before: median, changed >5 %: share, median")
    for g in sorted(groups):
        zb, za, ratio = (np.array(c) for c in zip(*groups[g]))
        cov = []
        for z in (zb, za):
            k, n = int(np.sum(np.abs(z) <= Z95)), z.size
            lo, hi = wilson(k, n)
            cov.append(f"{k / n:5.3f} [{lo:.2f}, {hi:.2f}]")
        changed = ratio[np.isfinite(ratio) & (np.abs(np.log(np.where(ratio > 0, ratio, 1.0))) > math.log(1.05))]
        med_changed = f"{np.median(changed):8.3g}" if changed.size else "       -"
        print(f"{g:<22} {cov[0]:>22} {cov[1]:>22}   {np.nanmedian(ratio):7.3g} {changed.size / zb.size:6.2f} {med_changed}"
              f"  n={zb.size}")
    switched(key, after)


def switched(key: dict, after: list[dict]) -> None:
    """The records whose refinement went from rejected to kept (and back): on them the median of
    ``|err| before / |err| after`` (how much closer the returned coefficients came), of the half
    widths after / before, and the coverage after."""
    on = [(key[(r["seed"], r["i"])], r) for r in after if "error" not in r and (r["seed"], r["i"]) in key
          and key[(r["seed"], r["i"])].get("refinement") == "rejected" and r.get("refinement") == "kept"]
    back = sum(1 for r in after if (r["seed"], r["i"]) in key and key[(r["seed"], r["i"])].get("refinement") == "kept"
               and r.get("refinement") == "rejected")
    pairs = [(b["terms"][t], a["terms"][t]) for b, a in on for t in a["terms"] if t in b["terms"]]
    if not pairs:
        print(f"refinement rejected -> kept: 0 records, kept -> rejected: {back}")
        return
    err = np.array([abs(tb["err"]) / max(abs(ta["err"]), 1e-300) for tb, ta in pairs])
    half = np.array([ta["half"] / tb["half"] for tb, ta in pairs])
    cov = float(np.mean([abs(ta["z"]) <= Z95 for _, ta in pairs]))
    print(f"refinement rejected -> kept: {len(on)} records, kept -> rejected: {back}; on them |err| before/after "
          f"median {np.nanmedian(err):.3g}, half after/before median {np.nanmedian(half):.3g}, coverage after "
          f"{cov:.3f} (n={len(pairs)})")


def _cpu() -> float:
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--records", type=int, default=60, help="drawn records (default 60)")
    ap.add_argument("--draw-seed", type=int, default=1, help="seed of the draws (default 1; 2 was held out)")
    ap.add_argument("--laws", default=",".join(LAWS), help=f"damping laws to draw from (default {','.join(LAWS)})")
    ap.add_argument("--spc", default="8:40", help="samples per cycle of the linear frequency, LO:HI (default 8:40)")
    ap.add_argument("--snr", default="30:60", help="SNR range [dB], LO:HI (default 30:60)")
    ap.add_argument("--via", choices=("mat", "csv", "arrays"), default="mat",
                    help="station identify on a MATLAB file (default) or a CSV, or the pipeline on the arrays")
    ap.add_argument("--record", choices=("impact", "impact-vel", "impact-disp", "free-acc", "free-vel", "free-disp"),
                    default="impact",
                    help="the rig's impact record (force + acc, default), the blow measured by a velocity or "
                         "displacement sensor (force + vel / disp), or a free decay from a displaced rest "
                         "measured as acc, vel or disp (no force, no rest)")
    ap.add_argument("--sensor-corner", type=float, default=0.0, metavar="SHARE",
                    help="impact-vel / impact-disp: the sensor's first-order AC coupling, its corner this share of "
                         "the linear frequency (told to the station unless --untold-corner)")
    ap.add_argument("--untold-corner", action="store_true", help="do not tell the station the sensor's corner")
    ap.add_argument("--kernel", choices=("point", "mean"), default="point",
                    help="impact records: point samples of the acceleration (the rig's, default) or both channels "
                         "as means over each sample interval (an integrating ADC; not told to the station)")
    ap.add_argument("--no-refine", action="store_true", help="station identify --no-refine")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (at most 2 on a shared machine)")
    ap.add_argument("--out", help="write one JSON row per record here")
    ap.add_argument("--summary", nargs="+", metavar="JSONL", help="only print the summary of stored rows")
    ap.add_argument("--family", choices=("default", *FAMILIES), default="default",
                    help="default: the laws of --laws; stick: Coulomb sign(v) (most records stop in the friction "
                         "band before they end; rows carry 'stuck'); mixed: x^2*v + v^3 together, the split drawn; "
                         "sensor: lab-rate records for --record impact-vel|impact-disp|free-vel|free-disp")
    ap.add_argument("--library", choices=("true", "wide"), default="true",
                    help="identify with the system's own terms (default) or damping v,x^2*v,v^3 (the station's)")
    ap.add_argument("--compare", nargs=2, metavar=("BEFORE", "AFTER"),
                    help="two row files of the same draws: coverage before/after and the half-width ratio")
    args = ap.parse_args()
    if args.compare:
        b, a = ([json.loads(line) for line in Path(f).read_text().splitlines() if line] for f in args.compare)
        compare(b, a)
        return
    if args.summary:
        report([json.loads(line) for f in args.summary for line in Path(f).read_text().splitlines() if line])
        return
    rng = np.random.default_rng(args.draw_seed)
    lo, hi = (float(s) for s in args.spc.split(":"))
    laws = tuple(args.laws.split(","))
    snr = tuple(float(s) for s in args.snr.split(":"))
    draws = [draw_family(rng, args.family, laws, (lo, hi), snr) for _ in range(args.records)]
    if args.sensor_corner:
        draws = [dict(d, corner=args.sensor_corner, told=not args.untold_corner) for d in draws]
    jobs = [(i, draws[i], args.draw_seed * 1000 + i, args.via,
             not args.no_refine, args.record, args.kernel, args.library)
            for i in range(args.records)]
    print(f"coarse ci95 coverage: {args.records} draws (seed {args.draw_seed}, family {args.family}, library "
          f"{args.library}), {args.spc} samples a cycle, "
          f"{args.record}, via {args.via}, {'--no-refine' if args.no_refine else 'refined'} (load {os.getloadavg()[0]:.1f})")
    c0 = _cpu()
    rows: list[dict] = []
    with contextlib.ExitStack() as stack:
        fh = stack.enter_context(open(args.out, "w")) if args.out else None
        if args.jobs > 1:
            it = stack.enter_context(ProcessPoolExecutor(args.jobs)).map(one, jobs)
        else:
            it = map(one, jobs)
        for row in it:
            rows.append(row)
            if fh:
                fh.write(json.dumps(row) + "\n")
                fh.flush()
    report(rows)
    print(f"({_cpu() - c0:.0f} s CPU)")


if __name__ == "__main__":
    main()
