"""Term selection of the output-error refinement: which candidate terms the data support.

Two paths over the output-error problem of :mod:`eddi.refine`
(:class:`eddi.output_error.OutputErrorProblem`), judged by the Bayesian information criterion
``BIC = n ln(RSS / n) + p ln(N)``:

* backward elimination from the full fit (:func:`_select`): the term with the smallest
  ``|c| / se`` first, each removal refitted and kept when it lowers the BIC (see
  :mod:`eddi.refine`'s notes);
* forward selection from ``x`` and ``v`` (:func:`_forward`), run when the backward path
  stalls on an ill-conditioned library, keeps a term on marginal evidence, or ends on a
  fitted start outside the record (:func:`select_terms`).

Both paths treat two BIC values within :data:`BIC_TIE` as a tie, won by the smaller model.

Measured on short, heavily damped records with the default library
(``benchmarks/bench_term_selection.py``, docs/eddi-method.md): the backward path alone kept
a spurious term on 14 of 80 tuning records and 18 of 70 held-out ones (12 and 16 of them
diverging); with the forward path 3 and 1, none diverging (session 5: 4 and 2). With the tie
rule on the backward path and the two further triggers (session 6): 0 and 1 on seeds 0-9,
0 and 0 on seeds 10-19 (main then: 1 and 2), no true term dropped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from eddi.energy import noise_level
from eddi.output_error import DIRECT_NRMSE, NUISANCE, STAGES, OutputErrorProblem
from eddi.terms import coefficient_unit, evaluate, parse_terms

#: ``mapper(fn, items) -> [fn(item) for item in items]``, possibly in forked processes (the
#: same contract as :data:`eddi.diagnosis.mapping.Mapper`; not imported from there, so that
#: identification does not import the diagnosis).
Mapper = Callable[[Callable[[Any], Any], Sequence[Any]], list]


def _serial_map(fn: Callable[[Any], Any], items: Sequence[Any]) -> list:
    return [fn(item) for item in items]


#: Backward elimination stops without a refit when the least significant term has
#: ``(c / se)^2 > WALD_KEEP ln N``: its removal would raise the BIC by ~``(WALD_KEEP - 1) ln N``.
WALD_KEEP = 4.0

#: Two BIC values closer than this tie: the model with fewer terms is preferred.
BIC_TIE = 2.0
#: A fit whose mean squared residual exceeds this multiple of the measured signal's white-noise
#: variance (:func:`eddi.energy.noise_level`) missed the record (a local minimum, or terms that
#: trade off): the forward path is tried (:func:`select_terms`).
MISFIT = 4.0


def core_terms(prob: OutputErrorProblem) -> list[int]:
    """Indices (into ``prob.names``) of the terms every model keeps: ``x`` (else the first
    stiffness term) and ``v`` (else the first damping term)."""
    core = []
    for group, first in (("stiffness", "x"), ("damping", "v")):
        idx = [i for i, (g, _) in enumerate(prob.names) if g == group]
        pick = [i for i in idx if prob.names[i][1] == first] or idx[:1]
        core += pick
    return sorted(core)


def core_start(prob: OutputErrorProblem, t: np.ndarray, x: np.ndarray, v: np.ndarray,
               y: np.ndarray) -> np.ndarray:
    """Coefficients of the core terms (:func:`core_terms`) by equation error:
    ``m a = -sum c_i term_i(x, v)`` in least squares over the window (``a`` measured, or
    the derivative of ``v``). A start that does not depend on the rest of the library."""
    core = core_terms(prob)
    a = y if prob.channel == "a" else np.gradient(v, t)
    step = max(1, t.size // 20000)
    cols = evaluate(parse_terms([prob.names[i][1] for i in core]), x[::step], v[::step])
    sol, *_ = np.linalg.lstsq(cols, -prob.eom.mass * a[::step], rcond=None)
    return sol


def select_terms(prob: OutputErrorProblem, p: np.ndarray, half: np.ndarray, rss: float, max_nfev: int,
                 core_coef: np.ndarray, mapper: Mapper | None = None,
                 start: "ForwardStart | None" = None) -> tuple[np.ndarray, np.ndarray, dict[str, str]]:
    """Backward elimination from the full fit, and forward selection from the core when needed.

    The backward path (:func:`_select`) can stall on an ill-conditioned library (a short or
    heavily damped record: few cycles over a small amplitude range, where ``x^3`` and ``x^5``
    or ``x^2 v`` and ``v^3`` trade off against each other): every term's interval is wide,
    yet removing any one of them alone raises the BIC; or the full model's simulation blows
    up and no term can be judged; or the fit lands in a local minimum (residual well above
    the sensor noise, a negative linear stiffness or damping). Then (some kept term's
    interval spans zero or its ``|c|/se`` is below ``sqrt(WALD_KEEP ln N)`` (kept on
    marginal evidence), the fit diverges, misses the record by more than ``sqrt(MISFIT)``
    times the noise, its ``x`` or ``v`` coefficient is negative, or its fitted initial ``x``
    is further from the measured one than the record's amplitude (an acceleration fit
    does not see a static offset: a polynomial with a second equilibrium can ring about
    it)) a forward path starts from the core (:func:`core_terms`, coefficients from
    :func:`core_start`) and adds, one at a time, the term that lowers the BIC most; the
    path with the lower BIC wins (within :data:`BIC_TIE`: the one with fewer terms).

    ``start``: the forward path's start computed beside the fit of every term
    (:func:`fit_beside_forward_start`); used when the forward path runs and it was computed
    from the inputs that path has here, else the start is computed here.
    """
    prob.residual(p, prob.n)
    if prob.diverged:  # nothing to judge the terms by: the forward path alone
        pb, hb, dropped, div_b, rss_b = p, half, {}, True, math.inf
    else:
        pb, hb, dropped = _select(prob, p, half, rss, max_nfev)
        rss_b = float(np.sum(prob.residual(pb, prob.n) ** 2))
        div_b = prob.diverged
    coef = np.abs(pb[:-NUISANCE] * prob.scale[prob.active])
    core = core_terms(prob)
    weak = [k for k, i in enumerate(prob.active) if i not in core and not hb[k] < coef[k]]
    signs = pb[:-NUISANCE] * prob.scale[prob.active]
    negative = any(signs[k] < 0 for k, i in enumerate(prob.active) if i in core)
    misfit = rss_b > MISFIT * prob.n * noise_level(prob.y) ** 2
    # kept on marginal evidence: the backward path stopped where one removal did not lower
    # the BIC, which a term of |c|/se ~ 3 does by chance about as often as not
    wald = math.sqrt(WALD_KEEP * np.log(prob.n_samples))
    marginal = any(coef[k] < wald * hb[k] / 1.959964 for k, i in enumerate(prob.active) if i not in core)
    # the fitted start outside the record: an acceleration fit does not see a static offset, and a
    # polynomial with a second equilibrium then rings about it (x0 9x the record's amplitude)
    x_amp = prob.scale[-NUISANCE]
    off_record = abs(pb[-NUISANCE] - prob.p0[-NUISANCE]) * x_amp > x_amp
    if not (div_b or weak or negative or misfit or marginal or off_record or not np.all(np.isfinite(hb))):
        return pb, hb, dropped
    saved = (list(prob.active), prob.scale.copy())
    nuisance = prob.p0[-NUISANCE:] * saved[1][-NUISANCE:]
    fwd = _forward(prob, nuisance, core, core_coef, max_nfev, mapper,
                   start if start is not None and start.key == _start_key(prob, nuisance, core, core_coef, max_nfev)
                   else None)
    if fwd is None:
        prob.active, prob.scale = saved
        return pb, hb, dropped
    pf, hf, rss_f, why = fwd
    bic_b = math.inf if div_b else prob.bic(rss_b, pb.size)
    bic_f = prob.bic(rss_f, pf.size)
    if bic_f < bic_b + (BIC_TIE if pf.size < pb.size else -BIC_TIE):
        return pf, hf, why
    prob.active, prob.scale = saved
    return pb, hb, dropped


def _forward(prob: OutputErrorProblem, nuisance: np.ndarray, core: list[int], core_coef: np.ndarray,
             max_nfev: int, mapper: Mapper | None = None,
             start: "ForwardStart | None" = None) -> tuple[np.ndarray, np.ndarray, float, dict[str, str]] | None:
    """Forward selection by BIC from the core terms (see :func:`select_terms`); each round's
    trials (one per term not yet in) through ``mapper`` (:mod:`eddi.diagnosis.mapping`).
    ``start``: the core's fit (:func:`_core_fit`) already computed from these inputs.

    Returns the parameters, their half widths, the RSS and, per term left out, why; None
    when the core itself does not fit (its simulation blows up).
    """
    n = prob.n
    others = _enter_forward(prob, core, core_coef)
    if start is None:
        p, rss, diverged = _core_fit(prob, nuisance, core, core_coef, max_nfev)
    else:  # computed beside the fit of every term: its simulations counted here
        if start.error is not None:
            raise start.error
        p, rss, diverged = start.p.copy(), start.rss, start.diverged
        prob.count += start.count
        prob.diverged = diverged
    if diverged:
        return None
    bic = prob.bic(rss, p.size)
    best_of: dict[int, float] = {}
    while others:
        base_active = list(prob.active)

        def trial(j: int, p: np.ndarray = p, base_active: list[int] = base_active) -> tuple:
            """The model with term ``j`` added, refitted: (BIC, parameters, active terms,
            simulations run). Everything it computes is returned (``mapper`` may run it in a
            forked copy of this process); ``prob`` is left as it was."""
            count = prob.count
            active = sorted(base_active + [j])
            q = np.insert(p, active.index(j), 0.0)
            prob.active = active
            sol = prob.fit(q, n, max(10, max_nfev // 3))
            rr = prob.residual(sol.x, n)
            out = (math.inf if prob.diverged else prob.bic(float(rr @ rr), q.size), sol.x, active,
                   prob.count - count)
            prob.active, prob.count = list(base_active), count
            return out

        # the trials of one round are independent: through ``mapper`` (other processes when
        # the caller has cores; the same results either way)
        trials = {}
        for j, got in zip(others, (mapper or _serial_map)(trial, list(others))):
            trials[j] = got[:3]
            prob.count += got[3]
            best_of[j] = got[0]
        j = min(trials, key=lambda i: trials[i][0])
        if not trials[j][0] < bic - BIC_TIE:  # a tie: the smaller model
            break
        bic, p, prob.active = trials[j]
        others.remove(j)
    half, rss = prob.ci95(p)
    why = {prob.names[j][1]: (f"{prob.names[j][0]} term ({coefficient_unit(prob.names[j][1])}) not added: "
                              f"the model without it has BIC {bic:.1f}, with it {best_of.get(j, math.inf):.1f} "
                              f"(forward selection from x and v: not supported by the data)")
           for j in others}
    return p, half, rss, why


def _enter_forward(prob: OutputErrorProblem, core: list[int], core_coef: np.ndarray) -> list[int]:
    """Set ``prob`` to the forward path's start (the core terms active, every scale from the
    core's coefficients or the floor); returns the terms not in the core."""
    prob.scale[core] = np.maximum(np.abs(core_coef), prob.floor[core])
    others = [i for i in range(len(prob.names)) if i not in core]
    prob.scale[others] = prob.floor[others]
    prob.active = list(core)
    return others


