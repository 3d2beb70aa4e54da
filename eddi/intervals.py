"""What the 95 % intervals of an output-error fit do not hold: warnings in plain sentences.

The intervals (:mod:`eddi.refine`) are the fit's covariance: they hold the noise, not a gain
error of the measured signal. A DAQ whose decimation filter droops in the passband (a sinc^K
decimator, e.g. the ADS131M04's sinc3: ``1 - K (omega dt)^2 / 24`` at ``omega``) measures the
acceleration ``1 - K (omega dt)^2 / 24`` too small. A linear model is blind to that gain
(its response scales with the initial state), but a term of total degree ``d`` in ``x, v``
needs its coefficient ``(d - 1) K (omega dt)^2 / 24`` larger to ring the same way: at 33
samples per cycle a sinc3 moved a fitted ``k3`` by ~1 %, 134 standard errors
(``benchmarks/bench_ci_coverage_chain.py``, ``coarse_sinc3``). When the pipeline is told
the filter (``Pipeline.condition(adc_sinc_order=...)``), the fit compares the model through
it and the bias is gone; when it is not, :func:`sampling_kernel_warning` says how far such a
filter would move the worst coefficient, in intervals, when that exceeds an interval half
width on a record of fewer than :data:`WARN_BELOW_SAMPLES` samples per cycle.
"""

from __future__ import annotations

import math

from eddi.model import EquationOfMotion
from eddi.terms import parse_terms

#: The decimation filter the warning assumes when the DAQ's is not known: sinc3 (the order of
#: the ADS131M04's, the project's own ADC; a mean over each sample interval is sinc1).
ASSUMED_SINC_ORDER = 3
#: Warn when the filter would move a coefficient by more than this many interval half widths...
WARN_HALF_WIDTHS = 1.0
#: ...on a record of fewer samples per cycle than this (a sinc3 droop moves a cubic term by
#: >= 1.3 % there). Above it, a clean record's intervals are narrower than such a droop too
#: (41 samples per cycle: 0.6 % on ``k3``), but most DAQs either point-sample, or decimate
#: with a compensated flat passband: a warning on every such record would be noise. The
#: assumption is stated in ``docs/eddi-method.md`` instead.
WARN_BELOW_SAMPLES = 30.0


def droop_bias(term: str, omega_dt: float, sinc_order: int = ASSUMED_SINC_ORDER) -> float:
    """Relative change of a term's fitted coefficient that a sinc^K droop causes.

    Parameters
    ----------
    term : str
        The term (e.g. ``"x^3"``, ``"x^2*v"``).
    omega_dt : float
        Fastest angular frequency of the response times the sample interval [rad].
    sinc_order : int
        ``K``.

    Returns
    -------
    float
        ``(d - 1) K omega_dt^2 / 24``, ``d`` the term's total degree in ``x`` and ``v``.
    """
    (tm,) = parse_terms(term)
    px, pv, pax, pav, _, _ = tm.exponents
    return (px + pv + pax + pav - 1) * sinc_order * omega_dt**2 / 24.0


def sampling_kernel_warning(eom: EquationOfMotion, ci95: dict[str, dict[str, float]], rate_hz: float,
                            frequency_hz: float, kernel_var: float) -> tuple[str, ...]:
    """One warning when an untold decimation filter could move a coefficient beyond its interval.

    Parameters
    ----------
    eom : EquationOfMotion
        The returned model.
    ci95 : dict
        Its 95 % half widths (``{"damping": {term: h}, "stiffness": {...}}``).
    rate_hz : float
        Sample rate [Hz].
    frequency_hz : float
        Fastest frequency of the response [Hz] (0: unknown, no warning).
    kernel_var : float
        The sampling kernel the fit was told (:attr:`ConditionedSignal.sample_kernel_var`);
        no warning when it is known (> 0).

    Returns
    -------
    tuple of str
        Empty or one sentence.
    """
    if kernel_var > 0 or not (frequency_hz > 0 and rate_hz > 0) or rate_hz / frequency_hz >= WARN_BELOW_SAMPLES:
        return ()
    omega_dt = 2.0 * math.pi * frequency_hz / rate_hz
    worst: tuple[float, str, float] | None = None
    for group in ("damping", "stiffness"):
        for term, c in getattr(eom, group).items():
            half = ci95.get(group, {}).get(term, math.inf)
            shift = abs(droop_bias(term, omega_dt) * c)
            if shift > 0 and math.isfinite(half) and half > 0 and (worst is None or shift / half > worst[0]):
                worst = (shift / half, term, abs(droop_bias(term, omega_dt)))
    if worst is None or worst[0] <= WARN_HALF_WIDTHS:
        return ()
    ratio, term, rel = worst
    return (f"the 95 % intervals assume point samples (or a flat-passband decimation filter): at "
            f"{rate_hz / frequency_hz:.0f} samples a cycle a sinc{ASSUMED_SINC_ORDER} decimator's droop "
            f"would move {term} by {100 * rel:.2g} % ({ratio:.1f} interval half widths); if the DAQ has one, "
            "give its order (adc_sinc_order)",)
