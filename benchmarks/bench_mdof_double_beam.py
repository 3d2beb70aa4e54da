"""Coupled two-mode model vs the modal sum on the measured resonant double beam (leave one out).

The data (``../shared/data/resonant-double-beam``, nine velocity ring-downs, one channel, no
force; see ``docs/real-data.md``) carry two modes (122 and 244 Hz, near 1:2). Today's model
is a sum of two uncoupled EDDI modes (:func:`eddi.multimode.identify_modes`, 0.83 % NMTE
leave-one-out). Here, per fold, the coupled model keeps every mode's own terms and adds
coupling forces derived from a potential ``V_c = sum_P theta_P P(x1, x2)`` (``P`` among
``x1^2 x2, x1 x2^2, x1^3 x2, x1^2 x2^2, x1 x2^3``: the 1:2-resonant quadratic ones first),
whose ``theta`` are identified from the **energy exchanged between the modes**: for each
mode and half cycle between zero crossings of ``x_k`` (where its own potential is zero) the
measured change of ``T_k`` minus what its own damping dissipates is regressed on
``int v_k dP/dx_k dt`` (EDDI phase one with coupling columns, both modes' rows stacked,
shared ``theta``: one potential). The coupled model is an :class:`eddi.mdof.model.MdofModel`
(modal coordinates, the velocity is ``v1 + v2``) simulated by :func:`eddi.mdof.simulate.simulate_mdof`
from the modal sum's initial-state estimate. Printed: NMTE and NRMSE of both, fold by fold,
and the identified ``theta`` with their share of the modes' energy budget.

    PYTHONPATH=. python benchmarks/bench_mdof_double_beam.py [--data DIR]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from eddi.energy import cumulative_energy, rate_interpolant, zero_crossings
from eddi.mdof.model import MdofModel
from eddi.mdof.simulate import simulate_mdof
from eddi.mdof.terms import parse_multi_term
from eddi.multimode import estimate_initial_states, identify_modes, separate_modes, trajectory_errors

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_double_beam import DEFAULT_DATA, TWO, load_records  # noqa: E402

#: Potential monomials P(x1, x2) and their gradients (eq 1, eq 2).
POTENTIALS = {
    "x1^2*x2": ("2*x1*x2", "x1^2"),
    "x1*x2^2": ("x2^2", "2*x1*x2"),
    "x1^3*x2": ("3*x1^2*x2", "x1^3"),
    "x1^2*x2^2": ("2*x1*x2^2", "2*x1^2*x2"),
    "x1*x2^3": ("x2^3", "3*x1*x2^2"),
}


def _grad_term(text: str) -> tuple[float, str]:
    head, _, rest = text.partition("*")
    if head.isdigit():
        return float(head), rest
    return 1.0, text


def own_terms(eom, k: int) -> tuple[dict[str, float], dict[str, float]]:
    """A single-coordinate equation's terms renamed to coordinate ``k + 1``."""
    def rename(t: str) -> str:
        return t.replace("x", f"x{k + 1}").replace("v", f"v{k + 1}")
    return ({rename(t): c for t, c in eom.damping.items()}, {rename(t): c for t, c in eom.stiffness.items()})


def coupling_theta(model, recs, trim_s: float = 0.05, stop_s: float = 1.5) -> tuple[dict[str, float], dict[str, float]]:
    """``theta_P`` from the energy exchanged (module docstring); also each mode's exchange share."""
    rows, rhs = [], []
    share = {}
    for t, v in recs:
        c = separate_modes(t, v, model.bands_hz, filter_order=model.filter_order)
        dt = t[1] - t[0]
        sl = slice(int(trim_s / dt), min(t.size - int(trim_s / dt), int(stop_s / dt)))
        tt = t[sl]
        x, vv, aa = c.x[:, sl], c.v[:, sl], c.a[:, sl]
        for k in (0, 1):
            eom = model.modes[k]
            gamma = zero_crossings(tt, x[k], vv[k])
            if gamma.size < 4:
                continue
            kin = 0.5 * rate_interpolant(tt, vv[k], aa[k])(gamma) ** 2
            own_power = vv[k] * sum(cf * parse_multi_term(tx, 1)(x[k:k + 1], vv[k:k + 1])
                                    for tx, cf in eom.damping.items())
            own = np.diff(cumulative_energy(tt, own_power)(gamma))
            cols = []
            for p in POTENTIALS.values():
                fac, g = _grad_term(p[k])
                cols.append(vv[k] * fac * parse_multi_term(g, 2)(x, vv))
            ex = np.diff(cumulative_energy(tt, np.column_stack(cols))(gamma), axis=0)
            w = 1.0 / kin[:-1]
            rows.append(ex * w[:, None])
            rhs.append((-np.diff(kin) - own) * w)
            share.setdefault(f"mode{k + 1}", []).append(float(np.sum(np.abs(-np.diff(kin) - own)) / np.sum(np.abs(own))))
    a, b = np.vstack(rows), np.concatenate(rhs)
    norms = np.linalg.norm(a, axis=0)
    theta = np.linalg.lstsq(a / norms, b, rcond=None)[0] / norms
    return dict(zip(POTENTIALS, theta)), {k: float(np.median(v)) for k, v in share.items()}


