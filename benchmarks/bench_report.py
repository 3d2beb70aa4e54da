"""Report generation time for 45 s captures (target: under 5 s; paper Sec. 3.3.1 records 45 s).

Run: python benchmarks/bench_report.py [REPEATS]. Records two impacts (600 N and 1110 N,
paper Fig. 12 levels) of 1 s pre-trigger + 44 s from ``sim://duffing-smooth`` through the pty
and the serial driver, then times, separately: reading + identification + validation
(:func:`station.session.run_session`) and the report itself (:func:`station.report.write_report`:
6 identification figures, 1 validation figure with two CWT maps, the HTML page). Prints one
line per stage and repeat, then the best report time.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

DEVICE = "sim://duffing-smooth"


def main(repeats: int = 3) -> None:
    from station.capture import ImpactPlan, acquire, configure_device, device_metadata
    from station.config import parse_config
    from station.devices import open_device
    from station.report import write_report
    from station.session import read_all, run_session
    from station.storage import CaptureWriter

    cfg = parse_config({"device": {"url": DEVICE},
                        "trigger": {"level_n": 50.0, "pretrigger_s": 1.0, "record_s": 44.0, "holdoff_s": 5.0},
                        "specimen": {"mass_kg": 0.815}})  # paper Sec. 3.3.1: 0.815 kg
    with tempfile.TemporaryDirectory() as d:
        h5 = Path(d) / "session.h5"
        t0 = time.perf_counter()
        with open_device(DEVICE) as daq:
            configure_device(daq, cfg)
            res = acquire(daq, cfg, CaptureWriter(h5), 2, impacts=ImpactPlan((600.0, 1110.0) * 3, (False,) * 6),
                          idle_timeout_s=10.0, device_meta=device_metadata(daq, DEVICE))
        print(f"acquire 2 x 45 s captures: {time.perf_counter() - t0:.2f} s ({res.captures} saved)")
        best = float("inf")
        for i in range(repeats):
            t1 = time.perf_counter()
            session = run_session(read_all([str(h5)]), fit_index=0)
            t2 = time.perf_counter()
            rep = write_report(session, Path(d) / f"report{i}")
            t3 = time.perf_counter()
            best = min(best, t3 - t2)
            n = session.measurements[0].t.size
            print(f"repeat {i}: read+identify+validate {t2 - t1:.2f} s; report {t3 - t2:.2f} s "
                  f"({len(rep.figures)} figures, {n} samples per capture, k1 {session.fit.model.eom.stiffness['x']:.1f})")
        print(f"report generation, best of {repeats}: {best:.2f} s (target < 5 s)")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("repeats", nargs="?", type=int, default=3, help="report repeats (default: %(default)s)")
    main(ap.parse_args().repeats)
