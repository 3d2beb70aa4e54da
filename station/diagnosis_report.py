"""Figures of a diagnosis (``station diagnose --report DIR``), one PNG per step.

* ``timeseries.png``: each held-out part, measured versus the baseline's and the extended
  model's simulations (fitted without that part);
* ``energy_per_cycle.png``: energy lost per cycle versus amplitude (measured, baseline,
  extended), log-log, so a slope of 1 reads as dry friction, 2 as viscous, 3 as quadratic drag;
* ``backbone.png``: instantaneous frequency and damping ratio versus amplitude;
* ``residual_force.png``: force the baseline misses over the phase plane ``(x, v)``, and what
  is left after the extension;
* ``spectra.png``: amplitude spectra of the held-out parts.

When the cause is a second mode seen in the measured signal (the extended model is a
:class:`~eddi.multimode.ModalSumModel`), the energy, backbone and residual-force figures are
drawn per mode: each mode's component is separated from the measured rate with the model's
band-pass (:func:`eddi.multimode.separate_modes`) and compared with that mode's held-out
simulation, so the joint's amplitude-dependent frequency and damping are read mode by mode.

Figures are built on :class:`matplotlib.figure.Figure` (Agg canvas, no pyplot state).
"""

from __future__ import annotations

import errno
from pathlib import Path
from typing import Sequence

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from eddi.diagnosis import Diagnosis, HeldOut, Record, backbone, energy_per_cycle, residual_force, spectrum  # noqa: E402
from eddi.diagnosis.settings import PRED_CAP  # noqa: E402
from eddi.multimode import ModalSumModel, separate_modes  # noqa: E402
from eddi.terms import parse_term  # noqa: E402
from station.figures import envelope, save  # noqa: E402
from station.storage import StorageError  # noqa: E402

_COLORS = {"measured": "0.2", "baseline": "tab:red", "extended": "tab:blue"}


def _new(rows: int, cols: int, size: tuple[float, float]) -> tuple[Figure, np.ndarray]:
    fig = Figure(figsize=size, layout="constrained")
    return fig, fig.subplots(rows, cols, squeeze=False)


def _curves(diag: Diagnosis) -> list[tuple[str, list[tuple[np.ndarray, np.ndarray]]]]:
    """(label, [(t, x) per held-out part]) for measured, baseline, extended."""
    out = []
    for name, attr in (("measured", "x_measured"), ("baseline", "x_baseline"), ("extended", "x_extended")):
        if name == "extended" and diag.cause in ("none", "unexplained"):
            continue
        out.append((name, [(h.t, getattr(h, attr)) for h in diag.held_out]))
    return out


def _modal(diag: Diagnosis) -> ModalSumModel | None:
    m = diag.extended.model
    return m if (diag.cause not in ("none", "unexplained") and isinstance(m, ModalSumModel)) else None


def _main_frequency(h: HeldOut) -> float:
    rate = 1.0 / float(h.t[1] - h.t[0])
    f, amp = spectrum(h.x_measured - np.mean(h.x_measured), rate)
    return _peak(f, amp)


