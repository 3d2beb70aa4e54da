"""HTML report of a session: the paper's figure set as PNGs and the coefficient table.

:func:`write_report` draws, for the record identified on (Lopez et al., EDDI, Fig. 10 and 11):

* ``force.png``: the measured force, whole record and the impact;
* ``displacement.png``: the displacement with its Morlet CWT and Fourier spectrum;
* ``kinetic.png``: the kinetic energy with ``T`` at the zero crossings of ``x``;
* ``dissipated.png``: measured versus modelled dissipated energy;
* ``mechanical.png``: the estimated mechanical energy;
* ``restoring.png``: the conservative force (Lagrangian route) or the potential energy
  (potential route) against the displacement, data and identified model;

and, for every record not used for the fit (Fig. 12), ``validation_N.png``: measured versus
simulated displacement in time, as CWT maps and as Fourier spectra. ``index.html`` shows them
with the coefficient table (and the rig's true values when the captures come from the
simulated rig) and the validation table.

Figures are :class:`matplotlib.figure.Figure` objects on the Agg canvas (no pyplot state).
The CWT is taken on the displacement averaged over blocks down to about ten samples per
period of the highest analysed frequency, so a 45 s capture at 19.2 kHz costs little.
"""

from __future__ import annotations

import html
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402

from eddi.energy import integrated_term, term_matrix  # noqa: E402
from eddi.model import EquationOfMotion  # noqa: E402
from eddi.validate import cwt_map, spectra  # noqa: E402
from station import figures  # noqa: E402
from station.session import RecordCheck, SessionResult, peak_force  # noqa: E402
from station.storage import StorageError  # noqa: E402

#: Frequencies of each CWT map.
CWT_FREQUENCIES = 64
#: Samples per period of the highest CWT frequency kept when the record is averaged down.
CWT_SAMPLES_PER_PERIOD = 10


@dataclass(frozen=True)
class Report:
    """What :func:`write_report` wrote.

    Attributes
    ----------
    index : Path
        The HTML page.
    figures : tuple of Path
        Every PNG, in page order.
    band_hz : tuple of float
        Frequency band of the CWT maps and spectra [Hz].
    """

    index: Path
    figures: tuple[Path, ...] = field(default_factory=tuple)
    band_hz: tuple[float, float] = (0.0, 0.0)


def dominant_frequency(t: np.ndarray, x: np.ndarray) -> float:
    """Frequency of the largest Fourier amplitude above two cycles per record [Hz].

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    x : ndarray, shape (n,)
    """
    sp = spectra(t, x, x)
    f, a = sp["freq_hz"], sp["measured"]
    span = float(t[-1] - t[0]) or 1.0
    keep = f > 2.0 / span
    if not np.any(keep):
        return 1.0
    return float(f[keep][int(np.argmax(a[keep]))])


def analysis_band(t: np.ndarray, x: np.ndarray) -> tuple[float, float]:
    """CWT / spectrum band around the dominant frequency ``f0``: ``[f0 / 4, 4 f0]`` [Hz].

    The low end stays above two cycles per record, the high end below a quarter of the rate.
    """
    f0 = dominant_frequency(t, x)
    span = float(t[-1] - t[0]) or 1.0
    rate = (t.size - 1) / span
    lo = max(0.25 * f0, 2.0 / span)
    hi = min(4.0 * f0, 0.25 * rate)
    return lo, max(hi, 1.5 * lo)


