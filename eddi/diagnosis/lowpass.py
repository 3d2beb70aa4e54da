"""The ``sensor_lowpass`` candidate: the acceleration channel's low-pass, fitted and corrected.

:mod:`eddi.diagnosis.align` corrects a response that lags the force by moving the force by the
measured lag. A low-pass (an anti-alias or conditioner filter on the acceleration's channel) is
a delay only well below its corner: near the blow's band it also rounds and spreads the blow,
and a delay cannot undo that (session 14, own sets: alignment alone cut the held-out error of
Butterworth-filtered sets by 60-85 % and stayed 2-4x over the floor, e.g. 0.271 -> 0.076).

For a linear structure the filter commutes with it: the response measured through ``H`` is the
structure's response to the force through ``H`` (``x``, ``v`` are the filtered acceleration's
integrals, filtered alike). So the correction passes each record's force through the fitted
filter (the same window widening, trimmed masks and per-fold refit of the baseline as the
alignment: :func:`eddi.diagnosis.align.refit`) and judges the held-out parts as measured.

The filter is fitted over the first blow, where the corrected acceleration
(:func:`eddi.diagnosis.lag.blow_window`) is the force's shape over the mass through the channel:
a digital Butterworth or Bessel (:data:`KINDS`) of each order of :data:`ORDERS` and each corner
of a log grid, one gain per record and one corner for all (one channel), least squares pooled
over the records; the kind, order and corner with the least residual are kept (a Bessel's
corner as scipy's ``norm="delay"`` defines it: group delay ``1 / w_c`` at DC). Fitting a
Butterworth alone to a Bessel-filtered channel matched the blow's shape but not its delay at the
structure's frequency (my tuning set seed 3: a 4th-order Bessel of 9 samples' delay fitted as a
3rd-order Butterworth of 7.9; held-out 0.015, but the impulse over the momentum 7 % off on the
filtered records). The corner's interval is where the pooled
residual stays within one residual variance of its least (a profile likelihood, ``Delta chi^2
= 1``: optimistic when the residual is the shape's rather than the noise's); the corners fitted
per record give its spread. A pure delay (the spline of :func:`eddi.calculus.delay`) is fitted
the same way: when the low-pass does not describe the blow better (:data:`SHAPE_SHARE`) the
records show a delay, not a filter, and the candidate is kept with that reason, never named.

Naming (:mod:`eddi.diagnosis.loop`): like any other cause (:func:`eddi.diagnosis.decide.decide`:
the margin's cut on every held-out part, within the named factor of the floor), and, since a
low-pass is also a lag, its held-out error must be below the alignment's by more than the floor
of the data (:func:`over_delay`): otherwise the simpler cause, the lag, is the one the records
can tell. Nothing is fitted without a claimed lag (nulls stay silent), nor on a one-sample blow
(a blow inside one sample holds no shape to fit a corner on).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from eddi.calculus import delay
from eddi.diagnosis.align import record_lags, refitted_candidate
from eddi.diagnosis.extend import Setup
from eddi.diagnosis.lag import blow_window
from eddi.diagnosis.records import Part, Record
from eddi.diagnosis.results import Candidate

#: The candidate's name (a measurement-chain cause).
NAME = "sensor_lowpass"
#: Filter families tried: maximally flat magnitude, maximally flat delay.
KINDS = ("butterworth", "bessel")
#: Orders tried (a first-order RC to an 8th-order anti-alias filter).
ORDERS = (1, 2, 3, 4, 6, 8)
#: Corners tried, as fractions of the sampling rate (log grid; 0.45: just below Nyquist).
CORNER_SHARES = tuple(float(v) for v in np.geomspace(0.004, 0.45, 64))
#: Corners of the fine grid between the coarse neighbours of the least residual.
FINE_POINTS = 41
#: The low-pass must leave at most this share of the pure delay's residual over the blow.
SHAPE_SHARE = 0.8
#: The filtered blow's end: where this share of its impulse response's absolute sum is reached.
SETTLE_SHARE = 0.99


@dataclass(frozen=True)
class LowPassFit:
    """The channel's low-pass fitted over the first blow (module notes).

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    order : int
        The filter's order.
    corner_hz, corner_lo_hz, corner_hi_hz : float
        The corner [Hz] and its interval (one residual variance above the least residual).
    corner_spread_hz : float
        Standard deviation of the corners fitted record by record [Hz].
    rss, delay_rss : float
        Pooled residual over the blows of the low-pass and of the best pure delay.
    delay_samples : float
        The best pure delay [samples].
    group_delay_samples : float
        The filter's group delay at DC [samples].
    """

    kind: str
    order: int
    corner_hz: float
    corner_lo_hz: float
    corner_hi_hz: float
    corner_spread_hz: float
    rss: float
    delay_rss: float
    delay_samples: float
    group_delay_samples: float

    @property
    def shape_share(self) -> float:
        return self.rss / self.delay_rss if self.delay_rss > 0 else math.inf


def filter_ba(kind: str, order: int, corner_hz: float, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """The digital filter ``(b, a)`` of :data:`KINDS` ``kind``, ``order`` and corner [Hz]."""
    from scipy.signal import bessel, butter

    wn = min(corner_hz / (rate_hz / 2), 0.99)
    return bessel(order, wn, norm="delay") if kind == "bessel" else butter(order, wn)


def _rss(model: np.ndarray, acc: np.ndarray) -> float:
    """Residual of ``acc`` against ``g model`` with the least-squares gain ``g``."""
    mm = float(np.dot(model, model))
    if not mm > 0:
        return float(np.dot(acc, acc))
    g = float(np.dot(model, acc)) / mm
    return float(np.dot(acc - g * model, acc - g * model)) if g > 0 else float(np.dot(acc, acc))


def _profile(wins, rate: float, kind: str, order: int, shares: Sequence[float] = CORNER_SHARES) -> np.ndarray:
    """Residual per record (rows) and corner (columns: ``shares`` of the rate) for one filter."""
    from scipy.signal import lfilter

    out = np.empty((len(wins), len(shares)))
    for j, share in enumerate(shares):
        b, a = filter_ba(kind, order, share * rate, rate)
        for i, (force, acc) in enumerate(wins):
            out[i, j] = _rss(lfilter(b, a, force), acc)
    return out


def fit_lowpass(records: Sequence[Record], f1: float) -> LowPassFit | None:
    """The channel's low-pass over the records' first blows (module notes); None when no record
    has a blow of 2 samples or more to fit it on."""
    from scipy.signal import group_delay

    wins = []
    for r in records:
        w = blow_window(r, f1, min_width=2)
        if w is not None:
            wins.append((w[0], w[1]))
    if not wins:
        return None
    rate = records[0].rate_hz
    best = None
    for kind in KINDS:
        for order in ORDERS:
            if kind == "bessel" and order == 1:
                continue  # the same first-order low-pass as the Butterworth's
            prof = _profile(wins, rate, kind, order)
            pooled = prof.sum(axis=0)
            k = int(np.argmin(pooled))
            if best is None or pooled[k] < best[2][best[3]]:
                best = (kind, order, pooled, k, prof)
    assert best is not None
    kind, order, pooled, k, prof = best
    n = sum(f.size for f, _a in wins)
    # a fine grid between the coarse neighbours of the least residual: the corner and its interval
    lo, hi = CORNER_SHARES[max(0, k - 1)], CORNER_SHARES[min(len(CORNER_SHARES) - 1, k + 1)]
    fine = np.geomspace(lo, hi, FINE_POINTS)
    fprof = _profile(wins, rate, kind, order, fine)
    fpooled = fprof.sum(axis=0)
    kf = int(np.argmin(fpooled))
    var = float(fpooled[kf]) / max(1, n - len(wins) - 1)
    inside = np.flatnonzero(fpooled <= fpooled[kf] + var)
    # at least one fine step either way (the grid's resolution, 0.4 %)
    c_lo = fine[inside[0] - 1] if inside[0] > 0 else CORNER_SHARES[max(0, k - 2)]
    c_hi = fine[inside[-1] + 1] if inside[-1] < fine.size - 1 else CORNER_SHARES[min(len(CORNER_SHARES) - 1, k + 2)]
    corner = float(fine[kf]) * rate
    per_record = [float(fine[int(np.argmin(row))]) * rate for row in fprof]
    delays = np.arange(0.0, 24.05, 0.1)
    d_pooled = np.array([sum(_rss(delay(f, d), a) for f, a in wins) for d in delays])
    kd = int(np.argmin(d_pooled))
    b, a = filter_ba(kind, order, corner, rate)
    gd = float(group_delay((b, a), w=[1e-4])[1][0])
    return LowPassFit(kind, order, float(corner), float(c_lo * rate), float(c_hi * rate),
                      float(np.std(per_record, ddof=1)) if len(per_record) > 1 else 0.0,
                      float(pooled[k]), float(d_pooled[kd]), float(delays[kd]), gd)


def _settle(b: np.ndarray, a: np.ndarray, limit: int = 4096) -> int:
    """Samples until :data:`SETTLE_SHARE` of the filter's impulse response (absolute) is out."""
    from scipy.signal import lfilter

    h = np.abs(lfilter(b, a, np.r_[1.0, np.zeros(limit - 1)]))
    c = np.cumsum(h)
    return int(np.searchsorted(c, SETTLE_SHARE * c[-1])) + 1


