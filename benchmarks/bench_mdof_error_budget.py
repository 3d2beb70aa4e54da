"""Where the multi-DOF coefficient error comes from: one ladder, one cause switched on per rung.

For a rig system (``simulated_rig/mdof/*.toml``, three impacts identify, a fourth at 70 % of
the largest is held out) the same identification (:func:`eddi.mdof.identify.identify_mdof`)
runs on

1. ``exact``: the simulated truth ``x, v, a`` and force (no sensor, no conditioning);
2. ``exact + drift filter``: the truth passed through the conditioning's zero-phase drift
   high-pass (``x`` twice, ``v`` once, at the cut-off the conditioning chose), then the
   quasi-static restoration of the identification;
3. ``noise-free acc``: quantised accelerations through the full conditioning (integration,
   high-pass, windows);
4. ``45 dB acc``: the benchmark's records (also what ``bench_mdof.py`` uses);
5. ``45 dB acc, polished``: rung 4's model polished on its training records
   (:func:`eddi.mdof.refine.refine_identified`, what ``station diagnose --refine`` delivers).

Printed per rung: coordinates chosen, tail modes, held-out nrmse per channel (the true model's
beside it), masses, and the cubic/coupling coefficients per unit mass against the truth
written in the same coordinates (``bench_mdof.coupling_errors``). The rung at which the error
appears is its cause.

    PYTHONPATH=. python benchmarks/bench_mdof_error_budget.py [--system two-mass-cubic]
    PYTHONPATH=. python benchmarks/bench_mdof_error_budget.py --chain h-two-cubic-2k [--seed 100]

``--chain`` takes a three-mass case of ``bench_mdof_chain.py`` (session 11); per rung the natural
frequencies of the model's linearisation are also printed against the truth's.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_mdof import _measurement, coupling_errors  # noqa: E402

from eddi.mdof.identify import identify_mdof  # noqa: E402
from eddi.mdof.signals import highpass  # noqa: E402
from eddi.mdof.validate import validate_mdof  # noqa: E402
from simulated_rig.hammer import HammerSpec, hammer_force  # noqa: E402
from simulated_rig.mdof_systems import load_mdof_system, mdof_impact_test  # noqa: E402
from station.mdof_data import condition_multichannel  # noqa: E402


def rungs(name: str, chain: str = "", seed: int = 100) -> tuple[object, dict[str, list]]:
    """The system's truth and the four rungs' records (train first three, held out last)."""
    if chain:
        from bench_mdof_chain import SETS, chain_system

        system = chain_system(chain, {k: v for t in SETS.values() for k, v in t.items()}[chain])
    else:
        system = load_mdof_system(name)
    peaks = list(system.impacts_n) + [0.7 * max(system.impacts_n)]
    raw = {snr: [mdof_impact_test(system, p, seed=seed + k, snr_db=snr) for k, p in enumerate(peaks)]
           for snr in (None, 45.0)}
    cond = {snr: [condition_multichannel(_measurement(r)) for r in rs] for snr, rs in raw.items()}

    def exact(r, c, filtered: bool):
        f = hammer_force(r.t, r.peak_force_n, HammerSpec(tip=system.tip))
        x, v = r.truth_x, r.truth_v
        if filtered:
            x, v = highpass(x, r.rate_hz, c.highpass_hz, 2), highpass(v, r.rate_hz, c.highpass_hz, 1)
        return replace(c, x=x, v=v, a=r.truth_a, force=f, highpass_hz=c.highpass_hz if filtered else 1e-3)

    return system.model(), {
        "exact": [exact(r, c, False) for r, c in zip(raw[None], cond[None])],
        "exact + drift filter": [exact(r, c, True) for r, c in zip(raw[None], cond[None])],
        "noise-free acc": cond[None],
        "45 dB acc": cond[45.0],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--system", default="two-mass-cubic", help="a built-in MDOF system or a system file")
    ap.add_argument("--chain", default="", help="a case of bench_mdof_chain.py instead of --system")
    ap.add_argument("--seed", type=int, default=100, help="noise seed of the first record (then +1, ...)")
    ap.add_argument("--rungs", default="", help="comma-separated rung labels to run (default all)")
    args = ap.parse_args()
    truth, ladder = rungs(args.system, args.chain, args.seed)
    if args.rungs:
        ladder = {k: v for k, v in ladder.items() if k in args.rungs.split(",")}
    true_f = truth.natural_frequencies_hz()
    for label, recs in ladder.items():
        ident = identify_mdof(recs[:3], truth.channels, truth.driving_point,
                              highpass_hz=None if label == "exact" else 2.0)
        models = [(label, ident.model)]
        if label == "45 dB acc":
            from eddi.mdof.refine import refine_identified

            models.append(("45 dB acc, polished", refine_identified(ident, recs[:3])[0]))
        for name, model in models:
            held, floor = validate_mdof(model, recs[3]), validate_mdof(truth, recs[3])
            freq = model.natural_frequencies_hz()
            print(f"== {name}: {ident.coordinates} coordinates, tail modes "
                  f"{', '.join(f'{f:.4g}' for f in ident.modes.frequencies_hz[:4])} Hz; held-out nrmse "
                  + ", ".join(f"{c} {held.channel_nrmse[c]:.4f} (true model {floor.channel_nrmse[c]:.4f})"
                              for c in truth.channels)
                  + f"; masses {', '.join(f'{m:.4g}' for m in model.mass)} kg (true "
                  + f"{', '.join(f'{m:.4g}' for m in truth.mass)}); natural frequencies "
                  + ", ".join(f"{a:.4g} ({100 * (a / b - 1):+.2f} %)" for a, b in zip(freq, true_f)) + " Hz")
            print(f"    kept: {next((n for n in ident.notes if 'kept' in n), '')[:160]}")
            for line in coupling_errors(truth, model, recs[:3]):
                print(line)


if __name__ == "__main__":
    main()
