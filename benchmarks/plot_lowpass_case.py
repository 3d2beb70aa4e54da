"""Figures of the ``sensor_lowpass`` correction on one of my tuning cases (docs/diagnosis.md,
"Session 15"): 0.042 kg, 26.3 Hz at 5 kHz, a 0.66 ms blow behind a 4th-order Butterworth at
643 Hz (the case of tests/eddi/test_diagnose_lowpass.py).

    python benchmarks/plot_lowpass_case.py --out docs/diagnosis-lowpass
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from eddi.calculus import delay  # noqa: E402
from eddi.diagnosis import diagnose  # noqa: E402
from eddi.diagnosis.chain import measured_frequency  # noqa: E402
from eddi.diagnosis.lag import blow_window  # noqa: E402
from eddi.diagnosis.lowpass import filter_ba, fit_lowpass  # noqa: E402
from tests.eddi.test_diagnose_lag_correction import _set  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy.signal import butter, lfilter

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="docs/diagnosis-lowpass")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rate = 5000.0
    recs = _set(0.042, 26.3, rate, chain=lambda a: lfilter(*butter(4, 643.0 / (rate / 2)), a), pulse_s=0.00066,
                zeta=0.025)
    f1 = measured_frequency(recs)
    fit = fit_lowpass(recs, f1)
    force, acc, _w, _r = blow_window(recs[0], f1)
    b, a = filter_ba(fit.kind, fit.order, fit.corner_hz, rate)
    n = np.arange(force.size) / rate * 1e3
    lp, dl = lfilter(b, a, force), delay(force, fit.delay_samples)
    fig, ax = plt.subplots(figsize=(7, 3.6))
    ax.plot(n, acc, "k.-", label="corrected acceleration a + w1^2 x (measured)")
    ax.plot(n, force / 0.042, "C7--", label="force / m (as measured)")
    ax.plot(n, dl * np.dot(dl, acc) / np.dot(dl, dl), "C1", label=f"force delayed {fit.delay_samples:.1f} samples")
    ax.plot(n, lp * np.dot(lp, acc) / np.dot(lp, lp), "C0",
            label=f"force through {fit.kind} order {fit.order}, {fit.corner_hz:.0f} Hz (fitted)")
    ax.set_xlabel("time in the blow's window [ms]")
    ax.set_ylabel("acceleration [m/s^2]")
    ax.set_title("Over the blow: a delay cannot round the pulse, the fitted low-pass does", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "blow.png", dpi=110)
    d = diagnose(recs, 0.042, damping="v", stiffness="x")
    h = d.held_out[0]
    names = {c.name: c for c in d.candidates}
    fig, ax = plt.subplots(figsize=(7, 3.6))
    k = slice(0, min(h.t.size, int(0.25 * rate)))
    t = (h.t[k] - h.t[0]) * 1e3
    ax.plot(t, h.x_measured[k] * 1e3, "k", lw=2, label="measured")
    ax.plot(t, h.x_baseline[k] * 1e3, "C3", label=f"baseline (held-out {d.baseline.nrmse:.3f})")
    ax.plot(t, h.x_extended[k] * 1e3, "C0--",
            label=f"{d.cause}: force through the fitted low-pass ({names['sensor_lowpass'].nrmse:.3f})")
    ax.set_xlabel("time from the held-out part's start [ms]")
    ax.set_ylabel("displacement [mm]")
    ax.set_title(f"Held-out part 1 (the alignment alone: {names['response_lag'].nrmse:.3f}; floor "
                 f"{d.noise_floor.data_nrmse:.3f})", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "heldout.png", dpi=110)
    print(f"wrote {out / 'blow.png'} and {out / 'heldout.png'}; cause {d.cause}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