def cwt_view(t: np.ndarray, x: np.ndarray, band_hz: tuple[float, float],
             n_freqs: int = CWT_FREQUENCIES) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Morlet CWT magnitude of ``x`` over ``band_hz``, on a record averaged down in blocks.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    x : ndarray, shape (n,)
    band_hz : (float, float)
    n_freqs : int

    Returns
    -------
    t_cols : ndarray, shape (m,), [s]
    freqs_hz : ndarray, shape (n_freqs,), [Hz]
    amplitude : ndarray, shape (n_freqs, m)
    """
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    rate = (t.size - 1) / float(t[-1] - t[0])
    q = max(1, int(rate / (CWT_SAMPLES_PER_PERIOD * band_hz[1])))
    m = t.size // q
    if m < 8:
        q, m = 1, t.size
    td = t[: m * q].reshape(m, q).mean(axis=1)
    xd = x[: m * q].reshape(m, q).mean(axis=1)
    freqs = np.linspace(band_hz[0], band_hz[1], n_freqs)
    return td, freqs, cwt_map(td, xd, freqs)


def _spectrum(t: np.ndarray, xm: np.ndarray, xs: np.ndarray) -> dict[str, np.ndarray]:
    xs = np.where(np.isfinite(xs), xs, 0.0)
    return spectra(t, xm, xs)


def trigger_time(meas, cond=None) -> float:
    """Time of the trigger [s] on the record's clock: the one origin of every panel.

    The first sample after the pre-trigger when the record says how long it is; otherwise
    the start of the motion found by conditioning (``cond.impact_start``); otherwise ``t[0]``.
    """
    pre = getattr(meas, "pretrigger_samples", None)
    if pre is not None and 0 <= pre < meas.t.size:
        return float(meas.t[pre])
    if cond is not None:
        return float(cond.t[cond.impact_start])
    return float(meas.t[0])


def stiffness_curve(eom: EquationOfMotion, x: np.ndarray) -> np.ndarray:
    """``sum k_n K_n(x)`` [N] (stiffness terms only), shape of ``x``."""
    terms = eom.stiffness_terms()
    if not terms:
        return np.zeros_like(x)
    return term_matrix(terms, x, np.zeros_like(x)) @ np.array(list(eom.stiffness.values()))


def potential_curve(eom: EquationOfMotion, x: np.ndarray) -> np.ndarray:
    """``sum k_n integral_0^x K_n`` [J], shape of ``x``."""
    out = np.zeros_like(x)
    for term, c in zip(eom.stiffness_terms(), eom.stiffness.values()):
        out = out + c * integrated_term(term, x)
    return out


def _fit_figures(session: SessionResult, out: Path, band: tuple[float, float]) -> list[tuple[str, Path]]:
    res = session.fit
    meas = session.measurements[session.fit_index]
    cond = res.conditioned
    eom = res.model.eom
    p1 = res.model.phase_one
    p2 = res.model.phase_two
    items: list[tuple[str, Path]] = []
    src = meas.source
    t0 = trigger_time(meas, cond)
    f = meas.channels.get("force")
    if f is not None:
        items.append(("Excitation: measured force",
                      figures.save(figures.force_figure(meas.t - t0, f, title=f"Force, {src}"), out / "force.png")))
    s, e = cond.impact_start, cond.free_stop
    t, x = cond.t[s:e] - t0, cond.x[s:e]
    ct, cf, ca = cwt_view(t, x, band)
    sp = _spectrum(t, x, x)
    items.append(("Displacement with its CWT and Fourier spectrum", figures.save(
        figures.response_figure(t, x, ct, cf, ca, sp["freq_hz"], sp["measured"], title=f"Displacement, {src}"),
        out / "displacement.png")))
    items.append(("Kinetic energy, with T at the zero crossings of x", figures.save(
        figures.kinetic_energy_figure(p1.t - t0, p1.kinetic, p1.gamma - t0, p1.kinetic_at_gamma), out / "kinetic.png")))
    items.append(("Dissipated energy: measured T(γ₀) − T(γᵢ) against the identified damping model", figures.save(
        figures.dissipated_energy_figure(p1.gamma[1:] - t0, p1.r_vector, p1.t - t0, p1.dissipated),
        out / "dissipated.png")))
    items.append(("Mechanical energy estimated from the damping model", figures.save(
        figures.mechanical_energy_figure(p1.t - t0, p1.kinetic, p1.mechanical), out / "mechanical.png")))
    xg = np.linspace(float(np.min(p2.x)), float(np.max(p2.x)), 400) if p2.x.size else np.zeros(2)
    if p2.conservative_force is not None:
        fig = figures.restoring_force_figure(p2.x, -p2.conservative_force, xg, stiffness_curve(eom, xg))
        caption = "Restoring force against displacement: from the energies (Lagrangian route) and the model"
    else:
        pot = p2.potential if p2.potential is not None else np.zeros_like(p2.x)
        fig = figures.restoring_force_figure(p2.x, pot, xg, potential_curve(eom, xg),
                                             quantity="potential energy [J]", title="Potential energy")
        caption = "Potential energy against displacement: from the energies (potential route) and the model"
    items.append((caption, figures.save(fig, out / "restoring.png")))
    return items


def _validation_figure(check: RecordCheck, band: tuple[float, float], path: Path, t0: float = 0.0) -> Path:
    t, xm, xs = check.t - t0, check.measured, np.where(np.isfinite(check.simulated), check.simulated, 0.0)
    ct, cf, cm = cwt_view(t, xm, band)
    _, _, cs = cwt_view(t, xs, band)
    sp = _spectrum(t, xm, xs)
    title = f"{check.source}: nrmse {check.nrmse:.3g}" + (f", peak force {check.peak_force_n:.4g} N"
                                                           if check.peak_force_n is not None else "")
    fig = figures.validation_figure(t, xm, xs, ct, cf, cm, cs, sp["freq_hz"], sp["measured"], sp["simulated"],
                                    title=title)
    if check.quantity != "displacement":
        fig.axes[0].set_ylabel(f"{check.quantity}")
    return figures.save(fig, path)


def _fmt(v: float | None, spec: str = ".4g") -> str:
    if v is None:
        return "–"
    if not math.isfinite(v):
        return "diverged"
    return format(v, spec)


def _coefficient_rows(eom: EquationOfMotion, truth: EquationOfMotion | None,
                      ci95: dict[str, dict[str, float]] | None = None,
                      units: dict[str, dict[str, str]] | None = None) -> str:
    ci95 = ci95 or {}
    units = units or {}
    rows = [f"<tr><td>mass</td><td>m</td><td>{eom.mass:.6g}</td><td></td><td>kg</td>"
            + (f"<td>{truth.mass:.6g}</td><td></td>" if truth is not None else "") + "</tr>"]
    for kind, mine, true in (("damping", eom.damping, truth.damping if truth else None),
                             ("stiffness", eom.stiffness, truth.stiffness if truth else None)):
        for term, c in mine.items():
            ci = ci95.get(kind, {}).get(term)
            unit = units.get(kind, {}).get(term, "")
            cells = (f"<td>{kind}</td><td>{html.escape(term)}</td><td>{c:+.6g}</td>"
                     f"<td>{'± ' + format(ci, '.2g') if ci is not None else '–'}</td><td>{html.escape(unit)}</td>")
            if truth is not None:
                tv = true.get(term) if true is not None else None
                err = f"{100 * (c - tv) / abs(tv):+.1f} %" if tv else "–"
                cells += f"<td>{_fmt(tv, '+.6g')}</td><td>{err}</td>"
            rows.append(f"<tr>{cells}</tr>")
    return "\n".join(rows)


def _choices_html(res, warnings: Sequence[str] | None = None) -> str:
    """The pipeline's choices and warnings (``warnings``: all of them, when the command has more
    than the pipeline's), for the top of the page."""
    ch = res.choices
    if ch is None:
        return ""
    items = [f"phase two: <b>{html.escape(ch.route)}</b> route"
             + (" (free-response nrmse " + ", ".join(f"{k} {v:.3g}" for k, v in ch.route_scores.items()) + ")"
                if ch.route_scores else ""),
             f"output-error refinement: <b>{html.escape(ch.refinement)}</b> — {html.escape(ch.refinement_reason)}",
             "terms kept: " + html.escape(", ".join(ch.damping_terms + ch.stiffness_terms))]
    for term, why in ch.dropped.items():
        items.append(f"dropped <b>{html.escape(term)}</b>: {html.escape(why)}")
    out = "<div class='choices'><b>Pipeline choices</b><ul>" + "".join(f"<li>{i}</li>" for i in items) + "</ul>"
    shown = ch.warnings if warnings is None else tuple(warnings)
    if shown:
        out += ("<div class='warn'><b>Warnings</b><ul>"
                + "".join(f"<li>{html.escape(w)}</li>" for w in shown) + "</ul></div>")
    else:
        out += "<p>No warnings: the model is stable and decays as the records do.</p>"
    return out + "</div>"