def timeseries_figure(diag: Diagnosis) -> Figure:
    """Held-out parts: measured versus simulated coordinate (whole part and its first cycles)."""
    n = len(diag.held_out)
    fig, ax = _new(n, 2, (12.0, 1.9 * n + 0.6))
    fig.suptitle("held-out records: measured vs simulated from the initial state "
                 "(each model fitted without that record; held-out nrmse in brackets)", fontsize=10)
    for i, h in enumerate(diag.held_out):
        a, z = ax[i, 0], ax[i, 1]
        t0 = h.t - h.t[0]
        f0 = _main_frequency(h)
        zoom = t0 <= (10.0 / f0 if f0 > 0 else t0[-1] / 20)
        series = [("measured", h.x_measured, "measured", 0.9)]
        if np.all(np.isfinite(h.x_baseline)):
            series.append(("baseline", h.x_baseline, f"baseline ({diag.judging.fold_nrmse[i]:.3g})", 0.7))
        else:
            series.append(("baseline", np.nan_to_num(h.x_baseline), "baseline (diverged)", 0.7))
        if diag.cause not in ("none", "unexplained") and np.all(np.isfinite(h.x_extended)):
            series.append(("extended", h.x_extended,
                           f"+ {diag.cause} ({diag.extended.fold_nrmse[i]:.3g})", 0.7))
        style = {"measured": (0.6, 1.0, 3), "baseline": (0.8, 0.8, 1), "extended": (2.0, 0.55, 2)}
        for name, x, lab, _lw in series:
            lw, al, zo = style[name]
            a.plot(*envelope(t0, x), color=_COLORS[name], lw=min(lw, 0.8), alpha=0.85 if name != "measured"
                   else 0.7, label=lab, zorder=zo)
            z.plot(t0[zoom], x[zoom], color=_COLORS[name], lw=lw, alpha=al, zorder=zo)
        lim = 1.3 * float(np.max(np.abs(h.x_measured)))
        for q in (a, z):
            q.set_ylim(-lim, lim)
        a.set_title(f"held out: {h.part.label}", fontsize=9)
        z.set_title("first 10 cycles", fontsize=9)
        a.set_ylabel("x [m]")
        a.legend(fontsize=7, loc="upper right")
    ax[-1, 0].set_xlabel("time in part [s]")
    ax[-1, 1].set_xlabel("time in part [s]")
    return fig


def _measured_modes(h: HeldOut, model: ModalSumModel,
                    cache: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray, slice]] | None = None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, slice]:
    """Separated measured components of a held-out part: x, v, a (n_modes, k) and the samples
    away from the filter's edges (``cache``, keyed by part, avoids separating twice)."""
    assert h.v_measured is not None
    key = id(h)
    if cache is not None and key in cache:
        return cache[key]
    c = separate_modes(h.t, h.v_measured, model.bands_hz, filter_order=model.filter_order)
    trim = int(0.05 / float(h.t[1] - h.t[0]))
    out = (c.x, c.v, c.a, slice(trim, max(trim + 1, h.t.size - trim)))
    if cache is not None:
        cache[key] = out
    return out


def _mode_curves(diag: Diagnosis, model: ModalSumModel, k: int, cache: dict | None = None
                 ) -> list[tuple[str, list[tuple[np.ndarray, np.ndarray, np.ndarray]]]]:
    """(label, [(t, x_k, v_k) per part]) for the measured component and the model's mode k."""
    meas, sim = [], []
    for h in diag.held_out:
        if h.v_measured is None or h.x_modes is None or h.v_modes is None:
            continue
        xm, vm, _am, keep = _measured_modes(h, model, cache)
        meas.append((h.t[keep], xm[k][keep], vm[k][keep]))
        if np.all(np.isfinite(h.x_modes[k])):
            sim.append((h.t, h.x_modes[k], h.v_modes[k]))
    return [("measured", meas), ("extended", sim)]


