"""What the 95 % intervals of the output-error fit (:mod:`eddi.refine`) hold, and warnings for what they do not.

:func:`sampling_curvature`: a DAQ's sampling kernel in the compared values;
:func:`noise_covariance_of_fit`: the noise covariance of coloured residuals;
:func:`sampling_kernel_warning`: a sentence when an untold decimation filter could move a
coefficient beyond its interval;
:func:`sampling_kernel_margin`: the intervals widened by what an unstated sampling kernel (point
samples or interval means) can do.

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

import numpy as np

from eddi.errors import SignalError
from eddi.model import EquationOfMotion
from eddi.refine_grid import through_sampling_pass
from eddi.secant_jacobian import switching_model
from eddi.terms import parse_terms

#: The decimation filter the warning assumes when the DAQ's is not known: sinc3 (the order of
#: the ADS131M04's, the project's own ADC; a mean over each sample interval is sinc1).
ASSUMED_SINC_ORDER = 3
#: Warn when the filter would move a coefficient by more than this many interval half widths...
WARN_HALF_WIDTHS = 1.0
#: ...on a record of fewer samples per cycle than this (a sinc3 droop moves a cubic term by
#: >= 0.6 % there; ``coarse_sinc3`` of the chain benchmark, ~31 a cycle: 1 %, 30-150 se).
#: Above it, a clean record's intervals can be narrower than such a droop too, but most
#: DAQs either point-sample, or decimate with a compensated flat passband: a warning on
#: every such record would be noise. The assumption is stated in ``docs/eddi-method.md``.
WARN_BELOW_SAMPLES = 40.0


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
    rc = analog_droop_bias(term, frequency_hz / rate_hz)
    return (f"the 95 % intervals assume point samples of the signal itself (no decimation filter, no analog "
            f"anti-alias filter rolling off near the response): at {rate_hz / frequency_hz:.0f} samples a cycle a "
            f"sinc{ASSUMED_SINC_ORDER} decimator's droop would move {term} by {100 * rel:.2g} % ({ratio:.1f} interval "
            f"half widths), a 1-pole analog filter at rate/{ANALOG_CUTOFF_DIVISOR:g} by {100 * rc:.2g} %; if the DAQ "
            "has a decimator, give its order (adc_sinc_order; `station identify --adc-filter sincK[:R]`); an analog "
            "filter is not modelled: record faster",)


#: The sampling kernel the intervals make room for when the record does not say how it was
#: sampled: a mean over each sample interval (sinc1: an integrating ADC, a block-average
#: decimation, the rig's own force channel), the mildest low-pass a sampled record has had
#: besides point samples. Session 12 (s12cov, ``benchmarks/bench_ci_coverage_coarse.py``):
#: records of such samples put ``x^2*v`` and ``x^3`` ``2 (omega dt)^2 / 24`` high (+1.6 % at
#: 14.6 samples a cycle), 3-128 standard errors at 50-60 dB, while point samples were unbiased;
#: nothing in a free response tells the two apart (a gain on every sample, see the module notes).
MARGIN_SINC_ORDER = 1
#: Say so in a warning when the margin adds more than this fraction of the noise interval to
#: some coefficient's interval.
MARGIN_WARN_FRACTION = 0.25


def sampling_kernel_margin(eom: EquationOfMotion, ci95: dict[str, dict[str, float]], rate_hz: float,
                           frequency_hz: float, kernel_known: bool,
                           measured: dict[str, dict[str, float]] | None = None,
                           estimate: tuple[float, float] | None = None
                           ) -> tuple[dict[str, dict[str, float]], tuple[str, ...]]:
    """The intervals widened by what an unknown sampling kernel can do, and a sentence when it matters.

    A record whose sampling is not stated may hold point samples or means over each sample
    interval (:data:`MARGIN_SINC_ORDER`); the two differ by a gain ``1 - (omega dt)^2 / 24`` on
    the response at ``omega`` that moves a term of total degree ``d`` by ``(d - 1)`` times it
    (:func:`droop_bias`; linear terms not at all). The fit cannot see it, so each coefficient's
    half width gets ``|droop_bias(term, omega dt, 1) c|`` added (a bound: the estimate is
    unbiased for point samples and off by that much for interval means). When the fit measured
    the margin itself (``measured``, :func:`measured_kernel_margin`: the record's harmonics bound
    its kernel), that is added instead. When the kernel is known (``kernel_known``: told
    ``sincK`` or ``none``, point samples) nothing is added.

    Parameters
    ----------
    eom : EquationOfMotion
        The returned model.
    ci95 : dict
        Its 95 % half widths from the noise (``{"damping": {term: h}, "stiffness": {...}}``).
    rate_hz, frequency_hz : float
        Sample rate and fastest frequency of the response [Hz] (0: unknown, nothing added).
    kernel_known : bool
    measured : dict, optional
        Margins per coefficient the fit measured (same layout as ``ci95``).
    estimate : (float, float), optional
        The record's own estimate of its kernel in interval means and its standard error (named
        in the sentence when informative).

    Returns
    -------
    ci95 : dict
        Widened half widths (a new dict; ``ci95`` itself when nothing is added).
    warnings : tuple of str
        Empty or one sentence naming the samples per cycle and the largest margin.
    """
    if kernel_known or not (frequency_hz > 0 and rate_hz > 0):
        return ci95, ()
    omega_dt = 2.0 * math.pi * frequency_hz / rate_hz
    informative = estimate is not None and 2.0 * estimate[1] < KERNEL_INFORMATIVE
    out: dict[str, dict[str, float]] = {g: dict(ci95.get(g, {})) for g in ci95}
    worst: tuple[float, str, float] | None = None
    for group in ("damping", "stiffness"):
        for term, c in getattr(eom, group).items():
            half = ci95.get(group, {}).get(term)
            if half is None or not math.isfinite(half):
                continue
            rel = abs(droop_bias(term, omega_dt, MARGIN_SINC_ORDER))
            margin = rel * abs(c)
            if measured is not None and term in measured.get(group, {}):
                # read from the record: that bound; not readable: the larger of it (one interval
                # mean through the fit, which holds what a gain does not) and the formula's
                margin = float(measured[group][term]) if informative else max(margin, float(measured[group][term]))
                rel = margin / abs(c) if c else 0.0
            out.setdefault(group, {})[term] = half + margin
            ratio = margin / half if half > 0 else math.inf
            if margin > 0 and (worst is None or ratio > worst[0]):
                worst = (ratio, term, rel)
    if worst is None or worst[0] <= MARGIN_WARN_FRACTION:
        return out, ()
    _, term, rel = worst
    read = ""
    if informative and measured is not None:
        read = (f"; its harmonics read a kernel of {estimate[0]:.2f} +- {estimate[1]:.2f} interval means (0 point "
                "samples, 1 an integrating ADC, 3 a sinc3 decimator)")
    return out, (f"coarse sampling: {rate_hz / frequency_hz:.0f} samples per cycle: the record does not say "
                 f"whether its samples are points or means over each sample interval (an integrating ADC), "
                 f"which moves the nonlinear terms{read}; the 95 % intervals include up to {100 * rel:.2g} % on "
                 f"{term} for it (state the sampling, `--adc-filter none` for point samples or sincK, to "
                 "drop it; record faster to shrink it)",)


#: Cut-off of the analog anti-alias filter the warning sizes: the sample rate over this (the
#: usual FFT-analyser convention, rate / 2.56).
ANALOG_CUTOFF_DIVISOR = 2.56


def analog_droop_bias(term: str, f_over_rate: float, divisor: float = ANALOG_CUTOFF_DIVISOR) -> float:
    """Relative change of a term's fitted coefficient that a 1-pole analog anti-alias filter causes.

    A DAQ that point-samples (no decimation filter) still has an analog front end; a 1-pole
    (RC) filter at ``fc`` passes ``1 / sqrt(1 + (f / fc)^2) ~ 1 - (f / fc)^2 / 2`` at ``f``: a
    gain on the measured acceleration, which a term of total degree ``d`` makes up for with its
    coefficient ``(d - 1)`` times larger, as :func:`droop_bias`. Session 10
    (``benchmarks/bench_ci_coverage_cli.py`` systems filtered before sampling): at 25 samples a
    cycle a 1-pole filter at 0.39 of the rate moved ``x^3`` by 0.9 % (86 standard errors at 55
    dB; this formula: 1.05 %); a 2-pole Butterworth there (gain ``1 - (f / fc)^4 / 2``) moved
    ``x^3`` by 1.7 standard errors, and on a 45 s, 50 dB record at 30 a cycle the damping
    terms by 3-5 (its phase; not sized here).

    Parameters
    ----------
    term : str
        The term.
    f_over_rate : float
        Fastest frequency of the response over the sample rate.
    divisor : float
        ``rate / fc``.

    Returns
    -------
    float
        ``(d - 1) (divisor f / rate)^2 / 2``.
    """
    (tm,) = parse_terms(term)
    px, pv, pax, pav, _, _ = tm.exponents
    return (px + pv + pax + pav - 1) * (divisor * f_over_rate) ** 2 / 2.0


#: A kept coefficient whose 95 % interval is wider than this fraction of its value is reported
#: as poorly determined (the record holds too little of its effect: fewer than ~8 standard
#: errors from zero). Its interval is honest (it may hold the truth 20-30 % away), but a printed
#: value with no sentence invites trust it does not deserve.
LOOSE_FRACTION = 0.25


def loose_coefficient_warnings(eom: EquationOfMotion, ci95: dict[str, dict[str, float]]) -> tuple[str, ...]:
    """One sentence per coefficient whose 95 % interval is wider than :data:`LOOSE_FRACTION`
    of its value (unbounded intervals are left to the divergence warnings)."""
    out = []
    for kind, coefs in (("damping", eom.damping), ("stiffness", eom.stiffness)):
        for term, c in coefs.items():
            half = ci95.get(kind, {}).get(term)
            if half is None or not math.isfinite(half) or c == 0 or abs(half) <= LOOSE_FRACTION * abs(c):
                continue
            out.append(f"{kind} coefficient {term} = {c:.4g} is poorly determined by this record: its 95 % "
                       f"interval is +-{100 * abs(half / c):.0f} % of the value (a larger or longer blow, "
                       f"several records, or a library without the term would pin it down)")
    return tuple(out)


#: Name the term selection in a warning when it made some kept coefficient's interval wider than
#: this multiple of its interval given the selected model.
SELECTION_WARN_RATIO = 2.0


def selection_warning(eom: EquationOfMotion, ci95: dict[str, dict[str, float]],
                      given: dict[str, dict[str, float]], dropped: dict[str, str] | tuple[str, ...]) -> tuple[str, ...]:
    """One sentence when the term selection's uncertainty widened a kept coefficient's interval.

    ``ci95``: the refinement's half widths with the selection's uncertainty
    (:attr:`eddi.refine.Refinement.ci95`); ``given``: as if the dropped terms were known to be
    absent (:attr:`eddi.refine.Refinement.ci95_given_selection`); ``dropped``: the dropped terms.
    """
    worst: tuple[float, str, float, float] | None = None
    for group in ("damping", "stiffness"):
        for term, c in getattr(eom, group).items():
            h, g = ci95.get(group, {}).get(term), given.get(group, {}).get(term)
            if h is None or g is None or not (g > 0 and math.isfinite(h)) or c == 0:
                continue
            if h > SELECTION_WARN_RATIO * g and (worst is None or h / g > worst[0]):
                worst = (h / g, term, abs(h / c), abs(g / c))
    if worst is None:
        return ()
    _, term, h_rel, g_rel = worst
    names = ", ".join(dropped)
    return (f"the term selection dropped {names}, which this record barely tells apart from {term}: {term}'s 95 % "
            f"interval (+-{100 * h_rel:.2g} %) holds what the fit with {names} allows (+-{100 * g_rel:.2g} % if "
            f"{names} were known to be absent); a larger blow or a longer record would tell them apart",)


def sampling_curvature(block: int, kernel_var: float = 0.0) -> float:
    """Weight of the second difference (on the grid of block centres) in a compared value.

    A compared value is the mean of ``block`` samples, and each sample is the DAQ's
    weighted mean of the signal around its time (its decimation filter: a kernel of variance
    ``kernel_var`` sample intervals squared; 0 for point sampling or a flat passband, ``1/12``
    for the mean over each sample interval, ``K/12`` for a sinc^K decimator such as the
    ADS131M04's sinc3). For a smooth signal the value is then the signal at the centre plus
    half the total variance times its second derivative:
    ``(block^2 - 1 + 12 kernel_var) / (24 block^2)`` times the second difference on the
    centres' grid (``O((omega h)^4)`` left). A kernel's delay is a time shift of the free
    response, which the fitted initial state absorbs.

    Unmodelled, a sinc3 decimator's droop ``1 - (omega dt)^2 / 8`` is a gain on the
    measured acceleration: at 33 samples per cycle it moved a fitted ``k3`` by ~1 % (134
    standard errors; ``benchmarks/bench_ci_coverage_chain.py``, ``coarse_sinc3``).
    """
    if not (kernel_var >= 0 and math.isfinite(kernel_var)):
        raise SignalError(f"sampling kernel variance must be >= 0 sample intervals^2, got {kernel_var}")
    return (block**2 - 1 + 12.0 * kernel_var) / (24.0 * block**2)


def sampling_quartic(block: int, kernel_var: float = 0.0) -> float:
    """Weight of the fourth difference (on the grid of block centres) in a compared value.

    The next term after :func:`sampling_curvature`: a compared value is ``y + (s2 / 2) y'' +
    (m4 / 24) y''''`` (``s2, m4``: variance and fourth moment of the block's samples, each
    the DAQ's kernel mean), and the second difference the curvature term uses is itself
    ``H^2 y'' + H^4 y'''' / 12`` on the centres' grid (``H = block dt``). Left out, the
    compared value was ``(omega H)^4 (1/288 - 1/1920)`` off for a large block: 4.7e-6 of the
    signal at ``omega H = 0.2`` (a gain that grows with frequency: a weak nonlinear term of a
    heavy, slow structure sampled at kHz, compared in blocks of hundreds of samples, moved
    by ~1 of its 95 % half widths at 60 dB: ``benchmarks/bench_ci_coverage_cli.py``).
    Returned: ``m4 / (24 H^4) - c2 / 12``, ``c2`` the curvature weight; ``m4`` of the block
    ``(B^2 - 1)(3 B^2 - 7) / 240``, combined with a kernel's of variance ``kv`` as
    independent parts, the kernel's fourth moment taken as ``3 kv^2`` (Gaussian).
    """
    c2 = sampling_curvature(block, kernel_var)
    s2b = (block**2 - 1) / 12.0
    m4 = (block**2 - 1) * (3 * block**2 - 7) / 240.0 + 6.0 * s2b * kernel_var + 3.0 * kernel_var**2
    return m4 / (24.0 * block**4) - c2 / 12.0


def through_sampling(y: np.ndarray, curvature: float, quartic: float) -> np.ndarray:
    """``y`` on the grid of block centres as the compared values hold it (along axis 0):
    ``y + curvature * second difference + quartic * fourth difference``. At the edges the
    differences are extrapolated linearly from the interior: the nearest interior one alone
    (as before) left the first compared value ``(omega H)^3 / 24`` off (3e-4 of the signal in
    blocks of ``omega H = 0.2``), where the free response is largest; a 1 t, 1.4 Hz record at
    20 kHz (blocks of 443 samples) had ``x^3`` 4e-5 off, noise-free."""
    fast = through_sampling_pass(y, curvature, quartic)  # a Jacobian: one compiled pass, the same floats
    return fast if fast is not None else through_sampling_numpy(y, curvature, quartic)


def through_sampling_numpy(y: np.ndarray, curvature: float, quartic: float) -> np.ndarray:
    """:func:`through_sampling` in numpy's passes (what the compiled pass must equal)."""
    out = np.array(y, dtype=float, copy=True)
    n = out.shape[0]
    if curvature and n >= 3:
        d2 = np.empty_like(out)
        d2[1:-1] = out[2:] - 2.0 * out[1:-1] + out[:-2]
        if n >= 4:
            d2[0], d2[-1] = 2.0 * d2[1] - d2[2], 2.0 * d2[-2] - d2[-3]
        else:
            d2[0], d2[-1] = d2[1], d2[-2]
        if quartic and n >= 6:
            d4 = np.empty_like(out)
            d4[2:-2] = out[4:] - 4.0 * out[3:-1] + 6.0 * out[2:-2] - 4.0 * out[1:-3] + out[:-4]
            d4[:2], d4[-2:] = d4[2], d4[-3]
            out += quartic * d4
        out += curvature * d2
    return out

#: Lags of the residual autocorrelation the colour test looks at (compared values).
COLOUR_LAGS = 10
#: Ljung-Box statistic over :data:`COLOUR_LAGS` lags beyond which the residuals count as
#: coloured (chi-square with 10 degrees of freedom: 0.1 % of white records exceed 29.6).
COLOUR_Q = 29.6
#: Smoothing of the residual periodogram: a moving mean over ``2 m + 1`` bins, ``m`` this
#: fraction of the bins (at least 8).
PSD_SMOOTH = 1.0 / 400


def normal_pinv(jac: np.ndarray) -> np.ndarray | None:
    """``pinv(J^T J)`` of a fit's Jacobian, or None when it has none: a sensitivity that overflowed
    (a column not finite) or an SVD that does not converge (numpy's LinAlgError). Every interval
    and shift of the output-error fit solves through here, so such a fit says "not determined"
    (infinite interval, no shift) instead of raising (blind unseen10, session 13: a 67 g set's
    diagnose exited 1 on "SVD did not converge" in :func:`integration_shift`)."""
    with np.errstate(over="ignore", invalid="ignore"):
        jtj = jac.T @ jac
    if not np.all(np.isfinite(jtj)):
        return None
    try:
        return np.linalg.pinv(jtj)
    except np.linalg.LinAlgError:
        return None


def noise_covariance_of_fit(jac: np.ndarray, r: np.ndarray, dof: int, jtj: np.ndarray | None = None) -> np.ndarray:
    """``J^T Sigma J``: the middle of the coefficients' covariance ``(J^T J)^-1 J^T Sigma J (J^T J)^-1``.

    White residuals (the Ljung-Box statistic of lags 1-:data:`COLOUR_LAGS` below
    :data:`COLOUR_Q`): ``s^2 J^T J``, ``s^2 = RSS / dof``, the usual ``s^2 (J^T J)^-1``.
    Coloured ones: a DAQ's decimation filter correlates neighbouring samples, and compared on
    every sample ``s^2 (J^T J)^-1`` holds one sample's variance where the fit averages over
    the band of the response, whose noise density is higher (sinc3 made the intervals ~1.3x
    too narrow, ``benchmarks/bench_ci_coverage_chain.py``); a drifting sensor bias colours
    them at low frequency, far below that band. ``Sigma`` is then the stationary noise's
    covariance from the residuals' smoothed periodogram ``S(f)``:
    ``J^T Sigma J = sum_f Re(J(f)^H J(f)) S(f) / n`` (Parseval: ``s^2 J^T J`` for a flat
    ``S``), so only the noise density in the band of the Jacobian counts. (A Toeplitz
    covariance from 10 residual lags smeared a drift's low-frequency power into that band and
    widened the intervals of drifting records 1.8x: RMS z 0.57.) The caller
    (``eddi.output_error.OutputErrorProblem.ci95``) keeps the wider of this and the white
    ``s^2 (J^T J)^-1`` per coefficient: a slow drift leaks into the coefficients a little, which the white ``s^2``
    (raised by the drift) held (drifting records: RMS z 1.35 with the band density alone,
    1.04 with the wider one).

    Parameters
    ----------
    jac : ndarray, shape (n, p)
        Jacobian of the compared values.
    r : ndarray, shape (n,)
        Residuals at the optimum.
    dof : int
        ``n - p``.
    """
    if jtj is None:
        jtj = jac.T @ jac
    n = r.size
    g0 = float(r @ r) / dof
    lags = min(COLOUR_LAGS, n // 4)
    if not (g0 > 0) or lags < 1:
        return g0 * jtj
    rho = np.array([float(r[:-k] @ r[k:]) for k in range(1, lags + 1)]) / float(r @ r)
    q = n * (n + 2) * float(np.sum(rho**2 / (n - np.arange(1, lags + 1))))
    if q <= COLOUR_Q:
        return g0 * jtj
    spec = np.abs(np.fft.rfft(r)) ** 2 / n * (n / dof)
    m = max(8, int(PSD_SMOOTH * spec.size))
    kernel = np.ones(2 * m + 1)
    dens = np.convolve(spec, kernel, mode="same") / np.convolve(np.ones(spec.size), kernel, mode="same")
    weight = np.full(spec.size, 2.0)
    weight[0] = 1.0
    if n % 2 == 0:
        weight[-1] = 1.0
    fj = np.fft.rfft(jac, axis=0)
    return np.real((fj.conj().T * (weight * dens)) @ fj) / n


#: The reference simulation has this many times the fit's RK4 steps.
FINER = 2
#: What the Richardson extrapolation (for an ``h^4`` error) leaves of an error of order ``h^5``
#: (RK4's amplitude error: 3.3 %), bounded: the correction's uncertainty is this fraction of it.
RICHARDSON_LEFT = 1.0 / 25.0


def _simulated_finer(prob, p: np.ndarray, factor: int) -> np.ndarray | None:
    """The fit's simulation at ``p`` with ``factor`` times the RK4 steps (None if it diverges)."""
    saved = (prob.steps, prob.substeps, prob._last, prob._memo, prob.count, prob.diverged)
    try:
        prob.steps, prob.substeps = prob.steps * factor, prob.substeps * factor
        out = prob._simulated(p, prob.n, sensitivities=False)
        ok = not prob.diverged and bool(np.all(np.isfinite(out)))
    finally:
        prob.steps, prob.substeps, prob._last, prob._memo, prob.count, prob.diverged = saved
    return out if ok else None


#: The record bounds its own sampling kernel when ``2 sigma`` of the estimate (in interval means,
#: sinc1) is below this; otherwise the bound is one interval mean (:data:`MARGIN_SINC_ORDER`).
KERNEL_INFORMATIVE = 1.0
#: ...and only when the third harmonic of its fastest oscillation is resolved by the curvature
#: model of a kernel: ``3 omega dt`` at most this [rad] (>= ~16 samples a cycle). The estimate
#: reads the kernel in the harmonics, and a second difference gives ``(sin(theta/2)/(theta/2))^2``
#: of a harmonic's curvature at ``theta`` rad a sample (0.67 at 8 a cycle): session 12's interval
#: means at 8-10 a cycle were read as ~0 (x^2*v 5 % off, 9.6 half widths).
KERNEL_HARMONIC_MAX = 1.2


def measured_kernel_margin(prob, p: np.ndarray, half: np.ndarray, jac: np.ndarray | None = None
                           ) -> tuple[np.ndarray, float, float] | None:
    """How far an unstated sampling kernel can move the fitted coefficients, as the record tells it.

    The compared values of a record of interval means differ from point samples by
    ``u = y(kernel + 1/12) - y(kernel)`` (:func:`sampling_curvature`): mostly a gain, which
    moves a degree-``d`` term by ``(d - 1) (omega dt)^2 / 24`` (:func:`sampling_kernel_margin`),
    and a harmonic-dependent part, which the fit can see: with ``J`` the fit's Jacobian at
    ``p``, ``k = -(u_perp . r) / (u_perp . u_perp)`` (``u_perp``: ``u`` less its projection on
    ``J``, ``r`` the residual) is the record's own estimate of its kernel in interval means,
    ``sigma = s / |u_perp|``. The coefficients move by ``-pinv(J) u`` per interval mean; the
    margin is that times ``|k| + 2 sigma`` when ``2 sigma`` < :data:`KERNEL_INFORMATIVE`
    (point samples of a strongly nonlinear record: ``k`` ~0 +- 0.02-0.1; interval means:
    1.0-1.2 +- 0.04-0.1, session 12), else times 1 (the prior bound). Cost: one simulation
    without sensitivities and a solve with the Jacobian (computed when None). Skipped (None)
    when the formula bound is below 5 % of every interval (densely sampled records) or a
    simulation diverges. On a record too coarse for the estimate (:data:`KERNEL_HARMONIC_MAX`)
    ``sigma`` is returned as ``inf`` and the margin is ``|pinv(J) u|`` (one interval mean), which
    :func:`sampling_kernel_margin` then takes with the formula bound, the larger of the two.

    Returns
    -------
    (margin, k, sigma) or None
        ``margin`` in the scaled units of ``p``'s active coefficients (>= 0).
    """
    k_act = len(prob.active)
    dt = float(prob.t[1] - prob.t[0]) / prob.block if prob.t.size > 1 else 0.0
    omega = prob.omega if hasattr(prob, "omega") else 0.0
    names = [prob.names[i][1] for i in prob.active]
    scale = prob.scale[prob.active]
    coefs = np.asarray(p[:k_act]) * scale
    if not (omega > 0 and dt > 0):
        return None
    formula = np.array([abs(droop_bias(t, omega * dt, MARGIN_SINC_ORDER)) for t in names]) * np.abs(coefs)
    if np.all(formula < 0.05 * np.where(half > 0, half, np.inf)):
        return None
    base = prob.simulated(p, prob.n)
    if prob.diverged:
        return None
    saved = (prob.curvature, prob.quartic, prob._last, prob._memo, prob.count, prob.diverged)
    try:
        kv = getattr(prob, "kernel_var", 0.0) + 1.0 / 12.0
        prob.curvature, prob.quartic = sampling_curvature(prob.block, kv), sampling_quartic(prob.block, kv)
        alt = prob._simulated(p, prob.n, sensitivities=False)
        ok = not prob.diverged and bool(np.all(np.isfinite(alt)))
    finally:
        prob.curvature, prob.quartic, prob._last, prob._memo, prob.count, prob.diverged = saved
    if not ok:
        return None
    if jac is None:
        jac = prob.jacobian(p)
    u = alt - base
    inv = normal_pinv(jac)
    if inv is None:
        return None
    gu = inv @ (jac.T @ u)
    u_perp = u - jac @ gu
    uu = float(u_perp @ u_perp)
    r = base - prob.y[: prob.n]
    dof = max(1, prob.n - p.size)
    if not uu > 0:
        k_hat, sigma = 0.0, math.inf
    else:
        k_hat = -float(u_perp @ r) / uu
        sigma = math.sqrt(float(r @ r) / dof / uu)
    if 3.0 * omega * dt > KERNEL_HARMONIC_MAX:  # too coarse to read the kernel: the prior bound
        sigma = math.inf
    bound = abs(k_hat) + 2.0 * sigma if 2.0 * sigma < KERNEL_INFORMATIVE else 1.0
    return np.abs(gu[:k_act]) * bound, k_hat, sigma


def integration_shift(prob, p: np.ndarray, jac: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Correction of the fitted coefficients for the fit's own integration error, and its uncertainty.

    The output-error fit (:mod:`eddi.refine`) simulates the model with RK4 at ``omega h <=
    0.1``. RK4's frequency is ``(omega h)^4 / 120`` low there and its amplitude decays a
    little too fast, and the fit moves the coefficients to make up for both: on an exact
    free response at ``omega h = 0.095`` (``tests/eddi/test_refine_floor.py``) ``k1``
    ended 1.3e-6 high and ``b1`` 2.2e-5 low, 2000 and 140 of their 95 % half widths at
    120 dB; the 55-60 dB records of ``benchmarks/bench_ci_coverage_chain.py`` had ``k1``
    1e-6 off (coverage 0.10, session 8). With the simulation at twice the steps,
    ``e = (y_2 - y) / (1 - 2^-4)`` (Richardson for an ``h^4`` error: the phase) is the
    coarse simulation's error, and to first order the fit with an exact integrator is ``p -
    pinv(J) e``. Of RK4's ``h^5`` amplitude error that leaves 3.3 % (``b1`` 8e-7 on that
    record), bounded by :data:`RICHARDSON_LEFT` of the correction and added to the 95 % half
    widths (a second reference at 4x the steps pinned it down, at three times the cost). A model
    with a ``sign`` term (:func:`eddi.secant_jacobian.switching_model`) has no ``h^4`` law: the
    switch falls anywhere inside a step, and the difference jumps with the step size (session 13,
    ``--family stick`` seed 1 record 38: the "correction" moved ``k1`` by +3.3e-5, 2.2 half widths,
    away from the fits at 4x and 16x the steps, which agreed within 3e-7): no shift, the
    difference's whole size as the uncertainty.
    Cost: one simulation without sensitivities at twice the steps, and a solve with the
    Jacobian the fit has at ``p``.

    Parameters
    ----------
    prob : eddi.refine._OutputError
        The problem at its optimum ``p``.
    p : ndarray
        Scaled parameters (active coefficients, then the nuisance ones).
    jac : ndarray, optional
        Jacobian of the compared values at ``p`` (computed when None).

    Returns
    -------
    shift, spread : ndarray
        Shift of the active coefficients and its uncertainty, in the scaled units of ``p``
        (zeros when a simulation diverges).
    """
    k = len(prob.active)
    zero = (np.zeros(k), np.zeros(k))
    coarse = prob.simulated(p, prob.n)
    if prob.diverged:
        return zero
    fine = _simulated_finer(prob, p, FINER)
    if fine is None:
        return zero
    if jac is None:
        jac = prob.jacobian(p)
    err = (fine - coarse) / (1.0 - float(FINER) ** -4)
    inv = normal_pinv(jac)
    if inv is None or not np.all(np.isfinite(err)):
        return zero
    dp = -(inv @ (jac.T @ err))[:k]
    if switching_model(prob.model_of(p)):
        # a sign term's switch inside a step: an error of low order that changes at random with the
        # step (no h^4 law to extrapolate): not corrected, bounded by the two step sizes' difference
        return np.zeros(k), np.abs(dp)
    return dp, RICHARDSON_LEFT * np.abs(dp)
