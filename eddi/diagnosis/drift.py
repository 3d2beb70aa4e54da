"""Captures that differ from each other: a frequency that drifts between captures.

Each held-out capture is simulated by a model fitted on the others, and its cycles give the
model's frequency over the measured one (:mod:`eddi.diagnosis.symptoms`, ``frequency_bias`` at
large amplitude, with its standard error from the cycles' own scatter). On captures of one
structure these per-capture biases agree within their errors; when the structure or the set-up
changes between captures (temperature, clamping, a loosening bolt) the captures at the ends of
the drift are mispredicted in opposite senses by the fits on the others. The median over the
parts (the ``frequency_bias`` symptom) hides it: 0.1 % a capture on a 19 Hz, ~70-cycle set read
+0.04 % +- 0.035 % as a median while the end captures were 2.5x their floor (session 20).

:func:`capture_drift` reports when the per-capture biases are inconsistent with one value
(chi-square over their standard errors beyond :data:`DRIFT_CHI2_P`) and span at least
:data:`DRIFT_MIN_PCT`.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from eddi.diagnosis.results import Symptom

#: Chance probability below which the per-capture biases' chi-square says they differ.
DRIFT_CHI2_P = 1e-3
#: ... and they must span at least this [%] (a difference of a few thousandths of a percent is
#: not worth a finding whatever its errors).
DRIFT_MIN_PCT = 0.05


def _chi2_sf(x: float, dof: int) -> float:
    """Survival function of the chi-square distribution (scipy's)."""
    from scipy.stats import chi2

    return float(chi2.sf(x, dof))


def capture_drift(rows: Sequence[dict[str, float]], records: Sequence[int], labels: Sequence[str],
                  amplitudes: Sequence[float]) -> Symptom | None:
    """A ``capture_drift`` symptom, or None: ``rows`` the parts' symptom numbers
    (``frequency_bias_high_pct`` and its ``_se_pct``), ``records`` each part's record, ``labels``
    and ``amplitudes`` [m] each part's capture name and peak displacement. Only with one part per
    capture and at least three captures with a measured bias."""
    if len(set(records)) != len(records):
        return None
    keep = [i for i, row in enumerate(rows)
            if math.isfinite(row.get("frequency_bias_high_pct", float("nan")))
            and 0 < row.get("frequency_bias_high_se_pct", float("inf")) < float("inf")]
    if len(keep) < 3:
        return None
    b = np.array([rows[i]["frequency_bias_high_pct"] for i in keep])
    se = np.array([rows[i]["frequency_bias_high_se_pct"] for i in keep])
    w = 1.0 / se ** 2
    mean = float(np.sum(w * b) / np.sum(w))
    chi2 = float(np.sum(w * (b - mean) ** 2))
    p = _chi2_sf(chi2, len(keep) - 1)
    span = float(np.max(b) - np.min(b))
    if not (p < DRIFT_CHI2_P and span >= DRIFT_MIN_PCT):
        return None
    amps = np.array([amplitudes[i] for i in keep])
    # the biases in the order of the captures' amplitudes: a stiffness law the model lacks moves
    # the frequency with amplitude; a drift between captures need not follow it
    rank = np.argsort(np.argsort(amps))
    rho = float(np.corrcoef(rank, np.argsort(np.argsort(b)))[0, 1]) if np.ptp(amps) > 0 else 0.0
    each = ", ".join(f"{labels[i]} {b[k]:+.2f} % (+-{se[k]:.2g} %)" for k, i in enumerate(keep))
    why = ("they follow the captures' amplitudes, so the stiffness's amplitude law may be what the model lacks"
           if abs(rho) > 0.99 else "not in the order of the captures' amplitudes: the structure or the set-up "
           "changed between captures (drift: temperature, clamping), and no one model fits them all")
    return Symptom("capture_drift",
                   f"the captures differ from each other: the held-out model's frequency is off by {each} "
                   f"(large amplitude), a spread of {span:.2f} % beyond what their noise allows "
                   f"(chi-square {chi2:.3g} on {len(keep) - 1} degrees of freedom, p = {p:.2g}); {why}",
                   {"span_pct": span, "chi2": chi2, "dof": float(len(keep) - 1), "p": p,
                    "amplitude_rank_correlation": rho,
                    **{f"bias_pct_{labels[i]}": float(b[k]) for k, i in enumerate(keep)}})
