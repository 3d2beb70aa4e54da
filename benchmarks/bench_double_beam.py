"""Leave-one-out prediction error on the measured resonant-double-beam ring-downs.

Reads the nine velocity records of ``../shared/data/resonant-double-beam`` (or ``--data``),
and for each model family below, for each record: identifies on the other eight, predicts
the held-out one from its initial state (fitted to the first ``--window-ms`` after the impact)
and computes NMTE (Cenedese et al. 2022: ``mean_t |y_pred - y| / max_t |y|``) and NRMSE
(``||y_pred - y|| / ||y||``) on the velocity. Prints the table; ``--json`` prints one object.

Also prints the diagnosis numbers quoted in ``docs/real-data.md``: the single-mode model's
residual spectrum (where its error lives), per-mode backbones (frequency and damping versus
amplitude, measured and model), a test for energy exchange between the modes and the
coupling terms the residual forces would support.

    python benchmarks/bench_double_beam.py                 # table, ~30 s
    python benchmarks/bench_double_beam.py --diagnose      # + the generic eddi.diagnose loop, station
                                                           # path and separated path (~1-2 min more)
    python benchmarks/bench_double_beam.py --figures docs/real-data --save-model models/double_beam_two_mode.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from scipy import signal

from eddi.diagnosis import backbone
from eddi.multimode import (
    ModalSumModel, Prediction, identify_modes, impact_index, predict_record, separate_modes,
    simulate_modal,
)

REPO = Path(__file__).resolve().parents[1]
DEFAULT_DATA = REPO.parent / "shared" / "data" / "resonant-double-beam"

WIDE = [(20.0, 600.0)]
MODE1 = [(40.0, 180.0)]
TWO = [(40.0, 180.0), (185.0, 400.0)]

#: name -> (bands, damping library, stiffness library), in the order of the diagnosis story
FAMILIES: dict[str, tuple[list[tuple[float, float]], tuple[str, ...], tuple[str, ...]]] = {
    "single-DOF, whole signal (EDDI, v, |v|v / x, |x|x)": (WIDE, ("v", "abs(v)*v"), ("x", "abs(x)*x")),
    "single mode 122 Hz only (nonlinear)": (MODE1, ("v", "abs(v)*v"), ("x", "abs(x)*x")),
    "two modes, linear (v / x)": (TWO, ("v",), ("x",)),
    "two modes, nonlinear damping only (v, |v|v / x)": (TWO, ("v", "abs(v)*v"), ("x",)),
    "two modes, nonlinear stiffness only (v / x, |x|x)": (TWO, ("v",), ("x", "abs(x)*x")),
    "two modes, nonlinear (v, |v|v / x, |x|x)  [default]": (TWO, ("v", "abs(v)*v"), ("x", "abs(x)*x")),
    "two modes, paper library (v, x^2 v, v^3 / x, x^3)": (TWO, ("v", "x^2*v", "v^3"), ("x", "x^3")),
}


def load_records(folder: Path) -> tuple[list[str], list[tuple[np.ndarray, np.ndarray]]]:
    """Records cut at the impact (largest |v|), time re-based to 0 there."""
    names, recs = [], []
    for f in sorted(folder.glob("ringdown-*.csv")):
        d = np.loadtxt(f, delimiter=",", skiprows=1)
        t, v = d[:, 0], d[:, 1]
        dt = (t[-1] - t[0]) / (t.size - 1)
        i0 = impact_index(v)
        names.append(f.stem)
        recs.append((dt * np.arange(t.size - i0), v[i0:]))
    return names, recs


Records = list[tuple[np.ndarray, np.ndarray]]


def leave_one_out(recs: Records, bands: list[tuple[float, float]], damping: tuple[str, ...],
                  stiffness: tuple[str, ...], window_s: float) -> tuple[list[ModalSumModel], list[Prediction]]:
    """Identify on all records but one, predict that one from its initial state; every record."""
    preds: list[Prediction] = []
    models: list[ModalSumModel] = []
    for i in range(len(recs)):
        train = [r for j, r in enumerate(recs) if j != i]
        model, _ = identify_modes(train, bands, damping=damping, stiffness=stiffness,
                                  initial_window_s=window_s)
        preds.append(predict_record(model, *recs[i], start=0))
        models.append(model)
    return models, preds


def residual_spectrum_share(recs: Records, preds: list[Prediction],
                            bands_hz: tuple[tuple[float, float], ...] = ((100.0, 145.0), (220.0, 265.0))) -> np.ndarray:
    """Share of the prediction residual's power in each band, pooled over records."""
    shares = np.zeros(len(bands_hz))
    total = 0.0
    for (t, _v), p in zip(recs, preds):
        r = np.nan_to_num(p.v_predicted - p.v_measured)
        fr, pw = signal.welch(r, 1.0 / (t[1] - t[0]), nperseg=4096)
        total += pw.sum()
        for k, (lo, hi) in enumerate(bands_hz):
            shares[k] += pw[(fr >= lo) & (fr < hi)].sum()
    return shares / total


