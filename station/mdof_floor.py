"""Each channel's prediction floor on the captures ``station validate`` scores (issue 14 item 5).

No model predicts a capture better, on average, than its measurement allows: the acceleration
noise integrated twice through the drift high-pass (:func:`eddi.mdof.validate.noise_floor`) and
the uncertainty of the measured impulse carried through the model
(:func:`eddi.mdof.validate.force_floor`), in quadrature. On a linear or mildly nonlinear structure
the second is negligible; on an energy sink the sink channel's response depends on the blow's
energy at the 1e-4 level (targeted energy transfer), and a light blow's impulse is known to a few
1e-3, so the true model itself misses its own captures by 0.07-0.21 (session 16, the bench's
nes-5-1, where the ideal force gives 0.0004). The floors go into the JSON (``channel_floor`` per
record and their mean) and a channel whose floor is above :data:`FLOOR_WARN` gets a warning: its
nrmse is no evidence for or against the model.

``station diagnose`` also judges every held-out fold per mode against each mode's floor (the
channels' floors carried through the inverse mode shapes, :mod:`eddi.mdof.modefloor`):
:func:`folds_in_modes` on the folds, :func:`modes_judged` the rule, :func:`mode_lines` the report.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

#: A channel whose prediction floor is above this is warned about (the nrmse the issue asks of every
#: channel: above it a channel's figure is set by the measurement, not by the model).
FLOOR_WARN = 0.05


def add_floors(obj: dict[str, Any], model: Any, records: Sequence[Any]) -> None:
    """Put each record's ``channel_floor`` / ``impulse_uncertainty``, and ``channel_floor`` over the
    records (the mean noise and impulse parts in quadrature), into a ``station validate`` object
    (``obj["records"]`` in the order of ``records``); warn."""
    from eddi.mdof.validate import force_floor, impulse_floor, noise_floor

    per = []
    for o, r in zip(obj["records"], records):
        acc, frc = noise_floor(r), force_floor(model, r)
        fl = np.hypot(acc, frc)
        o["channel_floor"] = {c: float(v) for c, v in zip(model.channels, fl)}
        o["impulse_uncertainty"] = impulse_floor(r)
        per.append((acc, frc, o["impulse_uncertainty"]))
    acc = np.mean([p[0] for p in per], axis=0)
    frc = np.mean([p[1] for p in per], axis=0)
    mean = np.hypot(acc, frc)
    obj["channel_floor"] = {c: float(v) for c, v in zip(model.channels, mean)}
    u = [p[2] for p in per]
    known = f"{100 * min(u):.2g}-{100 * max(u):.2g} %" if len(u) > 1 else f"{100 * u[0]:.2g} %"
    for c, fl, a, f in zip(model.channels, mean, acc, frc):
        if np.isfinite(fl) and fl > FLOOR_WARN:
            why = (f"the measured impulses are known to {known} and that moves this channel's prediction by {f:.3g}"
                   if f >= a else f"the acceleration noise through the drift high-pass leaves {a:.3g}")
            obj["warnings"].append(f"channel {c}: even the true equations are expected to miss it by about {fl:.3g} "
                                   f"nrmse on these captures ({why}; noise part {a:.3g}, impulse part {f:.3g}): "
                                   "its nrmse is set by the measurement, not by the model")


def folds_in_modes(fits: Sequence[dict[str, tuple]], records: Sequence[Any]) -> list[Any]:
    """Per held-out fold (``fits[k][kind] = (validation, identification, training)``, capture ``k``
    held out), both models' errors, the coupled model's without its coupling terms and the floor per
    mode in the basis of the fold's tail modes (:func:`eddi.mdof.modefloor.fold_in_modes`); None for a
    fold whose basis does not fit."""
    from eddi.mdof.modefloor import fold_in_modes, without_coupling
    from eddi.mdof.validate import validate_mdof

    out = []
    for k, fit in enumerate(fits):
        modes = fit["coupled"][1].modes
        try:  # the coupled model without its coupling terms, on the same held-out capture
            ablated = validate_mdof(without_coupling(fit["coupled"][1].model), records[k])
        except (ValueError, FloatingPointError, np.linalg.LinAlgError):
            ablated = None
        try:
            out.append(fold_in_modes(modes.shapes, modes.frequencies_hz, records[k], fit["baseline"][0],
                                     fit["coupled"][0], ablated))
        except (ValueError, np.linalg.LinAlgError):
            out.append(None)
    return out


def modes_judged(mode_folds: Sequence[Any], baseline: Sequence[float], coupled: Sequence[float],
                 margin: float) -> Any:
    """:func:`eddi.mdof.modefloor.judge_modes` on the folds where the baseline ran
    (:func:`eddi.mdof.verdict.baseline_ran`) and a basis was found; never earned when the coupled
    model is worse than the baseline over the channels (held-out gain not positive). None: no fold."""
    from dataclasses import replace

    from eddi.mdof.modefloor import judge_modes
    from eddi.mdof.verdict import baseline_ran, held_out_gain

    ran = baseline_ran(baseline)
    kept = [f for k, f in enumerate(mode_folds) if f is not None and ran[k]]
    if len(kept) < 2:
        return None
    judged = judge_modes(kept, margin)
    if judged is not None and judged.earned and not held_out_gain(baseline, coupled) > 0:
        judged = replace(judged, mode=None)
    return judged


def mode_lines(obj: dict[str, Any]) -> list[str]:
    """The printed per-mode table of a ``station diagnose`` object (empty without one)."""
    from eddi.mdof.modefloor import ModeJudgement

    m = obj.get("modes")
    if not m:
        return []
    keys = ("frequencies_hz", "floor", "noise_m", "baseline", "coupled", "excess_gain", "better_folds")
    j = ModeJudgement(*(tuple(m[k]) for k in keys), m["folds"], m["mode"], tuple(m.get("coupling_gain", ())))
    return ["Per mode, held out (the tail's linear modes; nrmse of the modal displacement, floor = the channels' "
            "noise through the inverse mode shapes, noise in m RMS at the shape's largest entry):"] + j.lines()
