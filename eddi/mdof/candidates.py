"""Which identified candidate to keep: the simplest whose simulation matches as well as noise allows.

``identify_mdof(coordinates="auto")`` fits up to four candidates (modal coordinates, physical
coordinates, physical with drift-filtered equations, lumped springs and dashpots), each a full
model. Each is simulated over its training records (mean per-channel nrmse, the training error).

Rule (session 9): among the candidates whose training error is within the records' **noise
floor** of the best one (:func:`eddi.mdof.validate.noise_floor`, mean over records and
channels), keep the one with the **fewest free coefficients** (masses included); ties by
training error. A difference of training errors smaller than what the measurement noise alone
leaves on the conditioned displacement does not tell the models apart, and the model with
fewer constants then determines each better. Session 8's rule (the smallest training error)
kept, once the free window stopped before the drift filter's end transient, the monomial
model of a two-mass chain over the lumped one at 0.0064 vs 0.0067 training nrmse (floor
~0.003): cubic coefficients 10 % off alone and 54 % polished, against 0.1 % and 0.8 % for the
lumped model (``benchmarks/bench_mdof_light.py``).

No I/O.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from eddi.mdof.records import ChannelRecord


@dataclass(frozen=True)
class CandidateChoice:
    """Result of :func:`choose_candidate`.

    Attributes
    ----------
    index : int
        The candidate kept.
    errors : tuple of float
        Training nrmse of every candidate (inf when its simulation diverged).
    parameters : tuple of int
        Free coefficients of every candidate (masses included).
    tolerance : float
        Training nrmse within which candidates count as equal (the best plus the noise floor).
    note : str
        One line for the identification's notes.
    own : tuple of float
        Each candidate's own training nrmse (before the form's best is taken): what a later
        choice among the same candidates and more can be given as ``known``.
    """

    index: int
    errors: tuple[float, ...]
    parameters: tuple[int, ...]
    tolerance: float
    note: str
    own: tuple[float, ...] = ()


def training_error(model, records: Sequence[ChannelRecord]) -> float:
    """Mean per-channel nrmse of ``model``'s simulation of the records (inf when it diverges)."""
    from eddi.mdof.validate import validate_mdof  # validation imports the identification

    errs = [validate_mdof(model, r).nrmse for r in records]
    return float(np.mean(errs)) if all(np.isfinite(errs)) else math.inf


def records_floor(records: Sequence[ChannelRecord]) -> float:
    """Mean over records and channels of the nrmse noise alone leaves (:func:`eddi.mdof.validate.noise_floor`)."""
    from eddi.mdof.validate import noise_floor

    return float(np.mean([np.mean(noise_floor(r)) for r in records]))


def parameter_count(ident) -> int:
    """Free coefficients of an identification: element constants (lumped) or monomials, plus masses."""
    model = ident.model
    if ident.lumped is not None:
        return len(ident.lumped.constants) + len(model.mass)
    return sum(len(d) + len(s) for d, s in zip(model.damping, model.stiffness)) + len(model.mass)


def choose_candidate(candidates: Sequence, names: Sequence[str], records: Sequence[ChannelRecord],
                     known: Sequence[float] = ()) -> CandidateChoice:
    """The candidate to keep (module docstring) and a note listing every candidate.

    A candidate's training error is simulated here unless it is already known (the same number,
    not simulated twice): ``known[k]`` for the first ``len(known)`` candidates (a former choice's
    :attr:`CandidateChoice.own` on the same records), else the candidate's own ``training_nrmse``
    when finite (an identification that simulated its model on these records, e.g. the lumped
    fit's :func:`eddi.mdof.physical.identify_lumped`). Session 15: one coupled identification of
    a three-mass chain simulated the first three candidates twice and the lumped one three times
    (4.6 of its 9.9 s CPU in the choices).
    """
    own = tuple(float(known[k]) if k < len(known) else _known_or_simulated(c, records)
                for k, c in enumerate(candidates))
    # a form that tried variants (the lumped fit's rows' starts) is judged by the best it reached:
    # which variant it then keeps is an estimation choice inside the form (eddi.mdof.physical)
    errors = tuple(min(e, f) if math.isfinite(f := getattr(c, "form_error", math.nan)) else e
                   for c, e in zip(candidates, own))
    params = tuple(parameter_count(c) for c in candidates)
    best = float(min(errors))
    tol = best + records_floor(records) if math.isfinite(best) else math.inf
    fair = [k for k, e in enumerate(errors) if e <= tol]
    keep = min(fair, key=lambda k: (params[k], errors[k]))
    why = "" if errors[keep] == best else (
        f" (within the noise floor of the best, {best:.3g} + floor = {tol:.3g}, with the fewest coefficients)")
    form = "" if own[keep] == errors[keep] else f" (the form's best; this variant {own[keep]:.3g})"
    note = (f"{names[keep]} kept: training nrmse {errors[keep]:.3g}{form}, {params[keep]} coefficients{why}"
            + "".join(f"; {nm} {e:.3g} ({p})" for k, (nm, e, p) in enumerate(zip(names, errors, params))
                      if k != keep))
    return CandidateChoice(keep, errors, params, tol, note, own)


def _known_or_simulated(candidate, records: Sequence[ChannelRecord]) -> float:
    """``candidate.training_nrmse`` when finite (computed on these records by its identification),
    else :func:`training_error`."""
    done = getattr(candidate, "training_nrmse", math.nan)
    return float(done) if math.isfinite(done) else training_error(candidate.model, records)