def filtered(rec: Record, b: np.ndarray, a: np.ndarray, late: int) -> Record:
    """``rec`` with its force through the filter ``(b, a)`` (from rest, the force less its value
    before the blow) and the driven window widened by ``late`` samples (the filtered blow)."""
    from scipy.signal import lfilter

    if rec.force is None:
        return rec
    base = float(np.median(rec.force[:rec.impact_start])) if rec.impact_start > 0 else 0.0
    force = lfilter(b, a, rec.force - base) + base
    if not rec.impact_end > rec.impact_start:
        return rec.replace(force=force)
    free = min(rec.free_stop - 1, rec.free_start + late)
    return rec.replace(force=force, impact_end=min(free, rec.impact_end + late), free_start=free)


def lowpass_candidate(records: Sequence[Record], setup: Setup, parts: Sequence[Part],
                      fold_masks: Sequence[Sequence[np.ndarray]], base_fold: Sequence[float], f1: float,
                      refine: bool = False, mapper=None) -> tuple[Candidate, list[np.ndarray]] | None:
    """The ``sensor_lowpass`` candidate and its held-out simulations; None when no lag is claimed
    or no blow has a shape to fit (module notes)."""
    if record_lags(records, f1) is None:
        return None
    fit = fit_lowpass(records, f1)
    if fit is None:
        return None
    rate = records[0].rate_hz
    b, a = filter_ba(fit.kind, fit.order, fit.corner_hz, rate)
    late = _settle(b, a)
    al = [filtered(r, b, a, late) for r in records]
    params = {"bessel": float(fit.kind == "bessel"), "order": float(fit.order), "corner_hz": fit.corner_hz, "corner_lo_hz": fit.corner_lo_hz,
              "corner_hi_hz": fit.corner_hi_hz, "group_delay_samples": fit.group_delay_samples,
              "shape_share": fit.shape_share, "delay_samples": fit.delay_samples}
    spread = {"corner_hz": fit.corner_spread_hz}
    contradicted = "" if fit.shape_share <= SHAPE_SHARE else (
        f"over the blow a pure delay ({fit.delay_samples:.1f} samples) fits the response as well as the "
        f"low-pass (residual {fit.shape_share:.2f} of the delay's, needs {SHAPE_SHARE:g}): the records show a "
        "lag, not a filter's shape")
    symptom = (f"is driven by the force as the structure received it, while the acceleration's channel "
               f"low-passes it ({fit.kind.capitalize()} order {fit.order}, corner {fit.corner_hz:.4g} Hz, group delay "
               f"{fit.group_delay_samples:.1f} samples): the blow is delayed and rounded; the force through "
               "the fitted filter fixes it")
    consistent = bool(fit.corner_spread_hz < 0.5 * fit.corner_hz)
    return refitted_candidate(NAME, records, al, setup, parts, fold_masks, base_fold, refine, mapper,
                              consistent, params, spread, symptom, "filtered forces", contradicted)


