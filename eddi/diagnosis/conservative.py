"""A stiffness mechanism is not named over a damping signature it leaves as it was (session 14).

A stiffness mechanism (``native == "stiffness"``: clearance, asymmetric or smooth stiffening)
is conservative: it stores energy and gives it back, it loses none. When the baseline's energy
lost per cycle departs from the measured one beyond its uncertainty
(:func:`eddi.diagnosis.symptoms.damping_signature`: beyond 15 % and 3 standard errors in a band)
and the named stiffness model's held-out simulations depart there as much, the name has cut the
held-out error by something other than the mechanism the records show: the verdict is
``unexplained`` with it as the best partial explanation. s12floor's family seed 206 (hidden
Coulomb friction 0.018 ``k1 A``, 22.5 kg, 10.5 Hz, 1 kHz, 24 dB) was named
``asymmetric_stiffness`` for a 53 % cut while the baseline lost 11 % too much energy per cycle at
large amplitude and 15 % too little at small (friction's signature: a constant force loses
relatively more at small amplitude) and the named model still 15 % too little.

The candidate's simulations keep only the coordinate; its rate is the derivative of a cubic
spline through them (error ~ (w h)^4, 0.3 % of the energy at 13 samples a cycle), and the
baseline is measured the same way for the comparison.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

import numpy as np

from eddi.diagnosis.decide import Decision
from eddi.diagnosis.records import Part, Record
from eddi.diagnosis.results import Symptom
from eddi.diagnosis.symptoms import _energy_numbers, damping_signature, energy_threshold_pct, part_noise

BANDS = ("high", "low")


def _rate(t: np.ndarray, x: np.ndarray) -> np.ndarray | None:
    from scipy.interpolate import CubicSpline  # local: scipy

    if x.size < 4 or not np.all(np.isfinite(x)):
        return None
    return CubicSpline(t, x)(t, 1)


def energy_mismatch(records: Sequence[Record], parts: Sequence[Part], sims: Sequence[np.ndarray], mass: float,
                    cond_nrmse: Sequence[float] | None) -> dict[str, tuple[float, float]]:
    """Per band, the median over the held-out parts of the energy mismatch of the simulations
    ``sims`` (coordinate only) and of its standard error [%]."""
    rows = []
    for i, (p, xs) in enumerate(zip(parts, sims)):
        r = records[p.record]
        sl = slice(p.start, p.stop)
        t, xm = r.t[sl], r.x[sl]
        vs = _rate(t, np.asarray(xs, float))
        if vs is None or xs.size != xm.size:
            continue
        d = cond_nrmse[i] if cond_nrmse is not None and i < len(cond_nrmse) else float("nan")
        rows.append(_energy_numbers(t, xm, r.v[sl], np.asarray(xs, float), vs, mass, part_noise(r, xm, d)))
    out = {}
    for key in BANDS:
        vals = [(row[f"energy_mismatch_{key}_pct"], row[f"energy_mismatch_{key}_se_pct"]) for row in rows
                if np.isfinite(row.get(f"energy_mismatch_{key}_pct", np.nan))]
        out[key] = ((float(np.median([v for v, _ in vals])), float(np.median([s for _, s in vals])))
                    if vals else (float("nan"), float("inf")))
    return out


def stiffness_over_damping(dec: Decision, symptoms: Sequence[Symptom], native: str, records: Sequence[Record],
                           parts: Sequence[Part], base_sims: Sequence[np.ndarray], winner_sims: Sequence[np.ndarray],
                           mass: float, cond_nrmse: Sequence[float] | None) -> Decision:
    """``dec`` itself, or ``unexplained`` (the winner as the partial explanation) when the winner
    is a stiffness mechanism (``native``) and the baseline's damping signature stays as it was
    under it (module notes): in a band where the baseline's energy mismatch is beyond its
    uncertainty, the winner's is still beyond its own threshold on the same side."""
    if dec.winner is None or native != "stiffness":
        return dec
    sig = next((s for s in symptoms if s.kind == "energy_mismatch"), None)
    if sig is None or not damping_signature(sig):
        return dec
    base = energy_mismatch(records, parts, base_sims, mass, cond_nrmse)
    named = energy_mismatch(records, parts, winner_sims, mass, cond_nrmse)
    for key in BANDS:
        b, sb = sig.values.get(f"{key}_amplitude_pct", np.nan), sig.values.get(f"{key}_amplitude_se_pct", np.nan)
        (bb, _), (c, sc) = base[key], named[key]
        if not (np.isfinite(b) and abs(b) > energy_threshold_pct(sb)):
            continue  # no signature in this band
        if np.isfinite(c) and abs(c) > energy_threshold_pct(sc) and np.sign(c) == np.sign(bb):
            w = dec.winner
            word = "large" if key == "high" else "small"
            reason = (f"{w.name} (a stiffness mechanism: it stores energy, it loses none) would cut the error by "
                      f"{100 * w.gain:.0f} %, but the energy lost per cycle at {word} amplitude stays as the baseline had it "
                      f"({bb:+.0f} % -> {c:+.0f} % +-{sc:.2g} %; the baseline {b:+.0f} % +-{sb:.2g} %): a damping "
                      f"signature beyond its uncertainty is left unexplained, so no stiffness is named")
            return replace(dec, cause="unexplained", winner=None, partial=w, reason=reason)
    return dec
