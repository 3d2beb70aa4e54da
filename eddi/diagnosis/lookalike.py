"""Look-alikes told apart within the cycle, on the held-out records.

Two mechanisms can reproduce the same held-out displacement. Quadratic drag ``|v| v`` and a
damping that grows with the displacement, ``|x| v``, lose the same energy per sinusoidal cycle
(both like ``A^3``): the energy balance EDDI fits and a simulated ring-down see one mechanism
(session 5 named drag for hidden ``|x| v``). Their forces differ *within* the cycle: drag is a
function of ``v`` alone, largest where the mass passes ``x = 0``; ``|x| v`` vanishes there and
peaks between. The same holds for a knee (clearance) against a smooth ``|x| x`` stiffening,
and for a hysteretic loop against a damping.

On a held-out part each candidate's model, fitted without it, leaves an equation-error
residual force ``r = F - m a - R(x, v)`` over the part's measured ``x, v, a`` (a hysteretic
force along the part's path from ``z = 0``). The model whose force shape the records hold
leaves the smaller residual. Mechanism A is compared with B cycle by cycle:

    D_c = sum over the samples of cycle c of (r_B^2 - r_A^2),   S_c = sum of (r_B - r_A)^2

If A holds the records' force shape and B does not, ``D_c ~ S_c`` (B's misfit is ``r_B -
r_A``); if B does, ``D_c ~ -S_c``; if neither, about 0. The statistic is the ratio
``u = sum D_c / sum S_c`` with the spread of ``D_c - u S_c`` over the cycles as its error:

    z = sum_c D_c / sqrt(n / (n - 1) sum_c (D_c - u S_c)^2)

over the ``n`` held-out cycles of every part (cycles as the independent blocks: the residual's
noise is filtered by the conditioning and its slow errors are correlated within a cycle;
weighting by ``S_c`` lets the large early cycles count as the data say, without their size
passing for scatter; the first cycle of a part, where a hysteretic state starts from zero, is
left out). A is *told apart* from B when ``z >= Z_SEPARATED`` and ``sum_c D_c > 0`` on every
part. Only models fitted the same way are compared so (EDDI's energy balance for both): a
model refitted by equation error minimises this very residual on its training records and
would win by its fitter (hysteresis against EDDI's drag did). :func:`eddi.diagnosis.name.decide`
needs a named mechanism told apart from every look-alike that would itself pass the held-out
tests; one fitted another way must be beaten on every held-out part in displacement.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from eddi.diagnosis.extend import Fit
from eddi.diagnosis.records import Part, Record
from eddi.energy import zero_crossings

#: A one-sided 3-sigma separation (chance 0.13 % if the two models fitted the records alike).
Z_SEPARATED = 3.0
#: |z| is capped here (written in the JSON; any value past Z_SEPARATED says the same).
Z_CAP = 1e6
#: Cycles below this fraction of the part's peak are left out (the noise's, not the model's).
CYCLE_FLOOR = 0.05


def residual_force(fit: Fit, rec: Record, part: Part) -> np.ndarray:
    """``F - m a - R(x, v)`` of ``fit``'s model over the part [N] (NaN where not finite)."""
    s, e = part.start, part.stop
    f = rec.force[s:e] if rec.force is not None else 0.0
    with np.errstate(all="ignore"):
        return f - fit.eom.mass * rec.a[s:e] - fit.eom.restoring_force(rec.x[s:e], rec.v[s:e])


def cycles(rec: Record, part: Part) -> list[tuple[int, int]]:
    """Full cycles of the part above :data:`CYCLE_FLOOR` of its peak, as index ranges into the part
    (the first cycle left out)."""
    s, e = part.start, part.stop
    x = rec.x[s:e]
    peak = float(np.max(np.abs(x))) if x.size else 0.0
    if not peak > 0 or x.size < 8:
        return []
    g = zero_crossings(rec.t[s:e], x, rec.v[s:e], hysteresis=CYCLE_FLOOR * peak)
    idx = np.searchsorted(rec.t[s:e], g)[::2]
    return [(int(a), int(b)) for a, b in zip(idx[1:-1], idx[2:]) if b > a]


