"""Figures of a diagnosis (``station diagnose --report DIR``), one PNG per step.

* ``timeseries.png``: each held-out part, measured versus the baseline's and the extended
  model's simulations (fitted without that part);
* ``energy_per_cycle.png``: energy lost per cycle versus amplitude (measured, baseline,
  extended), log-log, so a slope of 1 reads as dry friction, 2 as viscous, 3 as quadratic drag;
* ``backbone.png``: instantaneous frequency and damping ratio versus amplitude;
* ``residual_force.png``: force the baseline misses over the phase plane ``(x, v)``, and what
  is left after the extension;
* ``spectra.png``: amplitude spectra of the held-out parts.

Figures are built on :class:`matplotlib.figure.Figure` (Agg canvas, no pyplot state).
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from eddi.diagnose import Diagnosis, Record, backbone, energy_per_cycle, residual_force, spectrum  # noqa: E402
from station.figures import envelope, save  # noqa: E402

_COLORS = {"measured": "0.2", "baseline": "tab:red", "extended": "tab:blue"}


def _new(rows: int, cols: int, size: tuple[float, float]) -> tuple[Figure, np.ndarray]:
    fig = Figure(figsize=size, layout="constrained")
    return fig, fig.subplots(rows, cols, squeeze=False)


def _curves(diag: Diagnosis) -> list[tuple[str, list[tuple[np.ndarray, np.ndarray]]]]:
    """(label, [(t, x) per held-out part]) for measured, baseline, extended."""
    out = []
    for name, attr in (("measured", "x_measured"), ("baseline", "x_baseline"), ("extended", "x_extended")):
        if name == "extended" and diag.cause == "none":
            continue
        out.append((name, [(h.t, getattr(h, attr)) for h in diag.held_out]))
    return out


def timeseries_figure(diag: Diagnosis) -> Figure:
    """Held-out parts: measured versus simulated coordinate."""
    n = len(diag.held_out)
    fig, ax = _new(n, 1, (9.0, 2.2 * n + 0.5))
    for i, h in enumerate(diag.held_out):
        a = ax[i, 0]
        a.plot(*envelope(h.t, h.x_measured), color=_COLORS["measured"], lw=0.8, label="measured")
        if np.all(np.isfinite(h.x_baseline)):
            a.plot(*envelope(h.t, h.x_baseline), color=_COLORS["baseline"], lw=0.7, alpha=0.8,
                   label=f"baseline ({diag.baseline.fold_nrmse[i]:.3g})")
        if diag.cause != "none" and np.all(np.isfinite(h.x_extended)):
            a.plot(*envelope(h.t, h.x_extended), color=_COLORS["extended"], lw=0.7, alpha=0.8,
                   label=f"+ {diag.cause} ({diag.extended.fold_nrmse[i]:.3g})")
        a.set_title(f"held out: {h.part.label}", fontsize=9)
        a.set_ylabel("x")
        a.legend(fontsize=7, loc="upper right")
    ax[-1, 0].set_xlabel("time in part [s]" if diag.scheme == "amplitude-bands" else "time [s]")
    return fig


def energy_figure(diag: Diagnosis) -> Figure:
    """Energy lost per cycle versus amplitude, log-log."""
    mass = diag.baseline.model.mass
    fig, ax = _new(1, 1, (6.0, 4.2))
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
            a.loglog(amp[keep], de[keep], ".", ms=3, color=_COLORS[name], label=name)
    a.set_xlabel("amplitude")
    a.set_ylabel("energy lost per cycle [J]")
    a.set_title("slope 1: dry friction, 2: viscous, 3: quadratic drag", fontsize=9)
    a.legend(fontsize=8)
    return fig


def backbone_figure(diag: Diagnosis) -> Figure:
    """Frequency and damping ratio versus amplitude, cycle by cycle."""
    mass = diag.baseline.model.mass
    fig, ax = _new(1, 2, (10.0, 3.8))
    for name, parts in _curves(diag):
        for k, (t, x) in enumerate(parts):
            ok = np.isfinite(x)
            if ok.sum() < 8:
                continue
            v = np.gradient(x[ok], t[ok])
            amp, f, z = backbone(t[ok], x[ok], v, mass)
            lab = name if k == 0 else None
            ax[0, 0].semilogx(amp, f, ".", ms=3, color=_COLORS[name], label=lab)
            ax[0, 1].loglog(amp[z > 0], z[z > 0], ".", ms=3, color=_COLORS[name], label=lab)
    ax[0, 0].set_xlabel("amplitude")
    ax[0, 0].set_ylabel("frequency [Hz]")
    ax[0, 0].set_title("backbone", fontsize=9)
    ax[0, 1].set_xlabel("amplitude")
    ax[0, 1].set_ylabel("damping ratio")
    ax[0, 1].set_title("damping versus amplitude", fontsize=9)
    ax[0, 0].legend(fontsize=8)
    return fig


def residual_figure(diag: Diagnosis, records: Sequence[Record], max_points: int = 20000) -> Figure:
    """Force the model misses over (x, v): baseline, and after the extension."""
    models = [("baseline", diag.baseline.model)]
    if diag.cause != "none" and diag.extended.model.effect("second_mode") is None:
        models.append((f"+ {diag.cause}", diag.extended.model))
    fig, ax = _new(1, len(models), (5.2 * len(models), 4.2))
    xs = np.concatenate([r.x[r.free_start:r.free_stop] for r in records])
    vs = np.concatenate([r.v[r.free_start:r.free_stop] for r in records])
    a_ = np.concatenate([r.a[r.free_start:r.free_stop] for r in records])
    fs = np.concatenate([(r.force if r.force is not None else np.zeros_like(r.x))[r.free_start:r.free_stop]
                         for r in records])
    step = max(1, xs.size // max_points)
    res0 = residual_force(models[0][1], xs, vs, a_, fs)
    lim = float(np.nanpercentile(np.abs(res0), 99)) or 1.0
    for k, (name, eom) in enumerate(models):
        res = residual_force(eom, xs, vs, a_, fs)
        sc = ax[0, k].scatter(xs[::step], vs[::step], c=res[::step], s=1, cmap="coolwarm",
                              vmin=-lim, vmax=lim, rasterized=True)
        ax[0, k].set_xlabel("x")
        ax[0, k].set_ylabel("v")
        ax[0, k].set_title(f"residual force, {name}", fontsize=9)
    fig.colorbar(sc, ax=ax[0, -1], label="F - m a - model [N]")
    return fig


def spectra_figure(diag: Diagnosis) -> Figure:
    """Amplitude spectra of the held-out parts (measured, baseline, extended)."""
    n = len(diag.held_out)
    fig, ax = _new(n, 1, (8.0, 2.2 * n + 0.5))
    for i, h in enumerate(diag.held_out):
        rate = 1.0 / float(h.t[1] - h.t[0])
        for name, x in (("measured", h.x_measured), ("baseline", h.x_baseline), ("extended", h.x_extended)):
            if name == "extended" and diag.cause == "none":
                continue
            if not np.all(np.isfinite(x)):
                continue
            f, amp = spectrum(x, rate)
            keep = (f > 0) & (f < min(rate / 2, 50 * _peak(f, amp)))
            ax[i, 0].semilogy(f[keep], amp[keep], color=_COLORS[name], lw=0.7, label=name)
        ax[i, 0].set_title(f"held out: {h.part.label}", fontsize=9)
        ax[i, 0].set_ylabel("|X|")
        ax[i, 0].legend(fontsize=7)
    ax[-1, 0].set_xlabel("frequency [Hz]")
    return fig


def _peak(f: np.ndarray, amp: np.ndarray) -> float:
    k = int(np.argmax(amp[1:])) + 1 if amp.size > 1 else 0
    return float(f[k]) if f.size else 1.0


def write_report(diag: Diagnosis, records: Sequence[Record], out_dir: str | Path) -> list[Path]:
    """Write every figure of the diagnosis as PNG into ``out_dir`` (created).

    Returns
    -------
    list of Path
        The files written.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures = {
        "timeseries.png": timeseries_figure(diag),
        "energy_per_cycle.png": energy_figure(diag),
        "backbone.png": backbone_figure(diag),
        "residual_force.png": residual_figure(diag, records),
        "spectra.png": spectra_figure(diag),
    }
    return [save(fig, out / name) for name, fig in figures.items()]
