"""EDDI vs SINDy on the acceleration-only chain, and conditioning vs the paper's high-pass.

For each system of ``tests/eddi/impact_cases.py`` and SNR 60, 45, 30 dB (force and
accelerometer, 24-bit), the record is conditioned once (``eddi.conditioning.condition``)
and both methods get the same signals over the same free-response window and the same
candidate terms; SINDy's STLSQ threshold is the paper's 0.05 (Sec. 3.3.1). Printed: the
mean absolute relative coefficient error of each method, their run times, and the
displacement error of the conditioning vs the paper's integrate + 3rd-order Butterworth
high-pass at 2 Hz.

Run: ``python benchmarks/bench_accel_chain.py``
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from eddi.conditioning import condition, integrate_highpass  # noqa: E402
from eddi.pipeline import identify_measurement  # noqa: E402
from eddi.sindy import sindy_identify  # noqa: E402
from tests.eddi.impact_cases import SYSTEMS, impact_record  # noqa: E402


def _coef_err(eom, truth: dict) -> float:
    errs = []
    for group in ("damping", "stiffness"):
        for term, c in truth[group].items():
            errs.append(abs(getattr(eom, group)[term] / c - 1))
    return float(np.mean(errs))


def main() -> None:
    print(f"{'system':12s} {'SNR':>4s} | {'EDDI err':>9s} {'SINDy err':>9s} {'ratio':>6s} | "
          f"{'EDDI s':>6s} {'SINDy s':>7s} | {'x err ours':>10s} {'x err HP2':>9s} | nrmse")
    ratios = []
    for snr in (60.0, 45.0, 30.0):
        for name, spec in SYSTEMS.items():
            r = impact_record(name, snr_db=snr, seed=1)
            cond = condition(r.t, acc=r.acc, force=r.force)
            d, k = tuple(spec["damping"]), tuple(spec["stiffness"])
            t0 = time.perf_counter()
            res = identify_measurement(cond, spec["mass"], damping=d, stiffness=k)
            t_eddi = time.perf_counter() - t0
            w0, w1 = cond.window
            t0 = time.perf_counter()
            s_eom = sindy_identify(cond.t[w0:w1], cond.x[w0:w1], cond.v[w0:w1], cond.a[w0:w1],
                                   spec["mass"], damping=d, stiffness=k, threshold=0.05)
            t_sindy = time.perf_counter() - t0
            e_eddi, e_sindy = _coef_err(res.model.eom, spec), _coef_err(s_eom, spec)
            ratios.append(e_eddi / e_sindy if e_sindy > 0 else np.inf)
            xh, _ = integrate_highpass(r.t, r.acc, 2.0)
            xe = np.linalg.norm(cond.x[w0:w1] - r.x[w0:w1]) / np.linalg.norm(r.x[w0:w1])
            xh_e = np.linalg.norm(xh[w0:w1] - r.x[w0:w1]) / np.linalg.norm(r.x[w0:w1])
            print(f"{name:12s} {snr:4.0f} | {100 * e_eddi:8.2f}% {100 * e_sindy:8.2f}% {ratios[-1]:6.2f} | "
                  f"{t_eddi:6.2f} {t_sindy:7.2f} | {100 * xe:9.2f}% {100 * xh_e:8.2f}% | "
                  f"{res.validation.nrmse:.4f}")
    print(f"EDDI error / SINDy error: median {np.median(ratios):.3f}, worst {np.max(ratios):.3f} (goal <= 0.5)")


if __name__ == "__main__":
    main()
