"""EDDI vs SINDy on the two simulated cases of the paper (Sec. 3.1 Duffing, Sec. 3.2 pendulum).

Run::

    python benchmarks/bench_paper_cases.py            # clean data, as in the paper
    python benchmarks/bench_paper_cases.py --noise 60 # plus white noise at 60 dB SNR on x, v

Exact states come from scipy's DOP853 (rtol 1e-12, atol 1e-14). Both methods get the
same candidate terms (paper Eqs. 18, 20 and the x..x^5 stiffness library). SINDy uses
pysindy's STLSQ with the paper's thresholds (0.05 Duffing, 0.005 pendulum), fitted with
the acceleration given either exactly (from the ODE) or as the finite-difference
derivative of v (np.gradient), which is what a measurement offers, or fed only the state
(x, v) which pysindy differentiates itself (its default FiniteDifference), as the paper
used it. "EDDI auto + refine" adds the optional output-error refinement (eddi/refine.py). Prints a table of
percent errors per coefficient and run times, with the paper's own numbers (Tables 1-4).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.integrate import solve_ivp

from eddi import identify, validate
from eddi.sindy import sindy_identify

DAMPING = "v,v^2,v^3,x^2*v"
STIFFNESS = "x,x^2,x^3,x^4,x^5"


def _solve(rhs, y0, duration_s, rate_hz):
    t = np.arange(int(round(duration_s * rate_hz)) + 1) / rate_hz
    sol = solve_ivp(rhs, (0.0, t[-1]), y0, method="DOP853", rtol=1e-12, atol=1e-14, t_eval=t)
    return t, sol.y[0], sol.y[1], np.array(rhs(0.0, sol.y))[1]


def duffing_case():
    m, b, bnl, k, knl = 0.05, 0.5, 4000.0, 300.0, 3e8  # paper Eq. 17

    def rhs(_t, y):
        x, v = y
        return [v, -(b * v + bnl * x * x * v + k * x + knl * x**3) / m]

    t, x, v, a = _solve(rhs, [0.0, 10.0], 1.0, 1e4)
    exact = {"v": b, "x^2*v": bnl, "x": k, "x^3": knl}
    # paper Tables 1-2: (EDDI error %, SINDy error %)
    paper = {"v": (0.002, 0.5), "x^2*v": (0.05, 1.92), "x": (5.77, 20.3), "x^3": (0.1, 0.42)}
    return "Duffing (paper Sec. 3.1)", t, x, v, a, m, exact, paper, 0.05


def pendulum_case():
    m, l, b, g = 2.0, 0.8, 0.1, 9.81  # paper Eq. 19
    inertia, mgl = m * l * l, m * g * l

    def rhs(_t, y):
        th, w = y
        return [w, -(b * l * l * w + mgl * np.sin(th)) / inertia]

    t, x, v, a = _solve(rhs, [np.pi / 2, 0.0], 100.0, 100.0)
    exact = {"v": b * l * l, "x": mgl, "x^3": -mgl / 6, "x^5": mgl / 120}
    # paper Tables 3-4
    paper = {"v": (0.0094, 0.025), "x": (0.28, 0.032), "x^3": (1.34, 0.42), "x^5": (14.46, 7.83)}
    return "Pendulum (paper Sec. 3.2)", t, x, v, a, inertia, exact, paper, 0.005


def coefficient_errors(eom, exact):
    coefs = {**eom.damping, **eom.stiffness}
    return {name: 100.0 * abs(coefs[name] / val - 1.0) for name, val in exact.items()}


def run_case(case, snr_db, rng):
    title, t, x, v, a, mass, exact, paper, threshold = case
    if snr_db is not None:
        x = x + rng.normal(0, np.std(x) * 10 ** (-snr_db / 20), x.size)
        v = v + rng.normal(0, np.std(v) * 10 ** (-snr_db / 20), v.size)
        title += f", white noise {snr_db:g} dB SNR on x and v"
    rows = []

    def timed(label, fn):
        t0 = time.perf_counter()
        eom = fn()
        dt = time.perf_counter() - t0
        val = validate(eom, t, x, v=v)
        rows.append((label, coefficient_errors(eom, exact), dt, val.nrmse))

    timed("EDDI auto", lambda: _eddi(t, x, v, mass, "auto"))
    timed("EDDI potential", lambda: _eddi(t, x, v, mass, "potential"))
    timed("EDDI lagrangian", lambda: _eddi(t, x, v, mass, "lagrangian"))
    timed("EDDI as paper (Eq.12, cumulative)", lambda: identify(
        t, x, v, mass, damping=DAMPING, stiffness=STIFFNESS, route="lagrangian",
        weighting="paper", anchored=False, noise=None).eom)
    timed("EDDI auto + refine (output error on x)", lambda: identify(
        t, x, v, mass, damping=DAMPING, stiffness=STIFFNESS, refine=True).eom)
    timed("SINDy as paper (pysindy differentiates)", lambda: sindy_identify(
        t, x, v, None, mass, DAMPING, STIFFNESS, threshold))
    timed("SINDy, exact a", lambda: sindy_identify(t, x, v, a, mass, DAMPING, STIFFNESS, threshold))
    timed("SINDy, a = gradient(v)", lambda: sindy_identify(
        t, x, v, np.gradient(v, t), mass, DAMPING, STIFFNESS, threshold))

    names = list(exact)
    print(f"\n{title}")
    header = f"{'method':40s}" + "".join(f"{n + ' err %':>14s}" for n in names) + f"{'time s':>9s}{'nrmse':>11s}"
    print(header)
    print("-" * len(header))
    for label, errs, dt, nrmse in rows:
        print(f"{label:40s}" + "".join(f"{errs[n]:14.3g}" for n in names) + f"{dt:9.3f}{nrmse:11.2e}")
    print(f"{'paper EDDI (Tables 1-4)':40s}" + "".join(f"{paper[n][0]:14.3g}" for n in names))
    print(f"{'paper SINDy (Tables 1-4)':40s}" + "".join(f"{paper[n][1]:14.3g}" for n in names))


def _eddi(t, x, v, mass, route):
    return identify(t, x, v, mass, damping=DAMPING, stiffness=STIFFNESS, route=route).eom


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--noise", type=float, default=None, metavar="SNR_DB",
                        help="also add white noise at this SNR (dB, over the whole record)")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    identify(*duffing_case()[1:4], 0.05)  # warm the compiled simulator
    for case in (duffing_case(), pendulum_case()):
        run_case(case, None, rng)
        if args.noise is not None:
            run_case(case, args.noise, rng)


if __name__ == "__main__":
    main()
