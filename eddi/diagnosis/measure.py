"""Measure: the noise floor of the held-out error, derived from the records themselves.

A held-out nrmse means nothing without the error that noise and conditioning alone cause in
this procedure. The floor is measured by perturbing the records: white noise at each record's
measured noise level (its response channel at rest) is added to the channel the coordinate
came from, the record is conditioned again exactly as before, and the baseline is refitted
and simulated fold by fold. Per held-out part the floor is

    sqrt(d_cond^2 + d_pred^2)

with ``d_cond`` the change of the conditioned coordinate and ``d_pred`` the change of the
baseline's held-out simulation, both relative to the measured part's norm: what one more
draw of the noise moves the measurement and the prediction by. The floor of a part is the
median of that over :data:`DRAWS` draws (session 6; one draw before). One draw is one sample
of a heavy-tailed quantity: the refit's refinement is kept or not, a free response's start
moves; on the demo session (three captures of ``sim://duffing-smooth``) five single draws
gave a floor of 0.02-0.087 on a part the baseline reproduced to 0.008. It needs no true model (a
synthetic "truth" from the fitted baseline was tried first: where the baseline is wrong, e.g.
fitted to a high-passed acceleration, its synthetic records gave a floor of 0.4-0.7 and the
verdict ``none`` at nrmse 0.92). ``cause: "none"`` is only given within a factor of it.

**The floor of the data** (session 12, :func:`data_floor`). ``d_pred`` is the baseline's own
estimator spread: what another draw of the noise does to *this model's* refit. For a model of
the records that is what the noise costs a prediction; for an ill-determined one (a 9-term
polynomial standing in for a clearance, coefficients +-70-120 %) it is the model's instability,
and counting it in full let the worse model earn the larger excuse: two blind sets read
``none`` over a poor fit whose floor was almost all ``d_pred`` (0.11-0.43 per part against
0.04 for the conditioned records). ``none`` is judged against the floor with ``d_pred`` counted
at most :data:`~eddi.diagnosis.settings.PRED_CAP` times the part's own share
``sqrt(d_cond^2 + d_chain^2)``; a part whose ``d_pred`` is within that keeps its floor exactly.
The full floor stays in :attr:`NoiseFloor.fold_nrmse` (what the draws measured).
"""

from __future__ import annotations

from functools import partial
from typing import Any, Callable, Hashable, Sequence

import numpy as np

from eddi.diagnosis.extend import Setup
from eddi.diagnosis.mapping import Mapper, serial_map
from eddi.diagnosis.fitter import Fitter
from eddi.diagnosis.records import Part, Record
from eddi.diagnosis.results import NoiseFloor
from eddi.diagnosis.settings import MIN_FLOOR, NRMSE_CAP, PRED_CAP
from eddi.diagnosis.show import simulate_part
from eddi.errors import EddiError

#: A held-out simulation this far off (nrmse) is lost: its change under noise is not counted.
LOST = 1.0
#: Draws of the noise per part; the part's floor is their median.
DRAWS = 3
#: Seed offset between draws (each record of a draw gets ``seed + SEED_STEP * draw + index``).
SEED_STEP = 100
#: Seed of the first draw (:func:`noise_floor`'s default).
DRAW_SEED = 1


def _tail_noise(x: np.ndarray) -> float:
    """White-noise RMS of ``x`` from its sample-to-sample differences (last 10 %)."""
    tail = x[int(0.9 * x.size):]
    return float(np.std(np.diff(tail)) / np.sqrt(2.0)) if tail.size > 8 else 0.0


def perturbed_record(rec: Record, seed: int) -> Record:
    """The record with one more draw of its noise, conditioned again (same free window)."""
    from eddi.conditioning import condition

    rng = np.random.default_rng(seed)
    if rec.response in ("acc", "vel", "disp") and rec.noise_rms > 0:
        clean = {"acc": rec.a, "vel": rec.v, "disp": rec.x}[rec.response]
        raw = clean + rec.noise_rms * rng.standard_normal(clean.size)
        try:
            c = condition(rec.t, force=rec.force, pretrigger_samples=rec.pretrigger_samples,
                          **{rec.response: raw})
            return Record.from_conditioned(c, rec.label).replace(
                free_start=rec.free_start, free_stop=rec.free_stop, response=rec.response,
                noise_rms=rec.noise_rms, pretrigger_samples=rec.pretrigger_samples)
        except (EddiError, ValueError):
            pass
    # no conditioning to re-run: the noise goes on the coordinate itself
    sx = _tail_noise(rec.x[rec.free_start:rec.free_stop])
    return rec.replace(x=rec.x + sx * rng.standard_normal(rec.x.size))


