"""The held-out folds of a multi-channel diagnosis: each capture held out in turn, the coupled
model and the baseline (no nonlinear coupling; its variants: uncoupled modes, physical coordinates
joined by linear springs, lumped linear elements) identified on the others and validated on it,
the folds' CPU budget line, and the final baseline on every capture (split from
:mod:`station.mdof_commands`, which judges what the folds measure)."""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from eddi.errors import IdentificationError
from eddi.mdof.agreement import coupling_agreement
from eddi.mdof.identify import identify_mdof
from eddi.mdof.model import MdofModel
from eddi.mdof.predfloor import fold_floor, joint_floors
from eddi.mdof.validate import validate_mdof
from station.errors import InputFileError
from station.mdof_floor import folds_in_modes
from station.mdof_polish import polish_folds


#: Wall seconds of held-out folds past which a multi-channel diagnosis says on stderr that the
#: final model comes next (progress, not a measurement).
PROGRESS_S = 30.0

#: CPU seconds past which a multi-channel diagnosis says on stderr how long it expects to take.
BUDGET_CPU_S = 120.0


def budget_line(done: int, total: int, spent_s: float, refine: bool, budget_s: float = BUDGET_CPU_S,
                fold: int | None = None) -> str | None:
    """The stderr line once the projected CPU time exceeds ``budget_s`` (None within it).

    The projection: the mean CPU time of the ``done`` held-out folds so far times ``total``
    folds plus one for the final identification on every capture (a fold identifies twice
    on one capture fewer, so the final one costs less than a fold: an upper estimate). ``fold``
    (1-based): the line of that one fold (``done`` 1), as a forked worker that ran it says it.
    """
    if done <= 0 or total <= 0:
        return None
    projected = spent_s / done * (total + 1)
    if projected <= budget_s:
        return None
    hint = ("; most of it is the output-error polish of every fold, which --no-refine skips" if refine else "")
    which = f"held-out fold {fold} of {total} took" if fold is not None else f"{done} of {total} held-out folds took"
    return f"station diagnose: {which} {spent_s:.0f} s CPU; about {projected:.0f} s CPU in all{hint}"


def _held_out_folds(records: Sequence[Any], names: tuple[str, ...], dp: str, refine: bool = False,
                    say: Callable[[str], None] | None = None, clock: Callable[[], float] = time.process_time,
                    margin: float = 0.1, mapper: Callable | None = None, ahead: Callable[[], Any] | None = None
                    ) -> tuple[dict[str, list], dict[str, dict[str, list]], dict[str, list], float]:
    """Leave-one-out held-out errors of the coupled model and of the baseline (no nonlinear coupling).

    Returns per kind (``baseline``, ``coupled``) the fold nrmse, the per-channel and per-mode
    errors, and the largest span residual of the tail's shapes (``folds["polished"]``: per kind,
    which folds were polished; ``folds["floors"]``: per kind the folds' prediction floors,
    :class:`eddi.mdof.predfloor.FoldFloors`). With ``refine`` the folds' models are polished on their
    training records (:func:`eddi.mdof.refine.refine_identified`) before they predict the
    held-out capture, where the polish can change the verdict (:func:`station.mdof_polish.polish_folds`). The folds
    are independent: ``mapper(fn, items)`` (default in turn; :class:`station.forkmap.ForkMap` runs
    them in forked workers, the same results) computes them. Once a fold's CPU time (``clock``)
    projects past :data:`BUDGET_CPU_S`, the process that ran it says so through ``say`` (default:
    a line on stderr) rather than running on silently (:func:`budget_line`). ``ahead`` (optional):
    one more job the mapper runs beside the folds, first (``folds["ahead"]`` its result, else None).
    """
    say = say if say is not None else (lambda line: print(line, file=sys.stderr, flush=True))
    mapper = mapper if mapper is not None else (lambda fn, items: [fn(x) for x in items])

    def fold(k: int) -> tuple[dict[str, tuple], float]:
        start = clock()
        fit = _fold_fits(records, names, dp, k)
        line = budget_line(1, len(records), clock() - start, refine, fold=k + 1)
        if line:
            say(line)
        return fit

    fits: list[dict[str, tuple]] = []
    span = 0.0
    items: list[int] = ([-1] if ahead is not None else []) + list(range(len(records)))
    got = mapper(lambda k: ahead() if k < 0 else fold(k), items)
    first = got.pop(0) if ahead is not None else None
    for k, (fit, s) in enumerate(got):
        train = [r for j, r in enumerate(records) if j != k]
        fits.append({kind: (v, ident, train) for kind, (v, ident) in fit.items()})
        span = max(span, s)
    polished = (polish_folds(fits, records, names, margin, mapper) if refine
                else {"baseline": [], "coupled": []})
    folds: dict[str, list] = {"baseline": [], "coupled": []}
    per_channel = {kind: {c: [] for c in names} for kind in folds}
    per_mode: dict[str, list] = {kind: [] for kind in folds}
    for fit in fits:
        for kind in folds:
            v = fit[kind][0]
            folds[kind].append(v.nrmse)
            per_mode[kind].append([float(x) for x in v.mode_nrmse])
            for c, e in v.channel_nrmse.items():
                per_channel[kind][c].append(e)
    folds["polished"] = polished
    # per fold: whether the coupled model that was judged holds a nonlinear term between coordinates
    folds["coupling_terms"] = [bool(nonlinear_coupling_terms(fit["coupled"][1].model)) for fit in fits]
    # how far the folds' coupled models agree on the coupling force they identify (eddi.mdof.agreement)
    folds["agreement"] = coupling_agreement([fit["coupled"][1].model for fit in fits], records)
    folds["modes"] = folds_in_modes(fits, records)  # per mode, in the tail's basis (station.mdof_floor)
    # per kind, what a model identified from the other captures is expected to leave on each held-out
    # one: noise, the blow's impulse, the identification's own scatter (eddi.mdof.predfloor.joint_floors)
    folds["floors"] = joint_floors({kind: fold_floor([fit[kind][1].model for fit in fits], records, mapper)
                                    for kind in ("baseline", "coupled")})
    folds["ahead"] = first
    folds["fits"] = fits  # per fold and kind: (validation, identification, training captures)
    return folds, per_channel, per_mode, span