def over_delay(low: Candidate, lag: Candidate | None, floor_nrmse: float) -> Candidate:
    """``low`` contradicted when the alignment alone (``lag``) reproduces the held-out parts within
    ``floor_nrmse`` (the floor of the data) of it: the low-pass's shape then earns nothing the
    records can tell over the lag, which is the simpler cause (module notes)."""
    from dataclasses import replace

    if low.contradicted or lag is None or lag.skipped or not math.isfinite(lag.nrmse):
        return low
    if lag.nrmse - low.nrmse > floor_nrmse:
        return low
    how = "as well or better" if lag.nrmse <= low.nrmse else "within the floor of the data of it"
    return replace(low, contradicted=(
        f"the force aligned by the lag alone reproduces the held-out parts {how} ({lag.nrmse:.3g} against "
        f"{low.nrmse:.3g}, floor {floor_nrmse:.3g}): the filter's shape is not resolved beyond its delay"
        + (" (a delay commutes with a nonlinear structure, a low-pass does not)" if lag.nrmse < low.nrmse else "")))


def kind_of(params: dict[str, float]) -> str:
    """The filter's kind from a candidate's parameters."""
    return "bessel" if params.get("bessel", 0.0) else "butterworth"


def ba_of(params: dict[str, float], rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """The fitted filter ``(b, a)`` from a candidate's parameters."""
    return filter_ba(kind_of(params), int(params["order"]), params["corner_hz"], rate_hz)


def correction_note(c: Candidate) -> str:
    """The correction's figures in one sentence (for the diagnosis' notes)."""
    p = c.params
    if c.skipped or not math.isfinite(c.nrmse):
        return f"{NAME}: not measured ({c.skipped or 'no held-out part could be simulated'})"
    return (f"{NAME}: the force through a {kind_of(p).capitalize()} low-pass of order {p['order']:.0f}, corner "
            f"{p['corner_hz']:.4g} Hz ({p['corner_lo_hz']:.4g}-{p['corner_hi_hz']:.4g} Hz, spread "
            f"{c.spread.get('corner_hz', 0.0):.3g} Hz over the records; group delay "
            f"{p['group_delay_samples']:.2f} samples), fitted over the blows (residual {p['shape_share']:.2f} of a "
            f"pure delay's), and the baseline refitted: held-out nrmse {c.reference_nrmse:.3g} -> {c.nrmse:.3g} "
            f"({abs(100 * c.gain):.0f} % {'less' if c.gain >= 0 else 'more'}), per part "
            + ", ".join(f"{v:.3g}" for v in c.fold_nrmse)
            + (f"; not named: {c.contradicted}" if c.contradicted else ""))
