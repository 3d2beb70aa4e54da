"""The dense-grid simulation against every sample: its error bound and its cost (issue 13).

    python benchmarks/bench_dense_simulation.py [--repeats 3] [--masses 0.005,0.8,500]

:func:`eddi.simulate.simulate_dense` (what the pipeline's validation and, since session 9,
``station diagnose``'s held-out parts use on finely sampled records) integrates every sample
while the force acts, then RK4 steps of ``omega h <= 0.05`` on a grid of ``omega q dt <= 0.2``
(``omega``: the model's largest local angular frequency over the response's amplitudes, its
stiffening at the peak included) and interpolates back by cubic Hermite. This script measures,
on systems of its own, how far that is from :func:`eddi.simulate.simulate` on every sample:

* masses (``--masses``) x sample rates 2 / 10 / 40 kHz x natural frequencies 5 / 20 / 60 Hz x
  springs: hardening (tangent stiffness +300 % at the peak), softening (-75 %), linear; 2 %
  viscous damping plus cubic damping; a 1 ms half-sine blow from rest;
* per system: the largest difference of ``x`` and ``v`` (relative to their peaks), the
  every-sample simulation's own step-doubling error (the same run at twice the RK4 steps), and
  the CPU of the dense simulation as a ratio to the every-sample one (the peer measured in the
  same run, best of ``--repeats``).

Prints one line per system and the summary: the largest errors, against the noise of a 30-60
dB sensor (1e-3-3e-2 of the peak). A record whose grid would hold fewer than 4 samples is
simulated on every sample by ``simulate_dense`` itself (error 0, ratio ~1 plus the check).
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import time

import numpy as np


def _system(mass: float, f0: float, kind: str):
    from eddi.model import EquationOfMotion

    w0 = 2 * math.pi * f0
    k = mass * w0 ** 2
    c = 2 * 0.02 * mass * w0
    x_pk = 0.01 if mass < 1 else 0.002
    k3 = {"hard": 1.0, "soft": -0.25, "lin": 0.0}[kind] * k / x_pk ** 2
    stiffness = {"x": k} | ({"x^3": k3} if k3 else {})
    return EquationOfMotion.create(mass=mass, damping={"v": c, "x^2*v": 0.5 * c / x_pk ** 2},
                                   stiffness=stiffness), x_pk, w0


def _blow(n: int, fs: float, impulse: float, tau: float = 1e-3) -> np.ndarray:
    tt = (np.arange(n) - int(0.05 * fs)) / fs
    on = (tt >= 0) & (tt <= tau)
    f = np.zeros(n)
    f[on] = impulse * math.pi / (2 * tau) * np.sin(math.pi * tt[on] / tau)
    return f


def _best_cpu(fn, repeats: int) -> float:
    best = math.inf
    for _ in range(repeats):
        c0 = time.process_time()
        fn()
        best = min(best, time.process_time() - c0)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--repeats", type=int, default=3, help="timed runs per simulation; the best is kept (default 3)")
    ap.add_argument("--masses", default="0.005,0.8,500", help="masses [kg] (default: %(default)s)")
    args = ap.parse_args()
    from eddi.simulate import local_angular_frequency, simulate, simulate_dense

    masses = [float(m) for m in args.masses.split(",")]
    print(f"load average {os.getloadavg()[0]:.1f}; CPU ratios are same-run, best of {args.repeats}")
    errs = []
    for m, fs, f0, kind in itertools.product(masses, (2000.0, 10000.0, 40000.0), (5.0, 20.0, 60.0),
                                             ("hard", "soft", "lin")):
        eom, x_pk, w0 = _system(m, f0, kind)
        n = int(round(min(4.0, 60 / f0) * fs))
        t = np.arange(n) / fs
        f = _blow(n, fs, m * x_pk * w0 * 0.9)
        probe = simulate(eom, t, force=f)
        xs, vs = float(np.max(np.abs(probe.x))), float(np.max(np.abs(probe.v)))
        full = simulate(eom, t, force=f, x_scale=xs, v_scale=vs)
        double = simulate(eom, t, force=f, substeps=2 * full.substeps)
        dense = simulate_dense(eom, t, force=f, x_scale=xs, v_scale=vs)
        ex = float(np.max(np.abs(dense.x - full.x))) / xs
        ev = float(np.max(np.abs(dense.v - full.v))) / vs
        sd = float(np.max(np.abs(double.x - full.x))) / xs
        cf = _best_cpu(lambda: simulate(eom, t, force=f, x_scale=xs, v_scale=vs), args.repeats)
        cd = _best_cpu(lambda: simulate_dense(eom, t, force=f, x_scale=xs, v_scale=vs), args.repeats)
        wdt = local_angular_frequency(eom, xs, vs) / fs
        errs.append((ex, ev, sd, cd / cf))
        print(f"m {m:7.3f} kg  {fs / 1000:4.0f} kHz  {f0:3.0f} Hz  {kind:4s}  omega dt {wdt:.4f}  "
              f"dense - every sample: x {ex:.1e} v {ev:.1e}; every sample at 2x steps: {sd:.1e}; "
              f"CPU dense / every sample {cd / cf:.2f}", flush=True)
    a = np.array(errs)
    print(f"{len(errs)} systems: largest dense - every-sample difference x {a[:, 0].max():.2e}, v {a[:, 1].max():.2e} "
          f"of the peak (every sample's own step-doubling error up to {a[:, 2].max():.2e}); a 30-60 dB sensor's noise "
          f"is 1e-3-3e-2 of the peak: {1e-3 / max(a[:, 0].max(), a[:, 1].max(), 1e-300):.0f}x or more above it. "
          f"CPU dense / every sample: median {np.median(a[:, 3]):.2f}, range {a[:, 3].min():.2f}-{a[:, 3].max():.2f}")


if __name__ == "__main__":
    main()