def _core_fit(prob: OutputErrorProblem, nuisance: np.ndarray, core: list[int], core_coef: np.ndarray,
              max_nfev: int) -> tuple[np.ndarray, float, bool]:
    """The core terms fitted in stages from their equation-error coefficients (``prob`` set by
    :func:`_enter_forward`): the parameters, the RSS over the whole window, whether it diverged."""
    n = prob.n
    p = np.concatenate((core_coef / prob.scale[core], nuisance / prob.scale[-NUISANCE:]))
    norm = float(np.linalg.norm(prob.y)) or 1.0
    direct = float(np.linalg.norm(prob.residual(p, n))) / norm <= DIRECT_NRMSE
    for frac in (STAGES[-1:] if direct else STAGES):
        p = prob.fit(p, max(64, int(round(frac * n))), max_nfev).x
    r = prob.residual(p, n)
    return p, float(r @ r), prob.diverged


@dataclass(frozen=True)
class ForwardStart:
    """The forward path's start (:func:`_core_fit`) computed apart: its result, the simulations it
    asked for, and the inputs it was computed from (``key``, :func:`_start_key`)."""

    key: bytes
    p: np.ndarray
    rss: float
    diverged: bool
    count: int
    error: Exception | None = None  #: what the fit raised (raised where the forward path runs)