def compare(records: Sequence[Record], parts: Sequence[Part], fits_a: Sequence[Fit | None],
            fits_b: Sequence[Fit | None], memo: dict | None = None) -> dict[str, float]:
    """Mechanism A against B within the cycle (module notes), per-fold fits of each.

    ``memo``: a dict shared by calls on the same records and parts (while the fits live):
    each fit's residual force and each part's cycles are computed once, not once per pair.

    Returns
    -------
    dict
        ``z`` (positive: A leaves the smaller residual; NaN when not measurable),
        ``parts_won`` (parts where A's residual is smaller), ``parts`` and ``cycles``.
    """
    blocks: list[float] = []
    sizes: list[float] = []
    won = 0
    if len(fits_a) != len(parts) or len(fits_b) != len(parts) or any(f is None for f in [*fits_a, *fits_b]):
        return {"z": float("nan"), "parts_won": 0, "parts": len(parts), "cycles": 0}
    memo = {} if memo is None else memo

    def once(key: tuple, fn, *args):  # type: ignore[no-untyped-def]
        if key not in memo:
            memo[key] = fn(*args)
        return memo[key]

    for part, fa, fb in zip(parts, fits_a, fits_b):
        rec = records[part.record]
        where = (part.record, part.start, part.stop)
        ra = once(("residual", id(fa), *where), residual_force, fa, rec, part)
        rb = once(("residual", id(fb), *where), residual_force, fb, rec, part)
        ds = [(float(np.sum(rb[i:j] ** 2 - ra[i:j] ** 2)), float(np.sum((rb[i:j] - ra[i:j]) ** 2)))
              for i, j in once(("cycles", *where), cycles, rec, part)]
        ds = [(d, q) for d, q in ds if math.isfinite(d) and math.isfinite(q)]
        blocks += [d for d, _ in ds]
        sizes += [q for _, q in ds]
        won += int(sum(d for d, _ in ds) > 0)
    n = len(blocks)
    if n < 3 or not sum(sizes) > 0:
        return {"z": float("nan"), "parts_won": won, "parts": len(parts), "cycles": n}
    d_arr, s_arr = np.array(blocks), np.array(sizes)
    u = float(np.sum(d_arr) / np.sum(s_arr))
    spread = math.sqrt(n / (n - 1) * float(np.sum((d_arr - u * s_arr) ** 2)))
    total = float(np.sum(d_arr))
    z = total / spread if spread > 0 else math.copysign(Z_CAP, total) if total else 0.0
    return {"z": float(np.clip(z, -Z_CAP, Z_CAP)), "parts_won": won, "parts": len(parts), "cycles": n}


def told_apart(result: dict[str, float] | None) -> bool:
    """A's within-cycle win over B (:func:`compare`) is clear: ``z >= Z_SEPARATED`` on every part."""
    return (result is not None and not math.isnan(result["z"]) and result["z"] >= Z_SEPARATED
            and result["parts_won"] == result["parts"])


def attach(candidates: Sequence, lookalikes: dict[str, tuple[str, ...]], fold_fits: dict[str, list],
           records: Sequence[Record], parts: Sequence[Part], native: dict[str, str]) -> list:
    """``candidates`` with :attr:`~eddi.diagnosis.results.Candidate.within_cycle` filled: each
    tried candidate against each of its ``lookalikes`` (by name) tried too, from the per-fold
    fits ``fold_fits`` (by name); a pair fitted differently (``native``: how each is fitted)
    is not compared within the cycle (``same_fitter`` 0, ``z`` NaN)."""
    from dataclasses import replace

    tried = {c.name for c in candidates if not c.skipped and c.model is not None}
    memo: dict = {}  # residuals and cycles shared by the pairs (the fits live until the return)
    out = []
    for c in candidates:
        if c.name in tried and c.form != "observed":
            wc = {}
            for b in lookalikes.get(c.name, ()):
                if b not in tried:
                    continue
                same = bool(native.get(c.name)) and native.get(c.name) == native.get(b)
                wc[b] = ({**compare(records, parts, fold_fits.get(c.name) or [], fold_fits.get(b) or [], memo),
                          "same_fitter": 1} if same else
                         {"z": float("nan"), "parts_won": 0, "parts": len(parts), "cycles": 0, "same_fitter": 0})
            c = replace(c, within_cycle=wc) if wc else c
        out.append(c)
    return out