def draw_jobs(records: Sequence[Record], seed: int = DRAW_SEED) -> list[tuple[Hashable, Callable[[], Any]]]:
    """The floor's perturbed records (:func:`perturbed_record` of every record in every draw) as
    ``(key, job)`` pairs for a mapper that runs work beside its maps
    (:meth:`station.forkmap.ForkMap.beside`): they depend on the records alone, so a caller
    can queue them before the diagnosis (``station diagnose``: while the pipeline's baseline is
    fitted) and :func:`noise_floor` takes what was done (for these very record objects and
    seeds) instead of conditioning them again."""
    m = len(records)
    return [(_draw_key(records[i], seed + SEED_STEP * j + i),
             partial(perturbed_record, records[i], seed + SEED_STEP * j + i))
            for j in range(DRAWS) for i in range(m)]


def _draw_key(rec: Record, seed: int) -> Hashable:
    # the record object itself (its id: the job holding it keeps it alive until it is handed out)
    return ("noise floor draw", id(rec), int(seed))


def _perturbed(records: Sequence[Record], seed: int, mapper: Mapper | None) -> list[Record]:
    """Every record of every draw conditioned again (draw-major): those a mapper did beside
    (:func:`draw_jobs`; the mapper's ``done(key)``) taken, the others through ``mapper``."""
    m = len(records)
    items = [(j, i) for j in range(DRAWS) for i in range(m)]
    got: dict[tuple[int, int], Record] = {}
    done = getattr(mapper, "done", None)
    if done is not None:
        for j, i in items:
            ok, value = done(_draw_key(records[i], seed + SEED_STEP * j + i))
            if ok:
                got[(j, i)] = value
    rest = [ji for ji in items if ji not in got]
    # independent: through ``mapper`` too (in turn they were 1.5 s of the double beam's 6 s
    # that two cores could not share)
    made = (mapper or serial_map)(lambda ji: perturbed_record(records[ji[1]], seed + SEED_STEP * ji[0] + ji[1]),
                                  rest)
    got.update(zip(rest, made))
    return [got[ji] for ji in items]


def noise_floor(records: Sequence[Record], setup: Setup, parts: Sequence[Part],
                fold_masks: Sequence[Sequence[np.ndarray]], base_sims: Sequence[np.ndarray],
                seed: int = DRAW_SEED, refine: bool = False, mapper: Mapper | None = None,
                chain: tuple[Sequence[float], dict] | None = None) -> NoiseFloor:
    """The floor of the module notes, per held-out part (``base_sims``: the baseline's
    held-out simulations on the records as measured).

    On a part where the baseline (or its perturbed refit) is lost (nrmse >= :data:`LOST`)
    only ``d_cond`` counts. A part whose perturbed fit fails or diverges gets the smallest floor of the others (or
    :data:`MIN_FLOOR`); floors below :data:`MIN_FLOOR` are raised to it. The parts' refits
    run through ``mapper`` (:mod:`eddi.diagnosis.mapping`). ``chain``: per part the
    measurement chain's component (:func:`eddi.diagnosis.tolerance.chain_floor`) and the
    tolerances used; it joins each part's noise floor in quadrature.
    """
    m = len(records)
    perts = _perturbed(records, seed, mapper)
    draws = []
    for j in range(DRAWS):
        pert = perts[j * m:(j + 1) * m]
        # the same procedure as judged
        draws.append((pert, Fitter([r.signal() for r in pert], setup, pert, refine)))
    cond = []
    for i, r in enumerate(records):
        s, e = r.free_start, r.free_stop
        cond.append(float(np.median([np.linalg.norm(p[i].x[s:e] - r.x[s:e]) for p, _ in draws])
                          / (np.linalg.norm(r.x[s:e]) or 1.0)))

    def one(item: tuple[int, int]) -> tuple[float, float, float]:
        j, k = item
        pert, fitter = draws[j]
        part, masks, xb = parts[k], fold_masks[k], base_sims[k]
        rec, q = records[part.record], pert[part.record]
        xm = rec.x[part.start:part.stop]
        den = float(np.linalg.norm(xm)) or 1.0
        d_cond = float(np.linalg.norm(q.x[part.start:part.stop] - xm)) / den
        if not np.all(np.isfinite(xb)):
            return float("nan"), float("nan"), float("nan")
        if float(np.linalg.norm(xb - xm)) / den >= LOST:
            # the baseline is lost on this part: d_pred counts 0 whatever the perturbed refit
            # gives (below), so that refit (and its refinement) is not run
            return d_cond, 0.0, d_cond
        try:
            fit = fitter(masks).judged_baseline()[1]
        except EddiError:
            fit = None
        xs = simulate_part(fit.eom, q, part) if fit is not None else None
        if xs is None or not (np.all(np.isfinite(xs)) and np.all(np.isfinite(xb))):
            return float("nan"), float("nan"), float("nan")
        d_pred = float(np.linalg.norm(xs - xb)) / den
        if max(float(np.linalg.norm(xb - xm)), float(np.linalg.norm(xs - xm))) / den >= LOST:
            # a baseline that is lost on this part (diverges, or misses by the whole signal)
            # moves wildly with any perturbation: that says nothing of the noise
            d_pred = 0.0
        return float(np.hypot(d_cond, d_pred)), d_pred, d_cond

    # the parts are independent: through ``mapper`` (other processes when the caller has cores)
    n = len(parts)
    out = (mapper or serial_map)(one, [(j, k) for j in range(DRAWS) for k in range(n)])
    # per part the median over the draws (a draw that failed or diverged is left out)
    fold, preds, part_cond = [], [], []
    for k in range(n):
        got = [out[j * n + k] for j in range(DRAWS)]
        ok = [g for g in got if np.isfinite(g[0])]
        fold.append(float(np.median([g[0] for g in ok])) if ok else float("nan"))
        preds.append(float(np.median([g[1] for g in ok])) if ok else float("nan"))
        part_cond.append(float(np.median([g[2] for g in ok])) if ok else float("nan"))
    known = [f for f in fold if np.isfinite(f) and f < NRMSE_CAP]
    fill = min(known) if known else MIN_FLOOR
    fold = [f if (np.isfinite(f) and f < NRMSE_CAP) else fill for f in fold]
    return _floor(records, fold, cond, preds, chain, part_cond)