def _start_key(prob: OutputErrorProblem, nuisance: np.ndarray, core: list[int], core_coef: np.ndarray,
               max_nfev: int) -> bytes:
    """What the core's fit depends on beyond the record: the start, the scales, the fit's settings."""
    return b"|".join((np.asarray(core, dtype=np.int64).tobytes(), np.asarray(core_coef, dtype=float).tobytes(),
                      np.asarray(nuisance, dtype=float).tobytes(), prob.scale.tobytes(),
                      repr((max_nfev, prob.min_gain, prob.x_scale)).encode()))


def _core_fit_apart(prob: OutputErrorProblem, core_coef: np.ndarray, max_nfev: int) -> ForwardStart:
    """:func:`_core_fit` on the problem as it stands, ``prob`` left as it was (it may run in this
    process); an error is kept, to be raised only where the forward path runs."""
    core = core_terms(prob)
    nuisance = prob.p0[-NUISANCE:] * prob.scale[-NUISANCE:]
    key = _start_key(prob, nuisance, core, core_coef, max_nfev)
    saved = (prob.active, prob.scale, prob.count, prob.diverged)
    count = prob.count
    try:
        prob.scale = prob.scale.copy()
        _enter_forward(prob, core, core_coef)
        p, rss, diverged = _core_fit(prob, nuisance, core, core_coef, max_nfev)
        return ForwardStart(key=key, p=p, rss=rss, diverged=diverged, count=prob.count - count)
    except Exception as exc:  # noqa: BLE001 - raised by _forward if the forward path runs
        return ForwardStart(key=key, p=np.zeros(0), rss=math.nan, diverged=True, count=prob.count - count,
                            error=exc)
    finally:
        prob.active, prob.scale, prob.count, prob.diverged = saved