def _fold_fits(records: Sequence[Any], names: tuple[str, ...], dp: str, k: int
               ) -> tuple[dict[str, tuple], float]:
    """Fold ``k`` (capture ``k`` held out): per kind the held-out validation and the
    identification; and the largest span residual of the tail's shapes."""
    train = [r for j, r in enumerate(records) if j != k]
    # the baseline has no nonlinear coupling: uncoupled modes, and when the coupled model is
    # in physical coordinates also those coordinates joined by linear springs only (a
    # linear chain is not "modal coupling"); the better held out
    chosen = "auto"
    out: dict[str, tuple] = {}
    span = 0.0
    for kind in ("coupled", "baseline"):
        variants: tuple[tuple[str, bool | str], ...] = (("auto", True),) if kind == "coupled" else (
            (("auto", False),) + ((("physical", "linear"),) if chosen == "physical" else ())
            + _lumped_baseline(train))
        best = None
        for coords, coupling in variants:
            try:
                ident = identify_mdof(train, names, dp, coordinates=coords, coupling=coupling)
            except (IdentificationError, np.linalg.LinAlgError, ValueError) as exc:
                if best is not None or (coords, coupling) != variants[-1]:
                    continue
                raise InputFileError(f"identification failed with {records[k].label} held out: {exc}") from None
            cand = (validate_mdof(ident.model, records[k]), ident)
            if best is None or cand[0].nrmse < best[0].nrmse or not math.isfinite(best[0].nrmse):
                best = cand
        if best is None:
            raise InputFileError(f"identification failed with {records[k].label} held out")
        chosen = best[1].coordinates if kind == "coupled" else chosen
        span = max(span, best[1].span_residual)
        out[kind] = best
    return out, span


def _lumped_baseline(records: Sequence[Any]) -> tuple[tuple[str, str], ...]:
    """The baseline variant in lumped elements, linear springs and dashpots only (the linear physical
    model of the chain), with a force on every record (the lumped fit takes its scale from the blow).

    Why (session 14): the uncoupled modes cannot describe a chain whose tail resolves fewer modes
    than channels, and the per-coordinate fit in physical coordinates with linear coupling is far
    off on three masses: on linear chains the baseline was 2-360x its floor (``unexplained``) or
    grew (t7-lin3 of ``bench_mdof_nulls.py``: 9-17 nrmse on every fold, reported at gain 100 %)."""
    return (("lumped", "linear"),) if records and all(r.force is not None for r in records) else ()


def _final_baseline(records: Sequence[Any], names: tuple[str, ...], dp: str) -> Any:
    """The baseline on every capture, from the variants the folds choose among (uncoupled modes;
    physical coordinates joined by linear springs only), the one that reproduces the records best.

    The folds keep the better variant held out; the final model must be of the kind judged
    (uncoupled modes alone once gave a two-mass linear chain a damping ratio 45 % low while the
    folds, in physical coordinates, were at the noise floor)."""
    from dataclasses import replace

    auto = identify_mdof(records, names, dp, coupling=False)
    others = []
    for coords in ("physical",) + tuple(c for c, _k in _lumped_baseline(records)):
        try:
            others.append(identify_mdof(records, names, dp, coordinates=coords, coupling="linear"))
        except (IdentificationError, np.linalg.LinAlgError, ValueError):
            pass
    if not others:
        return auto
    err = [float(np.mean([validate_mdof(i.model, r).nrmse for r in records])) for i in [auto] + others]
    k = int(np.nanargmin(np.where(np.isfinite(err), err, np.nan))) if np.any(np.isfinite(err)) else 0
    if k == 0:
        return auto
    kind = "lumped elements (linear springs and dashpots)" if others[k - 1].lumped is not None \
        else "physical coordinates joined by linear springs"
    # the modal evidence (basis, unresolved modes) is the tail's, as for the uncoupled fit
    return replace(others[k - 1], modal_basis=auto.modal_basis, unresolved=auto.unresolved,
                   notes=others[k - 1].notes + (f"baseline in {kind} kept: training nrmse {err[k]:.3g}; uncoupled "
                                                f"modes {err[0]:.3g}",))


def nonlinear_coupling_terms(model: MdofModel) -> list[str]:
    """Terms of degree 2 or more in one coordinate's equation that involve another coordinate."""
    return [f"eq {i + 1}: {t.text}" for i in range(model.n_coords) for t, c in model.terms(i)
            if c != 0.0 and t.degree >= 2 and set(t.coordinates) - {i}]