def mode_backbones(model: ModalSumModel, recs: Records, amplitudes_m: list[list[float]]) -> list[dict[str, Any]]:
    """Per mode: measured (pooled) and model frequency / damping ratio at given amplitudes."""
    out = []
    for k, eom in enumerate(model.modes):
        amp_all, f_all, z_all = [], [], []
        for t, v in recs:
            c = separate_modes(t, v, model.bands_hz, filter_order=model.filter_order)
            n = int(0.05 / (t[1] - t[0]))
            a, f, z = backbone(t[n:-n], c.x[k][n:-n], c.v[k][n:-n], 1.0)
            amp_all.append(a), f_all.append(f), z_all.append(z)
        a = np.concatenate(amp_all)
        f = np.concatenate(f_all)
        z = np.concatenate(z_all)
        # model: free decay from above the largest measured amplitude
        x0 = 1.2 * float(np.max(a))
        t_sim = np.arange(int(4.0 / (recs[0][0][1] - recs[0][0][0]))) * (recs[0][0][1] - recs[0][0][0])
        init = np.zeros((len(model.modes), 2))
        init[k, 0] = x0
        sim = simulate_modal(model, t_sim, init)
        am, fm, zm = backbone(t_sim, sim.x_modes[k], sim.v_modes[k], 1.0)
        rows = []
        for amp in amplitudes_m[k]:
            sel = np.abs(np.log(a / amp)) < 0.1
            ms = np.abs(np.log(am / amp)) < 0.1
            rows.append({
                "amplitude_m": amp, "n_cycles": int(sel.sum()),
                "measured_hz": float(np.median(f[sel])) if sel.any() else None,
                "measured_hz_iqr": float(np.subtract(*np.percentile(f[sel], [75, 25]))) if sel.any() else None,
                "model_hz": float(np.median(fm[ms])) if ms.any() else None,
                "measured_zeta": float(np.median(z[sel])) if sel.any() else None,
                "model_zeta": float(np.median(zm[ms])) if ms.any() else None,
            })
        out.append({"mode": k + 1, "rows": rows, "measured": (a, f, z), "model": (am, fm, zm)})
    return out


def coupling_test(model: ModalSumModel, recs: Records) -> dict[str, dict[str, Any]]:
    """Share of each mode's residual force that candidate coupling terms explain (least squares)."""
    names = ["x1^2", "x1*x2", "x2^2", "x1*v2", "v1*x2", "x1^2*x2", "x1*x2^2"]
    res: dict[int, list[np.ndarray]] = {0: [], 1: []}
    cols: dict[int, list[np.ndarray]] = {0: [], 1: []}
    elastic: dict[int, list[np.ndarray]] = {0: [], 1: []}
    for t, v in recs:
        c = separate_modes(t, v, model.bands_hz, filter_order=model.filter_order)
        dt = t[1] - t[0]
        sl = slice(int(0.05 / dt), int(1.0 / dt))
        x1, x2, v1, v2 = c.x[0][sl], c.x[1][sl], c.v[0][sl], c.v[1][sl]
        cand = np.column_stack([x1**2, x1 * x2, x2**2, x1 * v2, v1 * x2, x1**2 * x2, x1 * x2**2])
        for k in (0, 1):
            eom = model.modes[k]
            res[k].append(c.a[k][sl] + eom.restoring_force(c.x[k][sl], c.v[k][sl]))
            cols[k].append(cand)
            elastic[k].append(eom.linear_stiffness() * c.x[k][sl])
    out = {}
    for k in (0, 1):
        r = np.concatenate(res[k])
        a = np.vstack(cols[k])
        coef, *_ = np.linalg.lstsq(a, r, rcond=None)
        explained = 1 - np.mean((r - a @ coef) ** 2) / np.mean(r**2)
        out[f"mode{k + 1}"] = {
            "residual_over_elastic_rms": float(np.sqrt(np.mean(r**2)) / np.sqrt(np.mean(np.concatenate(elastic[k]) ** 2))),
            "all_coupling_terms_explain": float(explained),
            "terms": names,
        }
    return out