def forks(mapper: Mapper | None) -> bool:
    """Whether ``mapper`` runs items in more than one process (it says so: ``jobs`` > 1, as
    :class:`station.forkmap.ForkMap`)."""
    return mapper is not None and int(getattr(mapper, "jobs", 1)) > 1


def fit_beside_forward_start(prob: OutputErrorProblem, fit_all: Callable[[], Any], core_coef: np.ndarray,
                             max_nfev: int, mapper: Mapper | None) -> tuple[Any, ForwardStart | None]:
    """``fit_all()`` (the fit of every term, where the backward path starts) and, when ``mapper``
    forks (:func:`forks`), the forward path's start beside it in another process.

    The two are independent: the forward path starts from the core's equation-error
    coefficients and the record's initial state, not from the fit of every term. Which path
    runs is known only after that fit (:func:`select_terms`); with a second core the start is
    ready by then (on the double beam the forward path runs: 0.67 s of CPU off the serial
    part), without one it would only cost CPU, and is computed where it is needed. Returns
    ``fit_all()``'s result and the start (None: not computed here). ``prob`` continues from
    the state ``fit_all`` left it in, whichever process ran it; the results are the same as in turn.
    """
    if not forks(mapper):
        return fit_all(), None

    def item(k: int) -> Any:
        if k == 0:
            return fit_all(), dict(vars(prob))
        return _core_fit_apart(prob, core_coef, max_nfev)

    (out, state), start = mapper(item, [0, 1])  # type: ignore[misc]
    vars(prob).update(state)
    return out, start


def _select(prob: OutputErrorProblem, p: np.ndarray, half: np.ndarray, rss: float,
            max_nfev: int) -> tuple[np.ndarray, np.ndarray, dict[str, str]]:
    """Backward elimination by BIC, smallest ``|c| / se`` first (see the module notes)."""
    n = prob.n
    dropped: dict[str, str] = {}
    while True:
        k_of = {i: k for k, i in enumerate(prob.active)}
        groups = [prob.names[i][0] for i in prob.active]
        droppable = [i for i in prob.active
                     if prob.names[i] != ("stiffness", "x")
                     and not (prob.names[i][0] == "damping" and groups.count("damping") == 1)]
        if not droppable:
            break
        coef = p[:-NUISANCE] * prob.scale[prob.active]
        se = half / 1.959964
        tval = {i: abs(coef[k_of[i]]) / se[k_of[i]] if se[k_of[i]] > 0 else np.inf for i in droppable}
        j = min(droppable, key=lambda i: tval[i])
        bic_old = prob.bic(rss, p.size)
        if tval[j] ** 2 > WALD_KEEP * np.log(prob.n_samples):
            # dropping it would raise the RSS by ~(c/se)^2 s^2 (Wald), the BIC by ~(c/se)^2 - ln N:
            # clearly supported, no refit needed
            break
        keep = [k for k in range(p.size) if k != k_of[j]]
        old_active = list(prob.active)
        prob.active = [i for i in prob.active if i != j]
        sol = prob.fit(p[keep], n, max(10, max_nfev // 3))
        trial = sol.x
        half_new, rss_new = prob.ci95(trial, sol.jac if sol.jac.shape == (n, trial.size) else None)
        bic_new = math.inf if prob.diverged else prob.bic(rss_new, trial.size)
        if not bic_new < bic_old + BIC_TIE:  # a tie: the smaller model, as on the forward path
            prob.active = old_active
            break
        group, name = prob.names[j]
        dropped[name] = (f"{group} term {coef[k_of[j]]:+.4g} ± {half[k_of[j]]:.2g} {coefficient_unit(name)} "
                         f"(|c|/se = {tval[j]:.2g}); without it BIC {bic_old:.1f} -> {bic_new:.1f}: "
                         f"not supported by the data")
        p, half, rss = trial, half_new, rss_new
    return p, half, dropped
