"""The paper's figure set, drawn from plain arrays with matplotlib (Agg, no pyplot).

Every function takes arrays in SI units and returns a :class:`matplotlib.figure.Figure`;
:func:`save` writes it as PNG and closes nothing global (no pyplot state is used, so figures
can be drawn from any thread and are garbage-collected with their last reference).

Long records (a 45 s capture at 19.2 kHz is 864 000 samples) are reduced for drawing with a
min/max envelope (:func:`envelope`), which keeps every peak visible while plotting a few
thousand points. The figures follow the paper (Lopez et al., EDDI): Fig. 10 (force,
displacement with CWT and Fourier spectra, kinetic energy with T at the zero crossings,
dissipated energy, mechanical energy), Fig. 11 (conservative force vs displacement, validation
overlays) and Fig. 12 (validation on impacts not used for the fit).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

#: Points kept per curve when a record is reduced for drawing.
PLOT_POINTS = 4000

_MEASURED = "#1f4e79"
_MODEL = "#c0392b"
#: The one time origin of every panel: the trigger (the report shifts its times so).
TIME_LABEL = "time after the trigger [s]"


def envelope(t: np.ndarray, y: np.ndarray, max_points: int = PLOT_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """Reduce a curve for drawing, keeping the minimum and maximum of each bin.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Abscissa (sorted).
    y : ndarray, shape (n,)
        Ordinate.
    max_points : int
        Upper bound on the points returned (even, >= 4).

    Returns
    -------
    t_out, y_out : ndarray, shape (m,), m <= max(n, max_points)
        The curve itself when ``n <= max_points``; otherwise, for each of ``max_points // 2``
        bins, its minimum and maximum in time order (so peaks survive the reduction).
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    n = y.shape[0]
    if n <= max_points:
        return t, y
    bins = max(2, max_points // 2)
    per = n // bins
    used = per * bins
    yb = y[:used].reshape(bins, per)
    tb = t[:used].reshape(bins, per)
    i_min = np.nanargmin(np.where(np.isnan(yb), np.inf, yb), axis=1)
    i_max = np.nanargmax(np.where(np.isnan(yb), -np.inf, yb), axis=1)
    first = np.minimum(i_min, i_max)
    second = np.maximum(i_min, i_max)
    rows = np.arange(bins)
    t_out = np.column_stack([tb[rows, first], tb[rows, second]]).ravel()
    y_out = np.column_stack([yb[rows, first], yb[rows, second]]).ravel()
    if used < n:
        t_out = np.append(t_out, t[-1])
        y_out = np.append(y_out, y[-1])
    return t_out, y_out


def save(fig: Figure, path: str | Path, dpi: int = 100) -> Path:
    """Write ``fig`` as PNG to ``path`` and return the path.

    Every text is drawn as plain text (no mathtext): a file name such as ``ring$x^2$.csv`` in a
    title is shown as it is, never parsed (a lone ``$`` would otherwise stop the report).
    """
    from matplotlib.text import Text

    for text in fig.findobj(Text):
        text.set_parse_math(False)
    path = Path(path)
    fig.savefig(path, dpi=dpi, format="png")
    return path


def _new(rows: int = 1, cols: int = 1, size: tuple[float, float] = (8.0, 3.2),
         **kw: object) -> tuple[Figure, np.ndarray]:
    fig = Figure(figsize=size, layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False, **kw)
    return fig, axes


def force_figure(t: np.ndarray, force: np.ndarray, title: str = "Excitation") -> Figure:
    """Measured force: the whole record and a zoom on the impact (paper Fig. 10(a)).

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    force : ndarray, shape (n,), [N]
    title : str
    """
    t = np.asarray(t, float)
    force = np.asarray(force, float)
    fig, ax = _new(1, 2, size=(9.0, 3.0), width_ratios=[2, 1])
    ax[0, 0].plot(*envelope(t, force), color=_MEASURED, lw=0.8)
    ax[0, 0].set_xlabel(TIME_LABEL)
    ax[0, 0].set_ylabel("force [N]")
    ax[0, 0].set_title(title)
    k = int(np.nanargmax(np.abs(force))) if force.size else 0
    # zoom on the pulse: where |F| exceeds 5 % of the peak, with its own width on each side
    above = np.flatnonzero(np.abs(force) > 0.05 * abs(force[k])) if force.size else np.zeros(1, int)
    near = above[np.abs(above - k) < max(t.size // 50, 50)]
    lo, hi = (int(near.min()), int(near.max())) if near.size else (k, k)
    width = max(hi - lo, 5)
    sl = slice(max(lo - 2 * width, 0), min(hi + 3 * width, t.size))
    ax[0, 1].plot(t[sl] * 1e3, force[sl], color=_MEASURED, lw=1.0, marker=".", ms=2)
    ax[0, 1].set_xlabel("time after the trigger [ms]")
    ax[0, 1].set_ylabel("force [N]")
    ax[0, 1].set_title(f"impact, peak {force[k]:.4g} N" if force.size else "impact")
    return fig


def response_figure(
    t: np.ndarray,
    x: np.ndarray,
    cwt_t: np.ndarray,
    cwt_freqs_hz: np.ndarray,
    cwt_amplitude: np.ndarray,
    spectrum_f_hz: np.ndarray,
    spectrum_amplitude: np.ndarray,
    title: str = "Displacement",
    x_label: str = "displacement [m]",
) -> Figure:
    """Displacement with its CWT map and Fourier spectrum (paper Fig. 10(b)).

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    x : ndarray, shape (n,), [m]
    cwt_t : ndarray, shape (nt,), [s]
        Times of the CWT columns.
    cwt_freqs_hz : ndarray, shape (nf,), [Hz]
    cwt_amplitude : ndarray, shape (nf, nt)
        Wavelet amplitude (any consistent unit; drawn on a linear colour scale).
    spectrum_f_hz : ndarray, shape (m,), [Hz]
    spectrum_amplitude : ndarray, shape (m,)
        Fourier amplitude of ``x``.
    """
    fig, ax = _new(2, 2, size=(9.0, 5.6), width_ratios=[3, 1])
    ax[1, 0].sharex(ax[0, 0])
    ax[0, 0].plot(*envelope(t, x), color=_MEASURED, lw=0.8)
    ax[0, 0].set_ylabel(x_label)
    ax[0, 0].set_title(title)
    mesh = _cwt_panel(ax[1, 0], cwt_t, cwt_freqs_hz, cwt_amplitude)
    ax[1, 0].set_xlabel(TIME_LABEL)
    fig.colorbar(mesh, ax=ax[1, 0], location="bottom", fraction=0.07, pad=0.02, aspect=50,
                 label=f"CWT amplitude [{_unit(x_label)}]")
    _zoom_panel(ax[0, 1], t, x, None, start=True)
    _spectrum_panel(ax[1, 1], cwt_freqs_hz, [(spectrum_f_hz, spectrum_amplitude, "measured", _MEASURED)],
                    unit=_unit(x_label))
    return fig


def _unit(label: str) -> str:
    """``"displacement [m]"`` -> ``"m"``."""
    return label[label.find("[") + 1: label.rfind("]")] if "[" in label else ""


def _cwt_panel(ax: object, t: np.ndarray, freqs: np.ndarray, amp: np.ndarray, vmax: float | None = None):
    """The CWT map (no blank margin: limits are the data's); returns the mesh for a colour bar."""
    amp = np.asarray(amp, float)
    ax.set_ylabel("frequency [Hz]")
    if np.size(t):
        ax.set_xlim(float(np.min(t)), float(np.max(t)))
    return ax.pcolormesh(np.asarray(t, float), np.asarray(freqs, float), amp, shading="auto", cmap="viridis",
                  vmin=0.0, vmax=vmax if vmax is not None else float(np.nanmax(amp)) if amp.size else 1.0,
                  rasterized=True)


def _zoom_panel(ax: object, t: np.ndarray, xm: np.ndarray, xs: np.ndarray | None, fraction: float = 0.1,
                start: bool = False) -> None:
    """The last (or first) ``fraction`` of the record, measured and simulated, unreduced."""
    t = np.asarray(t, float)
    n = t.size
    k = max(int(fraction * n), 2)
    sl = slice(0, min(n, k)) if start else slice(max(0, n - k), n)
    step = max(1, (sl.stop - sl.start) // 3000)
    ax.plot(t[sl][::step], np.asarray(xm, float)[sl][::step], color=_MEASURED, lw=1.6, alpha=0.6, label="measured")
    if xs is not None:
        ax.plot(t[sl][::step], np.asarray(xs, float)[sl][::step], color=_MODEL, lw=0.9, ls="--", label="simulated")
    ax.set_title("start of the record" if start else "end of the record", fontsize=9)
    ax.set_xlabel("[s]", fontsize=7)
    ax.tick_params(labelsize=7)
    ax.tick_params(axis="x", labelbottom=True)


def _spectrum_panel(ax: object, freqs_cwt: np.ndarray, curves: list[tuple[np.ndarray, np.ndarray, str, str]],
                    unit: str = "m") -> None:
    """Fourier amplitude against frequency; the first curve (measured) wide and light, the
    others thin and dashed on top, so the measurement stays visible under the simulation."""
    f_lo = float(np.min(freqs_cwt)) if np.size(freqs_cwt) else 0.0
    f_hi = float(np.max(freqs_cwt)) if np.size(freqs_cwt) else 1.0
    for i, (f, a, label, color) in enumerate(curves):
        f = np.asarray(f, float)
        a = np.asarray(a, float)
        keep = (f >= f_lo) & (f <= f_hi)
        if i == 0:
            ax.plot(a[keep], f[keep], color=color, lw=3.0, alpha=0.45, label=label, zorder=2)
        else:
            ax.plot(a[keep], f[keep], color=color, lw=1.0, ls="--", label=label, zorder=3)
    ax.set_ylim(f_lo, f_hi)
    ax.set_xlabel(f"Fourier amplitude [{unit}]")
    ax.set_ylabel("frequency [Hz]")
    ax.set_title("spectrum")
    if len(curves) > 1:
        ax.legend(fontsize=7, loc="upper right")


def kinetic_energy_figure(t: np.ndarray, kinetic_j: np.ndarray, crossing_t: np.ndarray,
                          crossing_kinetic_j: np.ndarray) -> Figure:
    """Kinetic energy ``T(t)`` and ``T(gamma_i)`` at the zero crossings (paper Fig. 10(c)).

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    kinetic_j : ndarray, shape (n,), [J]
    crossing_t : ndarray, shape (c,), [s]
        Times ``gamma_i`` where the displacement crosses zero.
    crossing_kinetic_j : ndarray, shape (c,), [J]
    """
    fig, ax = _new()
    a = ax[0, 0]
    a.plot(*envelope(t, kinetic_j), color=_MEASURED, lw=0.7, label="T(t)")
    a.plot(crossing_t, crossing_kinetic_j, "o", color=_MODEL, ms=2.5, label="T(γᵢ), x = 0")
    a.set_xlabel(TIME_LABEL)
    a.set_ylabel("energy [J]")
    a.set_title("Kinetic energy")
    a.legend(fontsize=8)
    return fig


def dissipated_energy_figure(crossing_t: np.ndarray, measured_j: np.ndarray, t_model: np.ndarray,
                             modelled_j: np.ndarray) -> Figure:
    """Measured vs modelled dissipated energy (paper Fig. 10(d), Eqs. 7 and 12).

    Parameters
    ----------
    crossing_t : ndarray, shape (c,), [s]
    measured_j : ndarray, shape (c,), [J]
        ``T(gamma_0) - T(gamma_i)``.
    t_model : ndarray, shape (m,), [s]
    modelled_j : ndarray, shape (m,), [J]
        Integral of ``v B(x, v)`` with the identified damping model.
    """
    fig, ax = _new()
    a = ax[0, 0]
    # the measured points open and wide, the model thin on top: both stay visible
    a.plot(crossing_t, measured_j, "o", color=_MEASURED, mfc="none", ms=5, mew=0.9,
           label="measured  T(γ₀) − T(γᵢ)", zorder=2)
    a.plot(*envelope(t_model, modelled_j), color=_MODEL, lw=0.8, label="model  ∫ v B(x, v) dt", zorder=3)
    a.set_xlabel(TIME_LABEL)
    a.set_ylabel("energy [J]")
    a.set_title("Dissipated energy")
    a.legend(fontsize=8)
    return fig


def mechanical_energy_figure(t: np.ndarray, kinetic_j: np.ndarray, mechanical_j: np.ndarray) -> Figure:
    """Kinetic energy and the estimated mechanical energy (paper Fig. 10(e), Eq. 12).

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    kinetic_j : ndarray, shape (n,), [J]
    mechanical_j : ndarray, shape (n,), [J]
    """
    fig, ax = _new()
    a = ax[0, 0]
    a.plot(*envelope(t, kinetic_j), color=_MEASURED, lw=0.6, label="T(t)")
    a.plot(*envelope(t, mechanical_j), color=_MODEL, lw=1.0, ls="--", label="E(t) estimated")
    a.set_xlabel(TIME_LABEL)
    a.set_ylabel("energy [J]")
    a.set_title("Mechanical energy")
    a.legend(fontsize=8)
    return fig


def restoring_force_figure(
    x: np.ndarray,
    force_measured_n: np.ndarray,
    x_model: np.ndarray,
    force_model_n: np.ndarray,
    t: np.ndarray | None = None,
    quantity: str = "force [N]",
    title: str = "Restoring force",
) -> Figure:
    """Conservative force against displacement, data and model (paper Fig. 11(a), (b)).

    Parameters
    ----------
    x : ndarray, shape (n,), [m]
        Displacement at the samples where phase two estimated the conservative force.
    force_measured_n : ndarray, shape (n,), [N]
        Conservative force estimated from the reformulated Lagrangian (Eq. 16).
    x_model : ndarray, shape (m,), [m]
    force_model_n : ndarray, shape (m,), [N]
        Identified stiffness model ``sum k_n K_n(x)`` on ``x_model``.
    t : ndarray, shape (n,), [s], optional
        Sample times; when given, a time-series panel is added (Fig. 11(a)).
    quantity : str
        Label of the ordinate (``"potential energy [J]"`` for the potential route).
    title : str
    """
    x = np.asarray(x, float)
    fm = np.asarray(force_measured_n, float)
    if t is not None:
        fig, ax = _new(1, 2, size=(9.0, 3.4))
        a_t, a = ax[0, 0], ax[0, 1]
        t = np.asarray(t, float)
        order = np.argsort(t)
        a_t.plot(*envelope(t[order], fm[order]), color=_MEASURED, lw=0.6, label="from energies")
        a_t.set_xlabel(TIME_LABEL)
        a_t.set_ylabel(quantity)
        a_t.set_title(title)
        a_t.legend(fontsize=8)
    else:
        fig, ax = _new(size=(5.0, 3.8))
        a = ax[0, 0]
    step = max(1, x.size // 20000)
    order = np.argsort(np.asarray(x_model, float))
    # the data wide and light, the model thin and dashed on top: both stay visible
    a.plot(x[::step], fm[::step], ".", color=_MEASURED, ms=5.0, alpha=0.25, mew=0, label="from energies", zorder=2)
    a.plot(np.asarray(x_model, float)[order], np.asarray(force_model_n, float)[order], color=_MODEL, lw=1.0,
           ls="--", label="identified model", zorder=3)
    a.set_xlabel("displacement [m]")
    a.set_ylabel(quantity)
    a.set_title(title)
    a.legend(fontsize=8)
    return fig


def validation_figure(
    t: np.ndarray,
    x_measured: np.ndarray,
    x_simulated: np.ndarray,
    cwt_t: np.ndarray,
    cwt_freqs_hz: np.ndarray,
    cwt_measured: np.ndarray,
    cwt_simulated: np.ndarray,
    spectrum_f_hz: np.ndarray,
    spectrum_measured: np.ndarray,
    spectrum_simulated: np.ndarray,
    title: str = "Validation",
) -> Figure:
    """Measured vs simulated response: time series, both CWT maps, Fourier spectra (Figs. 11(c), 12).

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    x_measured, x_simulated : ndarray, shape (n,), [m]
    cwt_t : ndarray, shape (nt,), [s]
    cwt_freqs_hz : ndarray, shape (nf,), [Hz]
    cwt_measured, cwt_simulated : ndarray, shape (nf, nt)
        Wavelet amplitudes; drawn on the same colour scale.
    spectrum_f_hz : ndarray, shape (m,), [Hz]
    spectrum_measured, spectrum_simulated : ndarray, shape (m,)
    title : str
    """
    fig, ax = _new(3, 2, size=(9.0, 7.0), width_ratios=[3, 1])
    for r in (1, 2):  # time axes shared; the zoom (time) and spectrum (amplitude) are not
        ax[r, 0].sharex(ax[0, 0])
    a = ax[0, 0]
    a.plot(*envelope(t, x_measured), color=_MEASURED, lw=1.6, alpha=0.6, label="measured")
    a.plot(*envelope(t, x_simulated), color=_MODEL, lw=0.8, ls="--", label="simulated")
    a.set_ylabel("displacement [m]")
    a.set_title(title)
    a.legend(fontsize=8, loc="upper right")
    vmax = (float(max(np.nanmax(cwt_measured), np.nanmax(np.nan_to_num(cwt_simulated))))
            if np.size(cwt_measured) else None)
    mesh = _cwt_panel(ax[1, 0], cwt_t, cwt_freqs_hz, cwt_measured, vmax)
    ax[1, 0].set_title("CWT, measured", fontsize=9)
    _cwt_panel(ax[2, 0], cwt_t, cwt_freqs_hz, np.nan_to_num(cwt_simulated), vmax)
    ax[2, 0].set_title("CWT, simulated", fontsize=9)
    ax[2, 0].set_xlabel(TIME_LABEL)
    _zoom_panel(ax[0, 1], t, x_measured, x_simulated)
    # the colour bar of both maps (same scale) where a blank cell would be
    ax[1, 1].axis("off")
    fig.colorbar(mesh, cax=ax[1, 1].inset_axes((0.05, 0.05, 0.12, 0.9)), label="CWT amplitude [m]")
    ax[0, 1].legend(fontsize=6, loc="lower right")
    _spectrum_panel(ax[2, 1], cwt_freqs_hz, [
        (spectrum_f_hz, spectrum_measured, "measured", _MEASURED),
        (spectrum_f_hz, spectrum_simulated, "simulated", _MODEL),
    ])
    return fig