def _binned(amp: np.ndarray, y: np.ndarray, bins: int = 12) -> tuple[np.ndarray, np.ndarray]:
    ok = np.isfinite(amp) & np.isfinite(y) & (amp > 0)
    if ok.sum() < 2 * bins:
        return np.zeros(0), np.zeros(0)
    a, yy = amp[ok], y[ok]
    edges = np.geomspace(np.percentile(a, 2), np.max(a), bins + 1)
    mid, med = [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (a >= lo) & (a < hi)
        if sel.sum() >= 5:
            mid.append(np.sqrt(lo * hi))
            med.append(np.median(yy[sel]))
    return np.array(mid), np.array(med)


def energy_figure(diag: Diagnosis, cache: dict | None = None) -> Figure:
    """Energy lost per cycle versus amplitude, log-log (per mode for a modal sum)."""
    mass = diag.judging.model.mass
    model = _modal(diag)
    n_modes = len(model.modes) if model is not None else 0
    fig, ax = _new(1, 1 + n_modes, (6.0 + 4.6 * n_modes, 4.2))
    for k in range(n_modes):
        assert model is not None
        q = ax[0, 1 + k]
        for name, parts in _mode_curves(diag, model, k, cache):
            amps, des = [], []
            for t, x, v in parts:
                amp, de = energy_per_cycle(t, x, v, 1.0)
                amps.append(amp)
                des.append(de)
            if amps:
                amp, de = np.concatenate(amps), np.concatenate(des)
                keep = (amp > 1e-2 * np.max(amp)) & (de > 0)
                meas = name == "measured"  # drawn over the model, so both stay visible
                q.loglog(amp[keep], de[keep], ".", ms=1.5 if meas else 4,
                         color=_COLORS[name], alpha=0.35 if meas else 0.5, zorder=3 if meas else 2,
                         label=("measured (separated)" if meas else "model, mode alone (held-out)"))
        f = model.natural_frequencies_hz()[k]
        q.set_title(f"mode {k + 1} ({f:.4g} Hz): energy lost per cycle", fontsize=9)
        q.set_xlabel("modal amplitude [m]")
        q.set_ylabel("energy lost per cycle per unit modal mass [J/kg]")
        q.legend(fontsize=8)
    a = ax[0, 0]
    for name, parts in _curves(diag):
        amps, des = [], []
        for t, x in parts:
            ok = np.isfinite(x)
            if ok.sum() < 8:
                continue
            v = np.gradient(x[ok], t[ok])
            amp, de = energy_per_cycle(t[ok], x[ok], v, mass)
            amps.append(amp)
            des.append(de)
        if amps:
            amp, de = np.concatenate(amps), np.concatenate(des)
            keep = (amp > 1e-3 * np.max(amp)) & (de > 0)
            meas = name == "measured"  # drawn over the simulations, so all stay visible
            a.loglog(amp[keep], de[keep], ".", ms=1.5 if meas else 3, color=_COLORS[name],
                     alpha=0.5 if meas else 0.6, zorder=3 if meas else 2, label=name)
    a.set_xlabel("amplitude [m]")
    a.set_ylabel("energy lost per cycle [J]")
    a.set_title(("whole signal; " if n_modes else "")
                + "slope 1: dry friction, 2: viscous, 3: quadratic drag", fontsize=9)
    a.legend(fontsize=8)
    return fig


def modal_backbone_figure(diag: Diagnosis, model: ModalSumModel, cache: dict | None = None) -> Figure:
    """Per mode: frequency and damping ratio versus modal amplitude, measured and model."""
    n_modes = len(model.modes)
    fig, ax = _new(n_modes, 2, (11.0, 3.6 * n_modes + 0.5))
    kb = diag.judging.model.linear_stiffness()
    fb = np.sqrt(max(kb, 0.0) / diag.judging.model.mass) / (2 * np.pi)
    fig.suptitle(f"backbone per mode (the single-mode baseline sits at {fb:.4g} Hz, off these axes)",
                 fontsize=10)
    for k in range(n_modes):
        for name, parts in _mode_curves(diag, model, k, cache):
            amps, fs, zs = [], [], []
            for t, x, v in parts:
                amp, f, z = backbone(t, x, v, 1.0)
                amps.append(amp)
                fs.append(f)
                zs.append(z)
            if not amps:
                continue
            amp, f, z = np.concatenate(amps), np.concatenate(fs), np.concatenate(zs)
            keep = amp > 0.02 * np.max(amp)
            amp, f, z = amp[keep], f[keep], z[keep]
            if name == "measured":
                ax[k, 0].plot(amp * 1e3, f, ".", ms=1.5, color="0.6", alpha=0.4,
                              label="measured, cycle by cycle")
                ax[k, 1].plot(amp * 1e3, 100 * z, ".", ms=1.5, color="0.6", alpha=0.4)
                for j, y in ((0, f), (1, 100 * z)):
                    mid, med = _binned(amp, y)
                    ax[k, j].plot(mid * 1e3, med, "o-", color=_COLORS["measured"], ms=4,
                                  label="measured, median" if j == 0 else None)
            else:
                for j, y in ((0, f), (1, 100 * z)):
                    mid, med = _binned(amp, y)
                    ax[k, j].plot(mid * 1e3, med, "s--", color=_COLORS["extended"], ms=4,
                                  label="model (held-out simulations)" if j == 0 else None)
            # robust axis limits: the cycle-by-cycle cloud has outliers at the noise floor
            for j, y in ((0, f), (1, 100 * z)):
                lo, hi = np.percentile(y[np.isfinite(y)], [3, 97]) if y.size else (0, 1)
                pad = 0.3 * (hi - lo) + 1e-9
                cur = ax[k, j].get_ylim() if name != "measured" else (lo - pad, hi + pad)
                ax[k, j].set_ylim(min(cur[0], lo - pad), max(cur[1], hi + pad))
        fk = model.natural_frequencies_hz()[k]
        ax[k, 0].set_title(f"mode {k + 1} ({fk:.4g} Hz): frequency vs amplitude", fontsize=9)
        ax[k, 1].set_title(f"mode {k + 1}: damping ratio vs amplitude", fontsize=9)
        ax[k, 0].set_ylabel("frequency [Hz]")
        ax[k, 1].set_ylabel("damping ratio [%]")
        for j in (0, 1):
            ax[k, j].set_xlabel("modal amplitude [mm]")
        ax[k, 0].legend(fontsize=7)
    return fig


def backbone_figure(diag: Diagnosis, cache: dict | None = None) -> Figure:
    """Frequency and damping ratio versus amplitude, cycle by cycle (per mode for a modal sum)."""
    model = _modal(diag)
    if model is not None:
        return modal_backbone_figure(diag, model, cache)
    mass = diag.judging.model.mass
    fig, ax = _new(1, 2, (10.0, 3.8))
    seen: list[np.ndarray] = []
    for name, parts in _curves(diag):
        for k, (t, x) in enumerate(parts):
            ok = np.isfinite(x)
            if ok.sum() < 8:
                continue
            v = np.gradient(x[ok], t[ok])
            amp, f, z = backbone(t[ok], x[ok], v, mass)
            # the axis is set by the data: cycles below 2 % of the peak amplitude (noise floor,
            # stray near-zero points) would stretch the log axis over decades of nothing
            keep = np.isfinite(amp) & np.isfinite(f) & (amp > 0.02 * float(np.nanmax(amp))) if amp.size else amp > 0
            amp, f, z = amp[keep], f[keep], z[keep]
            lab = name if k == 0 else None
            ax[0, 0].semilogx(amp, f, ".", ms=3, color=_COLORS[name], label=lab)
            ax[0, 1].loglog(amp[z > 0], z[z > 0], ".", ms=3, color=_COLORS[name], label=lab)
            seen.append(f)
    if seen and np.concatenate(seen).size:
        lo, hi = np.percentile(np.concatenate(seen), [2, 98])
        pad = 0.3 * (hi - lo) + 1e-9 * abs(hi)
        ax[0, 0].set_ylim(lo - pad, hi + pad)
    ax[0, 0].set_xlabel("amplitude [m]")
    ax[0, 0].set_ylabel("frequency [Hz]")
    ax[0, 0].set_title("backbone", fontsize=9)
    ax[0, 1].set_xlabel("amplitude [m]")
    ax[0, 1].set_ylabel("damping ratio [-]")
    ax[0, 1].set_title("damping versus amplitude", fontsize=9)
    ax[0, 0].legend(fontsize=8)
    return fig


def residual_figure(diag: Diagnosis, records: Sequence[Record], max_points: int = 20000,
                    cache: dict | None = None) -> Figure:
    """Force the model misses over (x, v): baseline, and after the extension."""
    models = [("baseline", diag.judging.model)]
    modal = _modal(diag)
    if (diag.cause not in ("none", "unexplained") and modal is None
            and diag.extended.model.effect("second_mode") is None):  # type: ignore[union-attr]
        models.append((f"+ {diag.cause}", diag.extended.model))
    n_modes = len(modal.modes) if modal is not None else 0
    fig, ax = _new(1, len(models) + n_modes, (5.2 * (len(models) + n_modes), 4.2))
    for k in range(n_modes):
        assert modal is not None
        _modal_residual(ax[0, len(models) + k], diag, modal, k, max_points, cache)
    xs = np.concatenate([r.x[r.free_start:r.free_stop] for r in records])
    vs = np.concatenate([r.v[r.free_start:r.free_stop] for r in records])
    step = max(1, xs.size // max_points)

    def per_record(eom) -> np.ndarray:  # record by record: a hysteretic force follows each path
        return np.concatenate([residual_force(eom, r.x[r.free_start:r.free_stop], r.v[r.free_start:r.free_stop],
                                              r.a[r.free_start:r.free_stop],
                                              None if r.force is None else r.force[r.free_start:r.free_stop])
                               for r in records])

    res0 = per_record(models[0][1])
    lim = float(np.nanpercentile(np.abs(res0), 99)) or 1.0
    for k, (name, eom) in enumerate(models):
        res = per_record(eom)
        sc = ax[0, k].scatter(xs[::step], vs[::step], c=res[::step], s=1, cmap="coolwarm",
                              vmin=-lim, vmax=lim, rasterized=True)
        ax[0, k].set_xlabel("x [m]")
        ax[0, k].set_ylabel("v [m/s]")
        ax[0, k].ticklabel_format(axis="both", style="sci", scilimits=(-2, 3))
        ax[0, k].set_title(f"residual force, {name}", fontsize=9)
    fig.colorbar(sc, ax=ax[0, len(models) - 1], label="F - m a - model [N]")
    return fig


def _modal_residual(q: Axes, diag: Diagnosis, model: ModalSumModel, k: int, max_points: int,
                    cache: dict | None = None) -> None:
    """Mode k: the force its linear part misses (measured component) against modal displacement,
    with the model's nonlinear stiffness over it."""
    eom = model.modes[k]
    lin_d = {t: c for t, c in eom.damping.items() if parse_term(t).exponents == (0, 1, 0, 0, 0, 0)}
    lin_k = {t: c for t, c in eom.stiffness.items() if parse_term(t).exponents == (1, 0, 0, 0, 0, 0)}
    nl_k = {t: c for t, c in eom.stiffness.items() if t not in lin_k}
    xs, rs = [], []
    for h in diag.held_out:
        if h.v_measured is None:
            continue
        x, v, a, keep = _measured_modes(h, model, cache)
        xk, vk, ak = x[k][keep], v[k][keep], a[k][keep]
        lin = sum((c * parse_term(t)(xk, vk) for t, c in {**lin_d, **lin_k}.items()), np.zeros_like(xk))
        xs.append(xk)
        rs.append(-ak - lin)
    if not xs:
        return
    x, r = np.concatenate(xs), np.concatenate(rs)
    step = max(1, x.size // max_points)
    q.plot(x[::step] * 1e3, r[::step], ".", ms=1, color="0.5", alpha=0.3,
           label="measured: -a - (linear part)", rasterized=True)
    grid = np.linspace(np.percentile(x, 0.5), np.percentile(x, 99.5), 200)
    knl = sum((c * parse_term(t)(grid, np.zeros_like(grid)) for t, c in nl_k.items()), np.zeros_like(grid))
    terms = " ".join(f"{c:+.3g} {t}" for t, c in nl_k.items()) or "none"
    q.plot(grid * 1e3, knl, color=_COLORS["extended"], lw=2, label=f"model: {terms}")
    lim = float(np.percentile(np.abs(r), 99.5))
    q.set_ylim(-1.3 * lim, 1.3 * lim)
    q.set_xlabel(f"mode {k + 1} displacement [mm]")
    q.set_ylabel("force per unit modal mass [N/kg]")
    q.set_title(f"mode {k + 1}: internal force its linear part misses\n(sign opposite to x: "
                "softening; same sign: hardening)", fontsize=9)
    q.legend(fontsize=7, loc="upper left")


def spectra_figure(diag: Diagnosis) -> Figure:
    """Amplitude spectra of the held-out parts (measured, baseline, extended)."""
    n = len(diag.held_out)
    cols = 1 if n <= 3 else 3
    rows = (n + cols - 1) // cols
    fig, ax = _new(rows, cols, (8.0 if cols == 1 else 15.0, 2.4 * rows + 0.6))
    model = _modal(diag)
    for i, h in enumerate(diag.held_out):
        q = ax[i // cols, i % cols]
        rate = 1.0 / float(h.t[1] - h.t[0])
        fmax = rate / 2
        for name, x in (("measured", h.x_measured), ("baseline", h.x_baseline), ("extended", h.x_extended)):
            if name == "extended" and diag.cause in ("none", "unexplained"):
                continue
            if not np.all(np.isfinite(x)):
                continue
            f, amp = spectrum(x - np.mean(x), rate)
            if name == "measured":
                top = 4 * _peak(f, amp) if model is None else 1.6 * max(model.natural_frequencies_hz())
                fmax = min(rate / 2, top)
            keep = (f > 0) & (f < fmax)
            lab = {"measured": "measured", "baseline": "baseline", "extended": f"+ {diag.cause}"}[name]
            q.semilogy(f[keep], amp[keep], color=_COLORS[name], lw=0.8, alpha=0.85, label=lab)
        if model is not None:
            for k, fk in enumerate(model.natural_frequencies_hz()):
                q.axvline(fk, color="0.5", ls=":", lw=0.8)
                q.text(fk, q.get_ylim()[1], f" mode {k + 1}", fontsize=7, va="top", color="0.3")
        q.set_title(f"held out: {h.part.label}", fontsize=9)
        q.set_ylabel("|X| [m]")
        q.set_xlabel("frequency [Hz]")
        if i == 0:  # proxies: a diverged simulation is not drawn, its label still belongs here
            names = ["measured", "baseline"] + ([] if diag.cause in ("none", "unexplained") else ["extended"])
            q.legend([Line2D([], [], color=_COLORS[nm], lw=1) for nm in names],
                     [{"measured": "measured", "baseline": "baseline",
                       "extended": f"+ {diag.cause}"}[nm] for nm in names], fontsize=7, loc="lower left")
    for j in range(n, rows * cols):
        ax[j // cols, j % cols].set_visible(False)
    return fig


def _peak(f: np.ndarray, amp: np.ndarray) -> float:
    k = int(np.argmax(amp[1:])) + 1 if amp.size > 1 else 0
    return float(f[k]) if f.size else 1.0


_CAPTIONS = {
    "timeseries.png": "Held-out parts: measured displacement [m] against the baseline's (and the extended "
                      "model's) simulation fitted without that part, versus time [s].",
    "energy_per_cycle.png": "Energy lost per cycle [J] versus amplitude [m], log-log: slope 1 reads as dry "
                            "friction, 2 as viscous damping, 3 as quadratic drag.",
    "backbone.png": "Frequency [Hz] and damping ratio [-] versus amplitude [m], cycle by cycle.",
    "residual_force.png": "Force the baseline misses [N] over the phase plane (displacement [m], "
                          "velocity [m/s]).",
    "spectra.png": "Amplitude spectra [m] of the held-out parts versus frequency [Hz].",
}


def _html(diag: Diagnosis, records: Sequence[Record], figures: Sequence[Path]) -> str:
    """The page: verdict, noise floor, candidates, symptoms, figures (every number with its unit)."""
    import html

    esc = html.escape
    fl = diag.noise_floor
    rows = []
    for c in diag.candidates:
        if c.skipped:
            rows.append(f"<tr><td>{esc(c.name)}</td><td colspan='4'>skipped: {esc(c.skipped)}</td></tr>")
            continue
        params = ", ".join(f"{esc(k)} = {v:.4g}" for k, v in c.params.items())
        rows.append(f"<tr><td>{esc(c.name)}</td><td>{c.nrmse:.4g}</td><td>{100 * c.gain:+.0f} %</td>"
                    f"<td>{'yes' if c.wins_every_part else 'no'}</td><td>{params}</td></tr>")
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>Diagnosis</title>",
        "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse}"
        "td,th{border:1px solid #ccc;padding:3px 6px}img{max-width:100%}</style></head><body>",
        f"<h1>Diagnosis: cause <code>{esc(diag.cause)}</code></h1>",
        f"<p>{esc(diag.verdict)}</p>",
        f"<p>What the baseline got wrong: {esc(diag.symptom)}.</p>",
        f"<p>Records: {esc(', '.join(r.label or '?' for r in records))}; held-out judging: "
        f"{esc(diag.scheme)} ({len(diag.parts)} parts).</p>",
        "<h2>Held-out error (displacement nrmse, dimensionless)</h2><table>"
        "<tr><th>model</th><th>held-out nrmse [-]</th><th>gain</th><th>better on every part</th>"
        "<th>parameters (SI)</th></tr>",
        f"<tr><td>noise floor</td><td>{fl.nrmse:.4g}</td><td></td><td></td><td>{esc(fl.method)}</td></tr>"
        + (f"<tr><td>floor of the data</td><td>{fl.data_nrmse:.4g}</td><td></td><td></td><td>the noise floor with "
           f"the baseline's own refit spread counted at most {PRED_CAP:g}x the records' share: what "
           "<code>none</code> is judged against</td></tr>" if fl.data_fold_nrmse and fl.data_nrmse < 0.999 * fl.nrmse else "")
        if fl is not None else "",
        (f"<tr><td>baseline (the pipeline's, as station identify"
         f"{'' if diag.pipeline and diag.pipeline.held_out else '; on its fit record, not held out'})</td>"
         f"<td>{diag.baseline.nrmse:.4g}</td>"
         f"<td></td><td></td><td><code>{esc(diag.baseline.model.equation_text())}</code></td></tr>"
         if diag.judged is not None else ""),
        f"<tr><td>baseline{' per fold (the candidates are judged against it)' if diag.judged is not None else ''}"
        f"</td><td>{diag.judging.nrmse:.4g}</td><td></td><td></td>"
        f"<td><code>{esc(diag.judging.model.equation_text())}</code></td></tr>",
        *rows, "</table>",
        "<h2>Symptoms</h2><ul>", *[f"<li><b>{esc(s.kind)}</b>: {esc(s.text)}</li>" for s in diag.symptoms],
        "</ul>", "<h2>Figures</h2>",
    ]
    for f in figures:
        cap = _CAPTIONS.get(f.name, f.name)
        parts.append(f"<figure><img src='{esc(f.name)}' alt='{esc(cap)}'><figcaption>{esc(cap)}"
                     "</figcaption></figure>")
    parts.append("</body></html>\n")
    return "\n".join(parts)


def write_report(diag: Diagnosis, records: Sequence[Record], out_dir: str | Path) -> list[Path]:
    """Write ``index.html`` and every figure of the diagnosis (PNG) into ``out_dir`` (created).

    Returns
    -------
    list of Path
        The files written (figures first, ``index.html`` last).
    """
    out = Path(out_dir)
    cache: dict = {}  # separated modal components of each held-out part, shared by the figures
    figures = {
        "timeseries.png": timeseries_figure(diag),
        "energy_per_cycle.png": energy_figure(diag, cache),
        "backbone.png": backbone_figure(diag, cache),
        "residual_force.png": residual_figure(diag, records, cache=cache),
        "spectra.png": spectra_figure(diag),
    }
    try:
        out.mkdir(parents=True, exist_ok=True)
        files = [save(fig, out / name) for name, fig in figures.items()]
        index = out / "index.html"
        index.write_text(_html(diag, records, files), encoding="utf-8")
    except OSError as exc:  # a full disk, a read-only folder: one line naming the folder
        what = "disk full" if exc.errno == errno.ENOSPC else (exc.strerror or str(exc))
        raise StorageError(f"{out}: cannot write the diagnosis report ({what})") from None
    return files + [index]