def coupling_theta_subset(model, recs, names: tuple[str, ...]) -> float:
    """``theta`` of one potential alone (the others fixed at zero)."""
    global POTENTIALS
    saved = POTENTIALS
    try:
        POTENTIALS = {k: v for k, v in saved.items() if k in names}
        theta, _ = coupling_theta(model, recs)
    finally:
        POTENTIALS = saved
    return float(theta[names[0]])


def coupled_model(model, theta: dict[str, float]) -> MdofModel:
    damping, stiffness = [], []
    for k in (0, 1):
        d, s = own_terms(model.modes[k], k)
        for p, th in theta.items():
            fac, g = _grad_term(POTENTIALS[p][k])
            g = parse_multi_term(g, 2).text
            s[g] = s.get(g, 0.0) + fac * th
        damping.append(d)
        stiffness.append(s)
    return MdofModel.create(coordinates="modal", mass=(1.0, 1.0), input=(0.0, 0.0), damping=tuple(damping),
                            stiffness=tuple(stiffness), channels=("vel",), shapes=((1.0, 1.0),),
                            driving_point="vel", notes="double beam: modal sum + coupling from energy exchange")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--window-ms", type=float, default=20.0)
    args = ap.parse_args()
    names, recs = load_records(args.data)
    if not recs:
        print(f"no ringdown-*.csv in {args.data}", file=sys.stderr)
        return 2
    rows = []
    from eddi.multimode import simulate_modal

    def predict(model, theta, t, v, init):
        if not theta:
            return simulate_modal(model, t, init).v
        sim = simulate_mdof(coupled_model(model, theta), t, x0=init[:, 0], v0=init[:, 1],
                            x_scale=np.abs(init[:, 1]) / (2 * np.pi * 122))
        return sim.v.sum(axis=0)

    for i, name in enumerate(names):
        train = [r for j, r in enumerate(recs) if j != i]
        model, _ = identify_modes(train, TWO, damping=("v", "abs(v)*v"), stiffness=("x", "abs(x)*x"),
                                  initial_window_s=args.window_ms / 1000)
        theta_all, share = coupling_theta(model, train)
        resonant = {"x1^2*x2": coupling_theta_subset(model, train, ("x1^2*x2",))}
        candidates = {"none": {}, "x1^2*x2 (1:2 resonant)": resonant, "all five": theta_all}
        inits = [estimate_initial_states(model, tt, vv, args.window_ms / 1000) for tt, vv in train]
        train_err = {k: float(np.mean([trajectory_errors(predict(model, th, tt, vv, ini), vv).nmte
                                       for (tt, vv), ini in zip(train, inits)])) for k, th in candidates.items()}
        pick = min(train_err, key=train_err.get)
        t, v = recs[i]
        init = estimate_initial_states(model, t, v, args.window_ms / 1000)
        e_sum = trajectory_errors(predict(model, {}, t, v, init), v)
        e_cpl = trajectory_errors(predict(model, candidates[pick], t, v, init), v)
        e_all = trajectory_errors(predict(model, theta_all, t, v, init), v)
        rows.append((name, e_sum, e_cpl, e_all))
        print(f"{name}: modal sum NMTE {100 * e_sum.nmte:.3f} % | coupled (chosen on training: {pick}) NMTE "
              f"{100 * e_cpl.nmte:.3f} % | all five couplings NMTE {100 * e_all.nmte:.3f} % | training NMTE "
              + ", ".join(f"{k} {100 * e:.3f} %" for k, e in train_err.items())
              + f" | theta x1^2*x2 {resonant['x1^2*x2']:.3g} | (energy drop - own dissipation)/own {share}")
        sys.stdout.flush()
    ma = np.mean([r[3].nmte for r in rows])
    print(f"all five couplings always: leave-one-out mean NMTE {100 * ma:.3f} %")
    ms = np.mean([r[1].nmte for r in rows])
    mc = np.mean([r[2].nmte for r in rows])
    print(f"leave-one-out mean NMTE: modal sum {100 * ms:.3f} %, coupled {100 * mc:.3f} % "
          f"({'at least as good' if mc <= ms * 1.0001 else 'WORSE'}); NRMSE {np.mean([r[1].nrmse for r in rows]):.4f} "
          f"vs {np.mean([r[2].nrmse for r in rows]):.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