def energy_rises(model: ModalSumModel, recs: Records) -> dict[str, dict[str, float]]:
    """Cycles where a mode's energy grows (energy flowing in), as a share of all cycles."""
    rises = np.zeros(2)
    counts = np.zeros(2)
    biggest = np.zeros(2)
    for t, v in recs:
        c = separate_modes(t, v, model.bands_hz, filter_order=model.filter_order)
        dt = t[1] - t[0]
        for k, eom in enumerate(model.modes):
            w2 = eom.linear_stiffness()
            e = 0.5 * (c.v[k] ** 2 + w2 * c.x[k] ** 2)
            per = int(round(2 * np.pi / np.sqrt(w2) / dt))
            n = (e.size // per) * per
            ec = e[:n].reshape(-1, per).mean(axis=1)
            trim = int(0.05 / dt / per) + 1
            ec = ec[trim:-trim]
            ec = ec[ec > 0.02**2 * ec.max()]
            de = np.diff(ec) / ec[:-1]
            rises[k] += np.sum(de > 0)
            counts[k] += de.size
            biggest[k] = max(biggest[k], float(de.max()))
    return {f"mode{k + 1}": {"cycles": int(counts[k]), "share_rising": float(rises[k] / counts[k]),
                             "largest_rise_per_cycle": float(biggest[k])} for k in range(2)}


def _diagnosis_summary(dg: Any) -> dict[str, Any]:
    return {
        "cause": dg.cause, "verdict": dg.verdict, "symptom": dg.symptom, "gain": float(dg.gain),
        "notes": list(dg.notes),
        "baseline_nrmse": float(dg.baseline.nrmse), "baseline_nmte": float(dg.baseline.nmte),
        "extended_nrmse": float(dg.extended.nrmse), "extended_nmte": float(dg.extended.nmte),
        "baseline_fold_nrmse": [float(x) for x in dg.baseline.fold_nrmse],
        "extended_fold_nrmse": [float(x) for x in dg.extended.fold_nrmse],
        "candidates": [{"name": c.name, "form": c.form, "nrmse": float(c.nrmse), "gain": float(c.gain),
                        "reference": c.reference, "reference_nrmse": float(c.reference_nrmse),
                        "nmte": float(c.nmte), "reference_nmte": float(c.reference_nmte),
                        "wins_every_part": c.wins_every_part, "consistent": c.consistent,
                        "skipped": c.skipped} for c in dg.candidates],
    }


def generic_diagnosis(folder: Path, names: list[str], recs: Records) -> dict[str, Any]:
    """The project's generic discrepancy loop, two ways.

    ``station``: exactly ``station diagnose FOLDER/ringdown-*.csv --mass 1`` (the station's own
    reading and conditioning of the velocity, default term libraries). ``separated``: the
    single-DOF baseline ``v, abs(v)*v`` / ``x, abs(x)*x`` on the drift-free displacement of
    this module's wide band (20-600 Hz) instead of the station's conditioning.
    """
    from eddi.diagnosis import Record, diagnose
    from station.commands.diagnose import load_records as station_records

    t0 = time.perf_counter()
    records, _ = station_records([str(f) for f in sorted(folder.glob("ringdown-*.csv"))])
    out = {"station": {**_diagnosis_summary(diagnose(records, 1.0)),
                       "seconds": time.perf_counter() - t0}}
    t0 = time.perf_counter()
    sep = []
    for name, (t, v) in zip(names, recs):
        c = separate_modes(t, v, WIDE)
        n = int(0.05 / (t[1] - t[0]))
        sep.append(Record.create(t, c.x[0], v, None, free_start=n, free_stop=t.size - n, label=name))
    dg = diagnose(sep, 1.0, damping=("v", "abs(v)*v"), stiffness=("x", "abs(x)*x"))
    out["separated"] = {**_diagnosis_summary(dg), "seconds": time.perf_counter() - t0}
    return out


def figures(outdir: Path, names: list[str], recs: Records, results: dict[str, dict[str, Any]],
            model_all: ModalSumModel, backbones: list[dict[str, Any]]) -> list[str]:
    """Write the four PNG figures of docs/real-data.md; return their paths."""
    from matplotlib.figure import Figure

    outdir.mkdir(parents=True, exist_ok=True)
    written = []
    single = results["single-DOF, whole signal (EDDI, v, |v|v / x, |x|x)"]["predictions"]
    two = results["two modes, nonlinear (v, |v|v / x, |x|x)  [default]"]["predictions"]
    linear = results["two modes, linear (v / x)"]["predictions"]
    i = 0  # first record, held out
    t = two[i].t
    # 1. time series: measured vs held-out predictions
    fig = Figure(figsize=(10, 7))
    axs = fig.subplots(3, 1)
    for ax, (lo, hi) in zip(axs, [(0, 3.1), (0.0, 0.08), (2.0, 2.05)]):
        sel = (t >= lo) & (t <= hi)
        ax.plot(t[sel], two[i].v_measured[sel], color="k", lw=0.8, label="measured")
        ax.plot(t[sel], single[i].v_predicted[sel], color="tab:orange", lw=0.8, label=f"single DOF (NMTE {100 * single[i].errors.nmte:.1f} %)")
        ax.plot(t[sel], two[i].v_predicted[sel], color="tab:red", lw=0.8, ls="--", label=f"two modes (NMTE {100 * two[i].errors.nmte:.2f} %)")
        ax.set_ylabel("velocity [m/s]")
    axs[0].legend(loc="upper right", fontsize=8)
    axs[-1].set_xlabel("time after impact [s]")
    axs[0].set_title(f"{names[i]} held out: predicted from its initial state (models fitted on the other 8)")
    written.append(_save(fig, outdir / "time-series.png"))
    # 2. residual spectra
    fig = Figure(figsize=(9, 4))
    ax = fig.subplots()
    fs = 1.0 / (t[1] - t[0])
    for preds, lab, col in [(single, "single-DOF residual", "tab:orange"), (linear, "two linear modes residual", "tab:blue"),
                            (two, "two nonlinear modes residual", "tab:red")]:
        p_all = []
        for p in preds:
            fr, pw = signal.welch(np.nan_to_num(p.v_predicted - p.v_measured), fs, nperseg=4096)
            p_all.append(pw)
        ax.semilogy(fr, np.mean(p_all, axis=0), color=col, label=lab)
    p_all = [signal.welch(p.v_measured, fs, nperseg=4096)[1] for p in two]
    ax.semilogy(fr, np.mean(p_all, axis=0), color="k", lw=0.7, label="measured")
    ax.set_xlim(0, 500)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("PSD [(m/s)^2/Hz]")
    ax.legend(fontsize=8)
    ax.set_title("Where the held-out prediction error lives (mean over 9 LOO folds)")
    written.append(_save(fig, outdir / "residual-spectrum.png"))
    # 3. backbones
    fig = Figure(figsize=(10, 7))
    axs = fig.subplots(2, 2)
    for k, bb in enumerate(backbones):
        a, f, z = bb["measured"]
        am, fm, zm = bb["model"]
        axs[0, k].plot(a * 1e3, f, ".", ms=1, color="0.8", label="measured, cycle by cycle")
        axs[1, k].plot(a * 1e3, z * 100, ".", ms=1, color="0.8")
        edges = np.geomspace(max(np.percentile(a, 1), 1e-6), np.max(a), 16)
        for arr_a, arr_f, arr_z, style, lab in [(a, f, z, "o", "measured, binned median"),
                                                (am, fm, zm, "-", "model (simulated, same estimator)")]:
            idx = np.digitize(arr_a, edges)
            mids, fmed, zmed = [], [], []
            for b in range(1, edges.size):
                sel = idx == b
                if np.sum(sel) >= 5:
                    mids.append(np.sqrt(edges[b - 1] * edges[b]) * 1e3)
                    fmed.append(np.median(arr_f[sel]))
                    zmed.append(np.median(arr_z[sel]) * 100)
            col = "k" if style == "o" else "tab:red"
            axs[0, k].plot(mids, fmed, style, color=col, ms=4, label=lab)
            axs[1, k].plot(mids, zmed, style, color=col, ms=4)
        axs[0, k].set_xscale("log")
        axs[1, k].set_xscale("log")
        axs[0, k].set_title(f"mode {k + 1}")
        axs[1, k].set_xlabel("modal displacement amplitude [mm] (per unit modal mass)")
        fmed = np.median(f)
        axs[0, k].set_ylim(fmed * 0.993, fmed * 1.005)
        axs[1, k].set_ylim(0, np.percentile(z * 100, 90) * 1.5)
    axs[0, 0].set_ylabel("frequency [Hz]")
    axs[1, 0].set_ylabel("damping ratio [%]")
    axs[0, 0].legend(fontsize=8)
    written.append(_save(fig, outdir / "backbones.png"))
    # 4. residual force of the linear modes vs displacement (the joint's signature)
    fig = Figure(figsize=(10, 4))
    axs = fig.subplots(1, 2)
    lin_model = results["two modes, linear (v / x)"]["models"][0]
    t0, v0 = recs[0]
    c = separate_modes(t0, v0, TWO)
    n = int(0.05 / (t0[1] - t0[0]))
    for k in range(2):
        eom = lin_model.modes[k]
        r = -(c.a[k] + eom.restoring_force(c.x[k], c.v[k]))[n:-n]
        xk = c.x[k][n:-n]
        step = max(1, xk.size // 20000)
        axs[k].plot(xk[::step] * 1e3, r[::step], ".", ms=1, color="0.4")
        xs = np.linspace(xk.min(), xk.max(), 200)
        nl = model_all.modes[k]
        axs[k].plot(xs * 1e3, (nl.stiffness.get("abs(x)*x", 0.0) * np.abs(xs) * xs
                                 + (nl.linear_stiffness() - eom.linear_stiffness()) * xs),
                    color="tab:red", label="stiffness of the nonlinear model minus the linear one")
        axs[k].set_xlabel(f"mode {k + 1} displacement [mm]")
        axs[k].set_title(f"mode {k + 1}: force the linear model misses")
    axs[0].set_ylabel("residual force per unit mass [m/s^2]")
    axs[0].legend(fontsize=8)
    written.append(_save(fig, outdir / "residual-force.png"))
    return written


def _save(fig: Any, path: Path) -> str:
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    return str(path)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; print the table (or JSON); 2 when the data folder is missing."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--window-ms", type=float, default=20.0, help="initial-state window [ms]")
    ap.add_argument("--figures", type=Path, default=None, help="write PNG figures here")
    ap.add_argument("--save-model", type=Path, default=None, help="write the two-mode model fitted on all nine records")
    ap.add_argument("--diagnose", action="store_true",
                    help="also run the generic discrepancy loop (eddi.diagnose) on the single-DOF baseline (~1 min)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if not args.data.is_dir():
        sys.stderr.write(f"data folder not found: {args.data}\n")
        return 2
    names, recs = load_records(args.data)
    w = args.window_ms / 1e3
    results = {}
    t_start = time.perf_counter()
    for fam, (bands, damp, stiff) in FAMILIES.items():
        t0 = time.perf_counter()
        models, preds = leave_one_out(recs, bands, damp, stiff, w)
        nm = np.array([p.errors.nmte for p in preds])
        nr = np.array([p.errors.nrmse for p in preds])
        results[fam] = {"models": models, "predictions": preds, "nmte": nm, "nrmse": nr,
                        "seconds": time.perf_counter() - t0}
    model_all, fits = identify_modes(recs, TWO, initial_window_s=w,
                                     notes="resonant double beam, nine ring-downs (01,03,04,05,07,08,09,11,12)")
    single_preds = results["single-DOF, whole signal (EDDI, v, |v|v / x, |x|x)"]["predictions"]
    shares = residual_spectrum_share(recs, single_preds)
    amps = [[1e-4, 2e-4, 4e-4, 6e-4, 8e-4], [1e-5, 3e-5, 1e-4, 3e-4, 6e-4]]
    backbones = mode_backbones(model_all, recs, amps)
    coupling = coupling_test(model_all, recs)
    rises = energy_rises(model_all, recs)
    summary = {
        "records": names,
        "initial_window_ms": args.window_ms,
        "families": {fam: {"nmte": r["nmte"].tolist(), "nmte_mean": float(np.mean(r["nmte"])),
                           "nrmse": r["nrmse"].tolist(), "nrmse_mean": float(np.mean(r["nrmse"]))}
                     for fam, r in results.items()},
        "model_all_nine": json.loads(model_all.to_json()),
        "natural_frequencies_hz": model_all.natural_frequencies_hz().tolist(),
        "single_dof_residual_power_share": {"100-145 Hz": float(shares[0]), "220-265 Hz": float(shares[1])},
        "backbones": [{"mode": b["mode"], "rows": b["rows"]} for b in backbones],
        "coupling": coupling,
        "energy_rises": rises,
        "seconds": time.perf_counter() - t_start,
    }
    if args.diagnose:
        summary["generic_diagnosis"] = generic_diagnosis(args.data, names, recs)
    if args.save_model is not None:
        args.save_model.parent.mkdir(parents=True, exist_ok=True)
        args.save_model.write_text(model_all.to_json() + "\n")
    if args.figures is not None:
        summary["figures"] = figures(args.figures, names, recs, results, model_all, backbones)
    if args.json:
        sys.stdout.write(json.dumps(summary, default=float) + "\n")
        return 0
    lines = [f"Leave-one-out over {len(recs)} records ({', '.join(n[-2:] for n in names)}); "
             f"prediction from the initial state fitted on the first {args.window_ms:g} ms after the impact",
             f"{'model':56s} {'NMTE mean':>9s} {'NRMSE mean':>10s}   NMTE per held-out record [%]"]
    for fam, r in results.items():
        per = " ".join(f"{100 * x:5.2f}" if np.isfinite(x) else "  inf" for x in r["nmte"])
        lines.append(f"{fam:56s} {100 * np.mean(r['nmte']):8.2f}% {np.mean(r['nrmse']):10.4f}   {per}")
    lines.append("reference: SSMLearn 4-D SSM model, NMTE 3.65 % on records 02, 06, 10 (data README)")
    lines.append("")
    lines.append("two-mode model fitted on all nine records:")
    for k, eom in enumerate(model_all.modes):
        lines.append(f"  mode {k + 1} ({model_all.natural_frequencies_hz()[k]:.3f} Hz): {eom.equation_text()}")
    lines.append(f"single-DOF held-out residual power: {100 * shares[0]:.1f} % in 100-145 Hz, "
                 f"{100 * shares[1]:.1f} % in 220-265 Hz")
    for b in backbones:
        lines.append(f"mode {b['mode']} backbone (amplitude [mm]: measured Hz / model Hz, measured zeta % / model zeta %):")
        for row in b["rows"]:
            if row["measured_hz"] is None or row["model_hz"] is None:
                continue
            lines.append(f"  {row['amplitude_m'] * 1e3:6.3f}: {row['measured_hz']:8.3f} / {row['model_hz']:8.3f}   "
                         f"{100 * row['measured_zeta']:.4f} / {100 * row['model_zeta']:.4f}   ({row['n_cycles']} cycles)")
    for k, c in coupling.items():
        lines.append(f"{k}: residual force / elastic force (rms) {c['residual_over_elastic_rms']:.2e}; "
                     f"7 coupling terms explain {100 * c['all_coupling_terms_explain']:.1f} % of it")
    for k, r in rises.items():
        lines.append(f"{k}: energy grows in {100 * r['share_rising']:.1f} % of {r['cycles']} cycles, "
                     f"largest rise {100 * r['largest_rise_per_cycle']:.1f} % per cycle")
    if args.diagnose:
        for way, g in summary["generic_diagnosis"].items():
            lines.append(f"eddi.diagnose ({way}): cause {g['cause']!r}, gain {100 * g['gain']:.1f} %; held-out "
                         f"displacement nrmse {g['baseline_nrmse']:.3f} -> {g['extended_nrmse']:.4f}, velocity "
                         f"NMTE {100 * g['baseline_nmte']:.2f} % -> {100 * g['extended_nmte']:.2f} % "
                         f"({g['seconds']:.0f} s)")
            lines.append("  per held-out record, nrmse baseline / extended: " + " ".join(
                f"{b:.3f}/{e:.4f}" for b, e in zip(g["baseline_fold_nrmse"], g["extended_fold_nrmse"])))
            for c in g["candidates"]:
                lines.append(f"  {c['name']:22s} {c['form']:9s} nrmse {c['nrmse']:.4f} gain {100 * c['gain']:6.1f} % "
                             f"over the {c['reference']} ({c['reference_nrmse']:.4f})" if not c["skipped"]
                             else f"  {c['name']:22s} skipped: {c['skipped']}")
            lines.append(f"  verdict: {g['verdict']}")
            lines.append(f"  symptom: {g['symptom']}")
            lines += [f"  note: {n}" for n in g["notes"]]
    if args.figures is not None:
        lines.append("figures: " + ", ".join(summary["figures"]))
    lines.append(f"total {summary['seconds']:.1f} s")
    sys.stdout.write("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