_CSS = ("body{font-family:sans-serif;max-width:1000px;margin:2em auto;color:#222}"
        "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}"
        "td:first-child,th:first-child{text-align:left}img{max-width:100%;margin:0.5em 0 1.5em 0}"
        "figcaption{font-size:90%;color:#555}.choices{background:#f4f6f8;border:1px solid #ccd;padding:0.5em 1em}"
        ".warn{background:#fff3cd;border:1px solid #e0b000;padding:0.3em 1em;margin:0.5em 0}")


def write_report(session: SessionResult, out_dir: str | Path, *, truth: EquationOfMotion | None = None,
                 title: str = "EDDI Station report", warnings: Sequence[str] | None = None) -> Report:
    """Write ``index.html`` and its PNG figures into ``out_dir`` (created).

    Parameters
    ----------
    session : SessionResult
        From :func:`station.session.run_session`.
    out_dir : str or Path
    truth : EquationOfMotion, optional
        The true physics (simulated rig): shown beside the identified coefficients.
    title : str
    warnings : sequence of str, optional
        Every warning of the identification as the command prints it (the pipeline's and the
        AC-coupling check's); default the pipeline's.

    Returns
    -------
    Report

    Raises
    ------
    StorageError
        When the directory or a file cannot be written (one line).
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise StorageError(f"{out}: cannot create the report directory ({exc.strerror or exc})") from None
    res = session.fit
    cond = res.conditioned
    band = analysis_band(cond.t[cond.free_start:cond.free_stop], cond.x[cond.free_start:cond.free_stop])
    try:
        items = _fit_figures(session, out, band)
        others = [m for i, m in enumerate(session.measurements) if i != session.fit_index]
        held = [(c, _validation_figure(c, band, out / f"validation_{i + 1}.png", trigger_time(m)))
                for i, (c, m) in enumerate(zip(session.held_out, others))]
    except OSError as exc:
        raise StorageError(f"{out}: cannot write a figure ({exc.strerror or exc})") from None
    eom = res.model.eom
    fit_src = session.measurements[session.fit_index].source
    val = res.validation
    parts = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
             f"<style>{_CSS}</style></head><body><h1>{html.escape(title)}</h1>",
             f"<p>Identified on <b>{html.escape(fit_src)}</b> ({res.model.route} route of phase two, "
             f"{res.model.phase_one.gamma.size} zero crossings); validated on "
             f"{len(session.held_out)} record(s) not used for the fit.</p>",
             _choices_html(res, warnings),
             f"<p><code>{html.escape(eom.equation_text())}</code> (SI units; time origin of every figure: "
             f"the trigger)</p>",
             "<h2>Coefficients</h2><table><tr><th>part</th><th>term</th><th>identified</th><th>95 % CI</th>"
             "<th>unit</th>" + ("<th>rig (true)</th><th>error</th>" if truth is not None else "") + "</tr>",
             _coefficient_rows(eom, truth, res.ci95, res.units), "</table>",
             "<h2>Validation</h2><table><tr><th>record</th><th>peak force [N]</th><th>simulated</th>"
             "<th>nrmse</th><th>nmte</th></tr>",
             f"<tr><td>{html.escape(fit_src)} (fit)</td><td>{_fmt(_peak(session))}</td>"
             f"<td>{'from rest, measured force' if res.driven_by_force else 'from the measured state'}</td>"
             f"<td>{_fmt(val.nrmse)}</td><td>{_fmt(val.nmte)}</td></tr>"]
    for c, _ in held:
        parts.append(f"<tr><td>{html.escape(c.source)}</td><td>{_fmt(c.peak_force_n)}</td>"
                     f"<td>{'from rest, measured force' if c.driven_by == 'force' else 'from the measured state'}"
                     f"</td><td>{_fmt(c.nrmse)}</td><td>{_fmt(c.nmte)}</td></tr>")
    if session.held_out:
        parts.append(f"<tr><th>mean of the held-out records</th><td></td><td></td>"
                     f"<td>{_fmt(session.mean_nrmse)}</td><td>{_fmt(session.mean_nmte)}</td></tr>")
    parts.append("</table><h2>Identification</h2>")
    for caption, path in items:
        parts.append(f"<figure><img src='{path.name}' alt='{html.escape(caption)}'>"
                     f"<figcaption>{html.escape(caption)}</figcaption></figure>")
    if held:
        parts.append("<h2>Validation on records not used for the fit</h2>")
    for c, path in held:
        cap = f"{c.source}: measured and simulated {c.quantity} in time, CWT and Fourier spectrum"
        parts.append(f"<figure><img src='{path.name}' alt='{html.escape(cap)}'>"
                     f"<figcaption>{html.escape(cap)}</figcaption></figure>")
    parts.append("</body></html>\n")
    index = out / "index.html"
    try:
        index.write_text("\n".join(parts), encoding="utf-8")
    except OSError as exc:
        raise StorageError(f"{index}: cannot write ({exc.strerror or exc})") from None
    return Report(index, tuple(p for _, p in items) + tuple(p for _, p in held), band)


def _peak(session: SessionResult) -> float | None:
    return peak_force(session.measurements[session.fit_index])


__all__ = ["Report", "analysis_band", "cwt_view", "potential_curve", "stiffness_curve", "write_report"]