def _floor(records: Sequence[Record], fold: list[float], cond: list[float], preds: list[float],
           chain: tuple[Sequence[float], dict] | None, part_cond: Sequence[float] = ()) -> NoiseFloor:
    """The :class:`NoiseFloor` of the noise's per-part floors ``fold``, the chain's share
    (``chain``: per part, and the tolerances used) joined in quadrature, at least
    :data:`MIN_FLOOR` per part."""
    method = (f"{DRAWS} more draws of each record's measured noise on its response channel, "
              "each conditioned again; per part the median over the draws of "
              "sqrt(d_cond^2 + d_pred^2) (module notes)")
    chain_parts: tuple[float, ...] = ()
    info: dict = {}
    noise_only = tuple(max(MIN_FLOOR, f) for f in fold)
    if chain is not None:
        chain_parts, info = tuple(float(c) for c in chain[0]), dict(chain[1])
        fold = [float(np.hypot(f, c)) for f, c in zip(fold, chain_parts)]
        method += ("; joined in quadrature by the measurement chain's tolerance, the change of the part's "
                   "held-out simulation under the stated gain and clock differences (eddi.diagnosis.tolerance)")
    fold = [max(MIN_FLOOR, f) for f in fold]
    data = data_floor(fold, part_cond, preds, chain_parts)
    return NoiseFloor(nrmse=float(np.mean(fold)), fold_nrmse=tuple(fold),
                      noise_rms=tuple(float(r.noise_rms) for r in records),
                      conditioning_nrmse=tuple(cond), prediction_nrmse=tuple(preds),
                      method=method, chain_nrmse=chain_parts, chain=info, noise_fold_nrmse=noise_only,
                      part_conditioning_nrmse=tuple(float(c) for c in part_cond), data_fold_nrmse=data)


def data_floor(fold: Sequence[float], part_cond: Sequence[float], preds: Sequence[float],
               chain_parts: Sequence[float]) -> tuple[float, ...]:
    """Per part, the floor of the data: ``fold`` with the baseline's ``d_pred`` counted at most
    :data:`PRED_CAP` times the data's own share ``sqrt(d_cond^2 + d_chain^2)`` (module notes,
    "the floor of the data"); ``()`` when the parts' ``d_cond`` were not measured."""
    if len(part_cond) != len(fold) or len(preds) != len(fold):
        return ()
    out = []
    for k, f in enumerate(fold):
        c, p = float(part_cond[k]), float(preds[k])
        ch = float(chain_parts[k]) if len(chain_parts) == len(fold) else 0.0
        if not (np.isfinite(c) and np.isfinite(p)):
            out.append(f)  # a part whose draws failed keeps the filled floor
            continue
        own = float(np.hypot(c, ch))
        if p <= PRED_CAP * own:
            out.append(f)  # the refit's spread is what the noise costs a model of these records: kept
            continue
        out.append(max(MIN_FLOOR, min(f, float(np.hypot(own, PRED_CAP * own)))))
    return tuple(out)
