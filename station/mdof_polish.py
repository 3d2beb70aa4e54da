"""The output-error polish of a multi-channel diagnosis's held-out folds: which folds are polished
(where the verdict or a printed channel figure needs it), the polish of one fold, and the text tag
that says which kind's figures are of polished models (split from :mod:`station.mdof_commands`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from eddi.errors import IdentificationError
from eddi.mdof.validate import validate_mdof

#: A fold whose model misses its held-out capture by more than this (nrmse) is not polished: the
#: output-error polish is a local least squares from the EDDI model, and a simulation this far
#: from the record (as far as silence is) has slipped phase by cycles, where the cost has other
#: minima; on the three-mass chain the polish took such baseline folds from 154 to 144 and from 44
#: to 42 (the verdict the same) for ~8 s CPU. Same rule for both kinds (fair comparison).
POLISH_MAX_NRMSE = 1.0


#: Coupled folds are polished, whatever the verdict, when an unpolished channel figure (mean over
#: the folds) is above this: the issue's held-out target per channel (#14). Below it the
#: unpolished figures are printed as what they are, upper bounds of the delivered (polished) kind.
CHANNEL_CLAIM_NRMSE = 0.05


def polish_folds(fits: list[dict[str, tuple]], records: Sequence[Any], names: tuple[str, ...],
                  margin: float, mapper: Callable | None = None) -> dict[str, list[int]]:
    """Polish the coupled folds, and the baseline folds where it can change the verdict (in place in
    ``fits``); the indices polished.

    A polished baseline fold is kept when it predicts its held-out capture better than the
    unpolished one (as the variants of a fold are chosen), so a polish only lowers its error; a
    polished coupled fold is kept whenever its simulation stays finite (its figure is the delivered
    kind's). Then:

    - baseline folds are polished (their lower errors can take the gain under the margin), except
      those above :data:`POLISH_MAX_NRMSE`, and none when the gain (per fold,
      :func:`eddi.mdof.verdict.held_out_gain`) stays above the margin even with every fold the
      polish may touch at the noise floor (what the true model reaches; the per-fold gain makes 0
      no bound): a polish that stops at the floor cannot change the verdict (the floor is a
      typical value, not a strict bound: a fold polished well below it could, which is the
      accepted risk of skipping); session 11: the 10 kHz three-mass chain,
      baseline folds 1.19 / 1.18 / 0.69 / 1.13 against coupled 0.02, polished its 0.69 fold for
      19 s of its 115 s CPU and the verdict stayed ``modal_coupling`` at gain 0.98);
    - coupled folds are polished (those under :data:`POLISH_MAX_NRMSE`) unless the coupling
      already wins by the margin and every channel's unpolished figure is within
      :data:`CHANNEL_CLAIM_NRMSE`: with the polish on, the coupled model the station delivers is
      polished, so an unpolished coupled figure is an upper bound of it (said so in the text).
      Session 11 skipped the polish wherever it could not change the verdict: the own chain
      ``t-two-cubic-2k`` then printed 0.060 / 0.061 on two channels (3x their floors) while the
      polished folds and the delivered model were at 0.02-0.03; polishing always (s12mfit) cost the
      10 kHz three-mass chain +52 % CPU (77 -> 117 s) to print 0.0070 where the bound said 0.020
      (session 12, ``bench_mdof_chain.py``).
    - coupled folds left unpolished because they won are polished after all when the baseline's
      polish takes the win under the margin (session 14: a two-mass chain with a 24 % quadratic
      spring, 33 dB, 0.8-2.7 N blows: coupled folds 0.032 / 0.030 / 0.026 unpolished won at gain
      66 %, the baseline's polish took it to 0.029 / 0.028 / 0.048 and the verdict read ``none``
      at 14 %, polished baseline against unpolished coupled).
    The baseline folds left unpolished (the kind not delivered) are upper bounds; the JSON's
    ``polished_folds`` and the text say which kind was polished.
    """
    from eddi.mdof.verdict import channel_floor, held_out_gain

    done: dict[str, list[int]] = {"baseline": [], "coupled": []}
    mapper = mapper if mapper is not None else (lambda fn, items: [fn(x) for x in items])

    def eligible(kind: str) -> list[int]:
        return [k for k, fit in enumerate(fits)
                if math.isfinite(fit[kind][0].nrmse) and fit[kind][0].nrmse <= POLISH_MAX_NRMSE]

    def polish(kind: str) -> None:
        todo = eligible(kind)
        # independent folds: ``mapper`` may run them in forked workers (each returns its validation)
        got = mapper(lambda k: polished_fold(fits[k][kind][1], fits[k][kind][2], records[k], fits[k][kind][0]),
                     todo)
        for k, p in zip(todo, got):
            v, ident, train = fits[k][kind]
            # the coupled figure is the polished model's (the kind delivered), even where the
            # unpolished one happened to predict the held-out capture better; a baseline fold keeps
            # the lower (the comparison made harder for the coupling, never easier)
            if p.nrmse < v.nrmse or (kind == "coupled" and p is not v and math.isfinite(p.nrmse)):
                fits[k][kind] = (p, ident, train)
            done[kind].append(k)

    baseline_now = [f["baseline"][0].nrmse for f in fits]
    coupled_now = [f["coupled"][0].nrmse for f in fits]
    channels_now = [float(np.mean([f["coupled"][0].channel_nrmse[c] for f in fits])) for c in names]
    if not (held_out_gain(baseline_now, coupled_now) > margin
            and all(math.isfinite(v) and v <= CHANNEL_CLAIM_NRMSE for v in channels_now)):
        polish("coupled")  # first: the baseline's polish is then judged against the coupled figures printed
    floors = channel_floor(records, names)
    touched = set(eligible("baseline"))
    # the best a polish could do: a fold it touches down to the noise floor (mean over channels)
    reach = float(np.mean([floors[c] for c in names]))
    best = [min(reach, f["baseline"][0].nrmse) if k in touched else f["baseline"][0].nrmse
            for k, f in enumerate(fits)]
    if not held_out_gain(best, [f["coupled"][0].nrmse for f in fits]) > margin:  # the polish may change it
        polish("baseline")
    # the coupled folds were left unpolished because they won by the margin; if the baseline's
    # polish takes that win away, the verdict would compare polished baseline folds with unpolished
    # (upper-bound) coupled ones: polish those too, so both kinds are judged as delivered
    if not done["coupled"] and done["baseline"] and not held_out_gain(
            [f["baseline"][0].nrmse for f in fits], [f["coupled"][0].nrmse for f in fits]) > margin:
        polish("coupled")
    return done


def polished_fold(ident: Any, train: Sequence[Any], held: Any, unpolished: Any) -> Any:
    """The held-out validation of ``ident``'s model polished on ``train`` (``unpolished`` if it diverges);
    the fold model's intervals are not computed (only its prediction is read)."""
    from eddi.mdof.refine import refine_identified

    try:
        model, _b, _a = refine_identified(ident, train, intervals=False)
    except (IdentificationError, ValueError, FloatingPointError):
        return unpolished
    v = validate_mdof(model, held)
    return v if math.isfinite(v.nrmse) else unpolished


def polish_tag(obj: dict[str, Any], kind: str) -> str:
    """Whether ``kind``'s held-out figures are those of polished fold models (with the polish on,
    the delivered model is polished; an unpolished fold's figure is an upper bound)."""
    done = obj.get("polished_folds")
    if done is None:  # no polish: the folds are of the kind delivered
        return ""
    k, n = len(done[kind]), len(obj[kind]["folds"])
    if k == n:
        return "   (folds polished)"
    return f"   ({k} of {n} folds polished; the others unpolished: upper bounds)"
