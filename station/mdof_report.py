"""``station report`` on multi-channel captures: one panel per channel, measured beside predicted.

The model and the scores are :func:`station.mdof_replay.replay_mdof_object`'s (identified on
every capture but the last, no mass given); the report is a folder with ``index.html`` (the
equations, masses, frequencies, the per-channel nrmse table) and one PNG per capture whose
panels are the channels' displacement over the free window, measured and simulated from
rest by the measured force (:mod:`station.figures` style: Agg, no pyplot).
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import Any

from station.figures import TIME_LABEL, envelope, save


def capture_figure(validation: Any, channels: list[str], title: str):
    """Panels (one per channel) of measured vs simulated displacement [mm]."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8.0, 1.9 * len(channels) + 0.6), layout="constrained")
    axes = fig.subplots(len(channels), 1, squeeze=False, sharex=True)[:, 0]
    for k, (ax, name) in enumerate(zip(axes, channels)):
        t, y = envelope(validation.t, 1e3 * validation.measured[k])
        ax.plot(t, y, color="#1f4e79", lw=0.8, label="measured")
        if not validation.diverged:
            t, y = envelope(validation.t, 1e3 * validation.simulated[k])
            ax.plot(t, y, color="#c0392b", lw=0.8, ls="--", label="model")
        ax.set_ylabel(f"x at {name} [mm]")
        ax.set_title(f"{name}: nrmse {validation.channel_nrmse[name]:.3g}", fontsize=9)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel(TIME_LABEL)
    fig.suptitle(title, fontsize=10)
    return fig


def write_mdof_report(obj: dict[str, Any], out: str | Path) -> list[Path]:
    """Write ``out/index.html`` and one figure per capture; return the figure paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    figures, rows = [], []
    for k, (rec, val) in enumerate(zip(obj["records"], obj["_validations"])):
        fig = capture_figure(val, obj["channels"], f"{rec['source']} ({rec['role']})")
        figures.append(save(fig, out / f"capture-{k}.png"))
        cells = "".join(f"<td>{rec['channel_nrmse'][c]:.4g}</td>" for c in obj["channels"])
        rows.append(f"<tr><td>{html.escape(rec['source'])}</td><td>{html.escape(rec['role'])}</td>{cells}"
                    f"<td>{rec['nrmse']:.4g}</td></tr>")
    head = "".join(f"<th>{html.escape(c)}</th>" for c in obj["channels"])
    imgs = "".join(f'<p><img src="{p.name}" alt="{html.escape(r["source"])}"></p>'
                   for p, r in zip(figures, obj["records"]))
    held = obj["held_out_nrmse"]
    body = (f"<h1>Multi-DOF report</h1><p>Identified on {html.escape(', '.join(obj['fit_records']))} "
            f"({html.escape(obj['coordinates'])} coordinates, driving point {html.escape(obj['driving_point'])}, "
            f"no mass given).</p><p>Masses {', '.join(f'{m:.4g}' for m in obj['masses_kg'])} kg; natural "
            f"frequencies {', '.join(f'{f:.5g}' for f in obj['natural_frequencies_hz'])} Hz.</p>"
            f"<p><code>{html.escape(obj['equation'])}</code></p>"
            f"<table border=1><tr><th>capture</th><th>role</th>{head}<th>mean</th></tr>{''.join(rows)}</table>"
            + (f"<p>Held-out nrmse (displacement, mean over channels): {held:.4g}</p>" if held is not None else
               "<p>A single capture: validated on itself.</p>")
            + imgs)
    (out / "index.html").write_text(f"<!doctype html><meta charset=utf-8><title>Multi-DOF report</title>{body}",
                                    encoding="utf-8")
    return figures
