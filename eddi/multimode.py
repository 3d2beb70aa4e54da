"""Several modes from one measured coordinate: separate, identify each with EDDI, recombine.

The EDDI method identifies single-degree-of-freedom oscillators. The paper's suggested route
to several degrees of freedom (Sec. 4) is to separate the modes, identify each with EDDI and
recombine. This module does that for free-decay (ring-down) records of one velocity channel:

1. **Calculus on the raw record.** Displacement and acceleration are derived from the measured
   velocity with high-order stencils (4th-order cumulative integration, 6th-order central
   difference) so that, at the modal frequencies, ``x``, ``v`` and ``a`` satisfy ``v = x'`` and
   ``a = v'`` to better than 1e-4 (a trapezoid would bias the identified frequency by
   ``(omega dt)^2 / 24``, 0.1 % at 122 Hz and 5120 Hz).
2. **Separation.** The same zero-phase Butterworth band-pass (``scipy.signal.sosfiltfilt``) is
   applied to ``x``, ``v`` and ``a`` of each mode's band. A linear zero-phase filter commutes
   with differentiation, so the modal ``x_k, v_k, a_k`` stay consistent, and it removes the
   integration drift. Filtering smears the record's ends, so identification drops the first
   and last ``trim_s`` seconds.
3. **Per-mode EDDI, stacked over records.** Phase one (paper Eqs. 7-11) writes, for each
   record and each zero crossing ``gamma_i`` of ``x_k``, the energy balance
   ``sum_j b_j int_{gamma_0}^{gamma_i} v B_j dt = T(gamma_0) - T(gamma_i)`` (unit mass,
   ``T = v^2 / 2``); rows of all records are stacked (each record's rows divided by its
   ``T(gamma_0)`` so every record weighs the same) and solved by least squares. Phase two
   (paper Eq. 16): with ``L = 2T - E`` and ``E' = -v B``, ``dL/dq - p q''/q'`` reduces
   analytically to ``a + B(x, v)``, the negative conservative force, so the conservative force
   ``K(x) = -a - B(x, v)`` is evaluated sample by sample (no division by ``v``, which the paper
   notes is noise-prone) and the stiffness library is fitted to it by least squares.
4. **Recombination.** The model's velocity is the sum of the modal velocities; each mode is an
   :class:`~eddi.model.EquationOfMotion` per unit mass simulated by :func:`eddi.simulate.simulate`.
5. **Initial state.** Prediction "from the measured initial state" needs every mode's
   ``(x_k, v_k)`` at the start. A zero-phase filter uses samples after ``t0``, so instead the
   modal states are fitted (nonlinear least squares) to the first ``initial_window_s`` seconds
   of the raw velocity after ``t0``: information from that short window only, as a delay
   embedding of the same length would use.

No I/O, no threads: arrays in, frozen results out.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError, model_validator
from scipy import interpolate, optimize, signal

from eddi.calculus import differentiate, integrate
from eddi.errors import IdentificationError, ModelError, SignalError
from eddi.model import EquationOfMotion, json_object
from eddi.simulate import simulate
from eddi.terms import parse_term

MODAL_SUM_SCHEMA_VERSION = 1

#: Default damping library per mode: viscous plus amplitude-proportional (joint micro-slip)
#: loss; ``abs(v)*v`` makes the loss per cycle grow like amplitude cubed.
MODAL_DAMPING: tuple[str, ...] = ("v", "abs(v)*v")
#: Default stiffness library per mode: linear plus ``abs(x)*x``, a frequency shift that is
#: linear in amplitude (softening when negative), as a frictional joint shows.
MODAL_STIFFNESS: tuple[str, ...] = ("x", "abs(x)*x")


class ModalSumModel(BaseModel):
    """Measured velocity = sum of modal velocities, each mode an EDDI equation per unit mass.

    Attributes
    ----------
    kind : "modal_sum"
        Tag telling this model from a single :class:`~eddi.model.EquationOfMotion` in JSON.
    modes : tuple of EquationOfMotion
        One single-coordinate equation per mode, ``mass = 1`` (per unit modal mass).
    bands_hz : tuple of (float, float)
        Pass band used to separate each mode [Hz], same order as ``modes``.
    filter_order : int
        Butterworth order of the separation band-pass (applied forward and backward).
    initial_window_s : float
        Length of raw record after ``t0`` used to estimate the modal initial states [s].
    observable : str
        What the summed coordinate rate is, for people.
    notes : str
        Where the model came from.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    kind: Literal["modal_sum"] = "modal_sum"
    schema_version: int = MODAL_SUM_SCHEMA_VERSION
    modes: tuple[EquationOfMotion, ...]
    bands_hz: tuple[tuple[float, float], ...]
    filter_order: int = 8
    initial_window_s: float = 0.02
    observable: str = "velocity [m/s]"
    notes: str = ""

    @model_validator(mode="after")
    def _check(self) -> "ModalSumModel":
        if not self.modes:
            raise ValueError("a modal-sum model needs at least one mode")
        if len(self.bands_hz) != len(self.modes):
            raise ValueError(
                f"expected one band per mode ({len(self.modes)}), got {len(self.bands_hz)}"
            )
        for lo, hi in self.bands_hz:
            if not (0 <= lo < hi):
                raise ValueError(f"band ({lo}, {hi}) Hz must satisfy 0 <= low < high")
        if self.schema_version != MODAL_SUM_SCHEMA_VERSION:
            raise ValueError(
                f"schema_version {self.schema_version} is not supported "
                f"(expected {MODAL_SUM_SCHEMA_VERSION})"
            )
        if self.filter_order < 1 or not self.initial_window_s > 0:
            raise ValueError("filter_order must be >= 1 and initial_window_s > 0")
        return self

    @classmethod
    def from_json(cls, text: str) -> "ModalSumModel":
        """Load from JSON text, raising :class:`ModelError` (one line) when invalid."""
        data = json_object(text)
        try:
            return cls(**data)
        except ValidationError as exc:
            err = exc.errors()[0]
            where = ".".join(str(p) for p in err.get("loc", ()))
            msg = str(err.get("msg", "invalid")).removeprefix("Value error, ")
            raise ModelError(f"invalid modal-sum model: {where + ': ' if where else ''}{msg}") from None

    def to_json(self, indent: int | None = 2) -> str:
        """Serialise to JSON text (``"kind": "modal_sum"``)."""
        return self.model_dump_json(indent=indent)

    def natural_frequencies_hz(self) -> np.ndarray:
        """Small-amplitude natural frequency of each mode [Hz], shape (n_modes,)."""
        return np.array(
            [math.sqrt(max(m.linear_stiffness(), 0.0) / m.mass) / (2 * math.pi) for m in self.modes]
        )

    def damping_ratios(self) -> np.ndarray:
        """Small-amplitude (viscous ``v`` term) damping ratio of each mode, shape (n_modes,)."""
        out = []
        for m in self.modes:
            w = math.sqrt(max(m.linear_stiffness(), 0.0) / m.mass)
            b = sum(float(c) for text, c in m.damping.items()
                    if parse_term(text).exponents == (0, 1, 0, 0, 0, 0))
            out.append(b / (2.0 * m.mass * w) if w > 0 else math.nan)
        return np.array(out)

    def to_dict(self) -> dict[str, Any]:
        """A plain dict (JSON-ready), the same content as :meth:`to_json`."""
        return json.loads(self.model_dump_json())

    def equation_text(self) -> str:
        """One equation per mode, for people: ``v = sum_k v_k`` and each mode's equation."""
        f = self.natural_frequencies_hz()
        parts = [f"v = sum of {len(self.modes)} modal velocities;"]
        for k, (m, fk) in enumerate(zip(self.modes, f)):
            lo, hi = self.bands_hz[k]
            text = m.equation_text().replace(" = F(t)", " = 0")
            parts.append(f"mode {k + 1} ({fk:.5g} Hz, band {lo:.4g}-{hi:.4g} Hz): {text}")
        return " ".join(parts[:1]) + " " + "; ".join(parts[1:])


def load_any_model(text: str) -> EquationOfMotion | ModalSumModel:
    """Load either a single equation of motion or a modal-sum model from JSON text.

    A JSON object with ``"kind": "modal_sum"`` is a :class:`ModalSumModel`; anything else is
    read as an :class:`~eddi.model.EquationOfMotion` (also inside ``"equation_of_motion"``).

    Raises
    ------
    ModelError
        If the text is not JSON or not a valid model of either kind.
    """
    data = json_object(text)
    if data.get("kind") == "modal_sum":
        return ModalSumModel.from_json(text)
    if data.get("kind") == "mdof":  # schema version 2: several coordinates (eddi.mdof.model)
        from eddi.mdof.model import MdofModel

        return MdofModel.from_json(text)  # type: ignore[return-value]
    return EquationOfMotion.from_json(text)



# -- calculus and separation ------------------------------------------------------------------


def _check_signal(t: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    t = np.asarray(t, dtype=float)
    v = np.asarray(v, dtype=float)
    if t.ndim != 1 or v.shape != t.shape:
        raise SignalError(f"t and v must be 1-D of the same length, got {t.shape} and {v.shape}")
    if t.size < 64:
        raise SignalError(f"record too short: expected at least 64 samples, got {t.size}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
        raise SignalError("t or v contains NaN or infinite values")
    dt = float((t[-1] - t[0]) / (t.size - 1))
    # times printed with few decimals jitter step by step; what must hold is that every
    # sample sits on the uniform grid (within 1 % of a step)
    grid = t[0] + dt * np.arange(t.size)
    if not dt > 0 or np.any(np.diff(t) <= 0) or np.max(np.abs(t - grid)) > 0.01 * dt:
        raise SignalError(
            f"time must be uniform and increasing: expected samples on a {dt:g} s grid within 1 % of a step"
        )
    return grid, v, dt


def _ar_predict(seed: np.ndarray, n: int, order: int, fit: np.ndarray) -> np.ndarray:
    """Continue ``seed`` forward by ``n`` samples with an AR model fitted on ``fit``."""
    p = int(min(order, max(1, fit.size // 4)))
    rows = np.lib.stride_tricks.sliding_window_view(fit, p + 1)
    coef, *_ = np.linalg.lstsq(rows[:, :p], rows[:, p], rcond=None)
    # keep the extension from growing: reflect unstable poles inside the unit circle
    roots = np.roots(np.concatenate(([1.0], -coef[::-1])))
    big = np.abs(roots) > 1.0
    if np.any(big):
        roots[big] = 1.0 / np.conj(roots[big])
        coef = -np.real(np.poly(roots))[1:][::-1]
    out = np.empty(n + p)
    out[:p] = seed[-p:]
    for i in range(n):
        out[p + i] = out[i : p + i] @ coef
    return out[p:]


def _ar_extend(v: np.ndarray, n_pad: int, order: int) -> np.ndarray:
    """``v`` with ``n_pad`` samples of linear prediction before and after, shape (n + 2 n_pad,)."""
    if n_pad <= 0:
        return v.copy()
    m = int(min(v.size, max(8 * order, v.size // 30)))
    head = _ar_predict(v[:m][::-1], n_pad, order, v[:m][::-1])[::-1]
    tail = _ar_predict(v[-m:], n_pad, order, v[-m:])
    return np.concatenate((head, v, tail))


def _band_filter(band_hz: Sequence[float], fs: float, order: int) -> np.ndarray:
    """Second-order sections of the Butterworth band-pass (low-pass when ``low == 0``).

    Cached: diagnosis designs the same few filters hundreds of times (2.2 s of a 19 s run).
    The array is shared: callers must not change it (SciPy's filters only read it, but
    need it writeable)."""
    return _butter_sos(float(band_hz[0]), float(band_hz[1]), float(fs), int(order))


@functools.lru_cache(maxsize=256)
def _butter_sos(lo: float, hi: float, fs: float, order: int) -> np.ndarray:
    if lo > 0:
        sos = signal.butter(order, [lo, hi], btype="bandpass", fs=fs, output="sos")
    else:
        sos = signal.butter(order, hi, btype="lowpass", fs=fs, output="sos")
    return sos


def _zero_phase(sos: np.ndarray, y: np.ndarray, pad: int = 256, ar_order: int = 30) -> np.ndarray:
    """Forward-backward filtering with linear-prediction padding at both ends."""
    n_pad = min(pad, y.size)
    return signal.sosfiltfilt(sos, _ar_extend(y, n_pad, ar_order))[n_pad : n_pad + y.size]


@dataclass(frozen=True)
class ModalComponents:
    """Separated modal states of one record.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
    x, v, a : ndarray, shape (n_modes, n)
        Modal displacement [m], velocity [m/s] and acceleration [m/s^2] (units of the input).
    bands_hz : tuple of (float, float)
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    bands_hz: tuple[tuple[float, float], ...]


def separate_modes(
    t: np.ndarray,
    v: np.ndarray,
    bands_hz: Sequence[tuple[float, float]],
    *,
    filter_order: int = 8,
    pad_s: float = 0.5,
    ar_order: int = 30,
) -> ModalComponents:
    """Split a velocity record into modal components with zero-phase band-passes.

    A band-pass run over a record that starts at full amplitude rings at the ends (its
    transient biases the energy at the first crossings by several times the energy lost per
    cycle of a lightly damped mode). The record is therefore extended at both ends by
    ``pad_s`` of linear prediction (an autoregressive model of order ``ar_order`` fitted by
    least squares to the first / last 0.1 s; a sum of damped sinusoids is exactly
    autoregressive) before filtering, and the extension is cut off afterwards.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Uniform time base.
    v : ndarray, shape (n,), [m/s]
        Measured velocity.
    bands_hz : sequence of (low, high)
        Pass band of each mode [Hz]; ``low = 0`` means a low-pass.
    filter_order : int
        Butterworth order (doubled by the forward-backward pass).
    pad_s : float
        Linear-prediction extension at each end [s].
    ar_order : int
        Order of the autoregressive model used for the extension.

    Returns
    -------
    ModalComponents
    """
    return _separate(t, v, bands_hz, filter_order, pad_s, ar_order, None)


def _separate(t: np.ndarray, v: np.ndarray, bands_hz: Sequence[tuple[float, float]], filter_order: int,
              pad_s: float, ar_order: int, cache: dict | None) -> ModalComponents:
    """:func:`separate_modes`; with ``cache`` (a dict the caller keeps while ``v`` lives), the
    padded record and each band's components are made once per record (diagnosis separates
    the same records in every fold)."""
    key = (id(v), v.size, float(pad_s), int(ar_order))
    prep = cache.get(key) if cache is not None else None
    if prep is None:
        t, v, dt = _check_signal(t, v)
        fs = 1.0 / dt
        n = v.size
        n_pad = min(n, int(round(pad_s * fs)))
        vp = _ar_extend(v, n_pad, ar_order)
        x_raw = signal.detrend(integrate(vp, dt), type="linear")
        a_raw = differentiate(vp, dt)
        prep = (t, fs, vp, x_raw, a_raw, slice(n_pad, n_pad + n))
        if cache is not None:
            cache[key] = prep
    t, fs, vp, x_raw, a_raw, keep = prep
    xs, vs, as_ = [], [], []
    for lo, hi in bands_hz:
        if not (0 <= lo < hi < fs / 2):
            raise SignalError(f"band ({lo}, {hi}) Hz must satisfy 0 <= low < high < {fs / 2:.1f}")
        bkey = key + (float(lo), float(hi), int(filter_order))
        got = cache.get(bkey) if cache is not None else None
        if got is None:
            sos = _band_filter((lo, hi), fs, filter_order)
            got = (signal.sosfiltfilt(sos, x_raw)[keep], signal.sosfiltfilt(sos, vp)[keep],
                   signal.sosfiltfilt(sos, a_raw)[keep])
            if cache is not None:
                cache[bkey] = got
        xs.append(got[0])
        vs.append(got[1])
        as_.append(got[2])
    return ModalComponents(
        t=t, x=np.array(xs), v=np.array(vs), a=np.array(as_),
        bands_hz=tuple((float(lo), float(hi)) for lo, hi in bands_hz),
    )


def suggest_bands(
    t: np.ndarray, v: np.ndarray, n_modes: int, *, min_ratio: float = 1.2,
    min_power_ratio: float = 1e-4,
) -> tuple[tuple[float, float], ...]:
    """Separation bands around the ``n_modes`` strongest spectral peaks of a record.

    Peaks of the Welch spectrum closer than a frequency ratio ``min_ratio`` count as one;
    peaks below ``min_power_ratio`` times the largest are ignored.
    Neighbouring bands meet at the geometric mean of their peaks; the outer edges sit at a
    third below the lowest peak and 60 % above the highest (below 0.45 of the sample rate).

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    v : ndarray, shape (n,)
    n_modes : int
    min_ratio : float
    min_power_ratio : float

    Returns
    -------
    tuple of (low, high), [Hz], sorted by frequency

    Raises
    ------
    SignalError
        If fewer than ``n_modes`` separate peaks are found.
    """
    t, v, dt = _check_signal(t, v)
    return suggest_bands_many([(t, v)], n_modes, min_ratio=min_ratio,
                              min_power_ratio=min_power_ratio)


def welch_sum(records: Sequence[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """Sum over records of each record's Welch spectrum normalised to unit total power.

    Parameters
    ----------
    records : sequence of (t, v)
        Uniform records of the same sample rate (lengths may differ).

    Returns
    -------
    freqs_hz : ndarray, shape (m,)
    power : ndarray, shape (m,)
        Dimensionless (each record weighs the same).
    """
    if not records:
        raise SignalError("expected at least one record, got none")
    nper = min(4096, min(np.asarray(v).size for _t, v in records))
    freqs = None
    total = None
    for t, v in records:
        t, v, dt = _check_signal(t, v)
        f, p = signal.welch(v, fs=1.0 / dt, nperseg=nper)
        s = float(np.sum(p))
        p = p / s if s > 0 else p
        if total is None:
            freqs, total = f, p
        elif p.shape != total.shape:
            raise SignalError("records have different sample rates; resample them first")
        else:
            total = total + p
    assert freqs is not None and total is not None
    return freqs, total


def suggest_bands_many(
    records: Sequence[tuple[np.ndarray, np.ndarray]], n_modes: int, *, min_ratio: float = 1.2,
    min_power_ratio: float = 1e-4,
) -> tuple[tuple[float, float], ...]:
    """:func:`suggest_bands` on the summed spectra of several records (:func:`welch_sum`).

    Raises
    ------
    SignalError
        If fewer than ``n_modes`` separate peaks are found.
    """
    freqs, power = welch_sum(records)
    fs = 2.0 * float(freqs[-1])
    peaks, _ = signal.find_peaks(power, height=min_power_ratio * float(np.max(power)))
    peaks = peaks[freqs[peaks] > 0]
    chosen: list[float] = []
    for i in peaks[np.argsort(power[peaks])[::-1]]:
        f = float(freqs[i])
        if all(max(f, c) / min(f, c) >= min_ratio for c in chosen):
            chosen.append(f)
        if len(chosen) == n_modes:
            break
    if len(chosen) < n_modes:
        raise SignalError(
            f"expected {n_modes} separate spectral peaks (ratio >= {min_ratio}), found {len(chosen)}"
        )
    chosen.sort()
    edges = [chosen[0] / 1.5]
    edges += [math.sqrt(a * b) for a, b in zip(chosen[:-1], chosen[1:])]
    edges.append(min(chosen[-1] * 1.6, 0.45 * fs))
    return tuple((float(lo), float(hi)) for lo, hi in zip(edges[:-1], edges[1:]))


# -- per-mode EDDI, stacked over records ------------------------------------------------------


@dataclass(frozen=True)
class ModeFit:
    """What the identification of one mode used and found.

    Attributes
    ----------
    eom : EquationOfMotion
        The mode's equation (unit mass).
    n_crossings : int
        Zero crossings used by phase one (all records).
    n_samples : int
        Samples used by phase two (all records).
    phase_one_residual : float
        RMS of the phase-one least-squares residual relative to the RMS right-hand side.
    phase_two_residual : float
        Same for phase two.
    """

    eom: EquationOfMotion
    n_crossings: int
    n_samples: int
    phase_one_residual: float
    phase_two_residual: float


def _zero_crossings(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Times where ``x`` changes sign (linear interpolation), shape (m,), [s]."""
    s = np.signbit(x)
    idx = np.nonzero(s[:-1] != s[1:])[0]
    x0, x1 = x[idx], x[idx + 1]
    frac = x0 / (x0 - x1)
    return t[idx] + frac * (t[idx + 1] - t[idx])


def _usable_span(v_mode: np.ndarray, dt: float, trim_s: float, floor_ratio: float) -> slice:
    """Samples after the filter's edge zone and before the mode sinks under ``floor_ratio``."""
    n = v_mode.size
    trim = int(round(trim_s / dt))
    env = np.abs(signal.hilbert(v_mode))
    peak = float(np.max(env[trim : n - trim])) if n > 2 * trim + 8 else 0.0
    if peak <= 0:
        return slice(0, 0)
    above = np.nonzero(env[trim : n - trim] >= floor_ratio * peak)[0]
    stop = trim + int(above[-1]) + 1 if above.size else trim
    return slice(trim, stop)


def identify_modes(
    records: Sequence[tuple[np.ndarray, np.ndarray]],
    bands_hz: Sequence[tuple[float, float]],
    *,
    damping: Sequence[str] = MODAL_DAMPING,
    stiffness: Sequence[str] = MODAL_STIFFNESS,
    filter_order: int = 8,
    trim_s: float = 0.05,
    floor_ratio: float = 0.02,
    initial_window_s: float = 0.02,
    notes: str = "",
    cache: dict | None = None,
) -> tuple[ModalSumModel, tuple[ModeFit, ...]]:
    """Identify a modal-sum model from one or more velocity ring-downs (per unit mass).

    Parameters
    ----------
    records : sequence of (t, v)
        Free-decay records, ``t`` [s] uniform, ``v`` [m/s]; the whole record is used
        (minus ``trim_s`` at each end), so it should start at or after the impact.
    bands_hz : sequence of (low, high)
        One separation band per mode [Hz]. One wide band gives a single-mode EDDI model.
    damping, stiffness : sequence of str
        Term libraries for every mode (see :mod:`eddi.terms`).
    filter_order : int
        Butterworth order of the band-passes.
    trim_s : float
        Seconds dropped at both ends of each separated component (filter edge effects) [s].
    floor_ratio : float
        A mode is used until its envelope falls below this fraction of its maximum (noise).
    initial_window_s : float
        Stored in the model: window used later to estimate initial states [s].
    notes : str
        Stored in the model.
    cache : dict, optional
        Kept by a caller that identifies from the same records many times (diagnosis folds):
        each record's separated components and filtered term columns are made once. Keyed
        by the identity of each ``v`` array, so the caller must keep them alive and unchanged.

    Returns
    -------
    model : ModalSumModel
    fits : tuple of ModeFit
        One per mode.

    Raises
    ------
    IdentificationError
        If a mode has too few zero crossings or a least-squares system is singular.
    """
    if not records:
        raise IdentificationError("expected at least one record, got none")
    d_terms = [parse_term(s) for s in damping]
    k_terms = [parse_term(s) for s in stiffness]
    comps = [_separate(t, v, bands_hz, filter_order, 0.5, 30, cache) for t, v in records]
    modes, fits = [], []
    for k in range(len(bands_hz)):
        q_rows, r_rows, spans = [], [], []
        for ri, c in enumerate(comps):
            rkey = ("phase-one rows", id(records[ri][1]), tuple(bands_hz[k]), filter_order, tuple(damping),
                    trim_s, floor_ratio)
            got = cache.get(rkey) if cache is not None else None
            if got is None:  # the component's span and energy rows: once per record and band
                got = _phase_one_rows(c, k, d_terms, trim_s, floor_ratio)
                if cache is not None:
                    cache[rkey] = got
            span, rows = got
            spans.append(span)
            if rows is not None:
                q_rows.append(rows[0])
                r_rows.append(rows[1])
        if not q_rows:
            raise IdentificationError(
                f"mode {k + 1} (band {bands_hz[k]} Hz): expected at least 4 zero crossings "
                "in some record, found fewer"
            )
        q = np.vstack(q_rows)
        r = np.concatenate(r_rows)
        b, res1 = _lstsq(q, r, f"mode {k + 1} phase one")
        # phase two: K(x) = -a - B(x, v), sample by sample, all records stacked. The band-pass
        # removed the harmonics the nonlinear terms generate from x, v and a; the same filter
        # is applied to every term's values so target and columns see the same band
        # (otherwise an abs(x)*x coefficient comes out ~20 % low, see tests).
        phi_rows, kf_rows = [], []
        for ri, (c, span) in enumerate(zip(comps, spans)):
            if span.stop - span.start < 16:
                continue
            band = _band_filter(bands_hz[k], 1.0 / float(c.t[1] - c.t[0]), filter_order)
            xf, vf = c.x[k], c.v[k]
            damp = sum((bj * term(xf, vf) for bj, term in zip(b, d_terms)), np.zeros_like(xf))
            kf = (-c.a[k] - _zero_phase(band, damp))[span]
            ckey = ("phase-two columns", id(records[ri][1]), tuple(bands_hz[k]), filter_order,
                    tuple(stiffness)) if cache is not None else None
            full = cache.get(ckey) if cache is not None else None
            if full is None:  # depends on the component only: made once per record and band
                full = np.column_stack([_zero_phase(band, term(xf, vf)) for term in k_terms])
                if cache is not None:
                    cache[ckey] = full
            cols = full[span]
            # weigh each record by its amplitude so large records do not dominate
            wgt = 1.0 / max(float(np.sqrt(np.mean(kf**2))), 1e-300)
            phi_rows.append(cols * wgt)
            kf_rows.append(kf * wgt)
        kcoef, res2 = _lstsq(np.vstack(phi_rows), np.concatenate(kf_rows), f"mode {k + 1} phase two")
        eom = EquationOfMotion.create(
            mass=1.0,
            damping={s: float(c_) for s, c_ in zip(damping, b)},
            stiffness={s: float(c_) for s, c_ in zip(stiffness, kcoef)},
            coordinate="modal displacement per unit modal mass [m]",
            notes=f"mode {k + 1}, band {bands_hz[k][0]:g}-{bands_hz[k][1]:g} Hz, EDDI stacked over "
            f"{len(records)} record(s)",
        )
        modes.append(eom)
        fits.append(ModeFit(eom, int(r.size), int(sum(p.shape[0] for p in phi_rows)), res1, res2))
    model = ModalSumModel(
        modes=tuple(modes),
        bands_hz=tuple((float(lo), float(hi)) for lo, hi in bands_hz),
        filter_order=filter_order,
        initial_window_s=initial_window_s,
        notes=notes,
    )
    return model, tuple(fits)


def _phase_one_rows(c: ModalComponents, k: int, d_terms: Sequence[Any], trim_s: float, floor_ratio: float
                    ) -> tuple[slice, tuple[np.ndarray, np.ndarray] | None]:
    """Usable span of mode ``k`` of a record and its phase-one rows (None when too short)."""
    dt = float(c.t[1] - c.t[0])
    span = _usable_span(c.v[k], dt, trim_s, floor_ratio)
    t_k, x_k, v_k = c.t[span], c.x[k][span], c.v[k][span]
    if t_k.size < 16:
        return span, None
    gam = _zero_crossings(t_k, x_k)
    if gam.size < 4:
        return span, None
    # cubic splines: linear interpolation of v at its peak (x = 0) under-reads T by
    # ~(omega dt)^2 / 4, which is comparable to the energy lost per cycle here
    t_energy = 0.5 * interpolate.CubicSpline(t_k, v_k)(gam) ** 2
    cols = []
    for term in d_terms:
        w = interpolate.CubicSpline(t_k, v_k * term(x_k, v_k)).antiderivative()
        wg = w(gam)
        cols.append(wg[1:] - wg[0])
    scale = t_energy[0] if t_energy[0] > 0 else 1.0
    return span, (np.column_stack(cols) / scale, (t_energy[0] - t_energy[1:]) / scale)


def _lstsq(a: np.ndarray, b: np.ndarray, what: str) -> tuple[np.ndarray, float]:
    if a.shape[0] < a.shape[1]:
        raise IdentificationError(f"{what}: expected at least {a.shape[1]} equations, got {a.shape[0]}")
    # scale columns so the condition number reflects the problem, not the units
    norms = np.linalg.norm(a, axis=0)
    if np.any(norms == 0):
        raise IdentificationError(f"{what}: a candidate term is identically zero on the data")
    coef, _res, rank, _sv = np.linalg.lstsq(a / norms, b, rcond=None)
    if rank < a.shape[1]:
        raise IdentificationError(f"{what}: the least-squares system is singular (rank {rank})")
    coef = coef / norms
    rel = float(np.sqrt(np.mean((a @ coef - b) ** 2)) / max(np.sqrt(np.mean(b**2)), 1e-300))
    return coef, rel


# -- simulation and prediction ----------------------------------------------------------------


@dataclass(frozen=True)
class ModalSimulation:
    """Simulated modal-sum response.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
    v : ndarray, shape (n,)
        Summed velocity (the observable).
    x_modes, v_modes : ndarray, shape (n_modes, n)
        Each mode's coordinate and rate.
    diverged : bool
        True when any mode blew up.
    """

    t: np.ndarray
    v: np.ndarray
    x_modes: np.ndarray
    v_modes: np.ndarray
    diverged: bool


def simulate_modal(
    model: ModalSumModel, t: np.ndarray, initial_states: np.ndarray
) -> ModalSimulation:
    """Free response of every mode from its initial state, summed.

    Parameters
    ----------
    model : ModalSumModel
    t : ndarray, shape (n,), [s]
        Uniform output times; ``t[0]`` is where the initial states hold.
    initial_states : ndarray, shape (n_modes, 2)
        ``(x_k, v_k)`` of each mode at ``t[0]``.

    Returns
    -------
    ModalSimulation
    """
    init = np.asarray(initial_states, dtype=float)
    if init.shape != (len(model.modes), 2):
        raise SignalError(
            f"initial_states must have shape ({len(model.modes)}, 2), got {init.shape}"
        )
    xs, vs, div = [], [], False
    for eom, (x0, v0) in zip(model.modes, init):
        res = simulate(eom, t, x0=float(x0), v0=float(v0))
        xs.append(res.x)
        vs.append(res.v)
        div = div or res.diverged
    v_modes = np.array(vs)
    return ModalSimulation(
        t=np.asarray(t, dtype=float), v=v_modes.sum(axis=0), x_modes=np.array(xs),
        v_modes=v_modes, diverged=div,
    )


def estimate_initial_states(
    model: ModalSumModel, t: np.ndarray, v: np.ndarray, window_s: float | None = None
) -> np.ndarray:
    """Modal states at ``t[0]`` that best explain the first ``window_s`` of the velocity.

    Only samples in ``[t[0], t[0] + window_s]`` are used, so the estimate is available
    ``window_s`` after the start (no filter looks beyond it). Each mode's amplitude and phase
    are found by linear least squares on the modes' linear free responses, then refined by
    nonlinear least squares on the full model.

    Parameters
    ----------
    model : ModalSumModel
    t : ndarray, shape (n,), [s]
    v : ndarray, shape (n,), [m/s]
    window_s : float, optional
        Defaults to ``model.initial_window_s``.

    Returns
    -------
    ndarray, shape (n_modes, 2)
        ``(x_k, v_k)`` per mode at ``t[0]``.
    """
    t, v, dt = _check_signal(t, v)
    w = model.initial_window_s if window_s is None else float(window_s)
    n = min(t.size, max(8, int(round(w / dt)) + 1))
    tw, vw = t[:n], v[:n]
    n_modes = len(model.modes)
    # linear start: basis responses of each mode's linear part, from unit x0 and unit v0
    basis = []
    for eom in model.modes:
        lin = eom.model_copy(update={
            "damping": {k_: c for k_, c in eom.damping.items() if k_ == "v"},
            "stiffness": {k_: c for k_, c in eom.stiffness.items() if k_ == "x"},
            "effects": (),
        })
        basis.append(simulate(lin, tw, x0=1.0, v0=0.0).v)
        basis.append(simulate(lin, tw, x0=0.0, v0=1.0).v)
    p0, *_ = np.linalg.lstsq(np.column_stack(basis), vw, rcond=None)
    scale = np.array([[1.0 / max(math.sqrt(abs(m.linear_stiffness())), 1.0), 1.0] for m in model.modes])
    scale = scale * max(float(np.max(np.abs(vw))), 1e-300)

    big = 1e3 * max(float(np.max(np.abs(vw))), 1e-300)

    def resid(p: np.ndarray) -> np.ndarray:
        st = p.reshape(n_modes, 2) * scale
        r = simulate_modal(model, tw, st).v - vw
        return np.where(np.isfinite(r), r, big)

    z0 = (p0.reshape(n_modes, 2) / scale).ravel()
    sol = optimize.least_squares(resid, z0, method="lm", xtol=1e-10, ftol=1e-10)
    return sol.x.reshape(n_modes, 2) * scale


def impact_index(v: np.ndarray) -> int:
    """Index of the largest ``|v|``: where the free decay is taken to start.

    Parameters
    ----------
    v : ndarray, shape (n,)
    """
    v = np.asarray(v, dtype=float)
    if v.size == 0:
        raise SignalError("empty record")
    return int(np.argmax(np.abs(v)))


@dataclass(frozen=True)
class TrajectoryErrors:
    """Prediction errors of one record.

    Attributes
    ----------
    nmte : float
        ``mean_t |y_pred - y| / max_t |y|`` (Cenedese et al. 2022, ``computeTrajectoryErrors``).
    nrmse : float
        ``||y_pred - y||_2 / ||y||_2`` (the form :func:`eddi.validate.validate` uses).
    """

    nmte: float
    nrmse: float


def trajectory_errors(y_pred: np.ndarray, y: np.ndarray) -> TrajectoryErrors:
    """NMTE and NRMSE of a predicted trajectory against the measured one.

    Parameters
    ----------
    y_pred, y : ndarray, shape (n,)

    Returns
    -------
    TrajectoryErrors
    """
    y_pred = np.asarray(y_pred, dtype=float)
    y = np.asarray(y, dtype=float)
    if y_pred.shape != y.shape or y.size == 0:
        raise SignalError(f"expected two arrays of the same non-zero length, got {y_pred.shape} and {y.shape}")
    err = y_pred - y
    if not np.all(np.isfinite(err)):
        return TrajectoryErrors(nmte=math.inf, nrmse=math.inf)
    peak = float(np.max(np.abs(y)))
    norm = float(np.linalg.norm(y))
    return TrajectoryErrors(
        nmte=float(np.mean(np.abs(err)) / peak) if peak > 0 else math.inf,
        nrmse=float(np.linalg.norm(err) / norm) if norm > 0 else math.inf,
    )


@dataclass(frozen=True)
class Prediction:
    """A record predicted from its initial state.

    Attributes
    ----------
    start : int
        Index of the record where prediction starts (the impact).
    t : ndarray, shape (m,), [s]
    v_measured, v_predicted : ndarray, shape (m,)
    initial_states : ndarray, shape (n_modes, 2)
    errors : TrajectoryErrors
    simulation : ModalSimulation
    """

    start: int
    t: np.ndarray
    v_measured: np.ndarray
    v_predicted: np.ndarray
    initial_states: np.ndarray
    errors: TrajectoryErrors
    simulation: ModalSimulation


def predict_record(
    model: ModalSumModel, t: np.ndarray, v: np.ndarray, *, start: int | None = None,
    window_s: float | None = None,
) -> Prediction:
    """Predict a velocity record from its initial state and score it.

    Parameters
    ----------
    model : ModalSumModel
    t : ndarray, shape (n,), [s]
    v : ndarray, shape (n,), [m/s]
    start : int, optional
        First sample of the free decay (default: :func:`impact_index`).
    window_s : float, optional
        Initial-state window (default ``model.initial_window_s``).

    Returns
    -------
    Prediction
    """
    t, v, _dt = _check_signal(t, v)
    i0 = impact_index(v) if start is None else int(start)
    if not 0 <= i0 < t.size - 64:
        raise SignalError(f"start index must leave at least 64 samples, got {i0} of {t.size}")
    tt, vv = t[i0:], v[i0:]
    init = estimate_initial_states(model, tt, vv, window_s)
    sim = simulate_modal(model, tt, init)
    return Prediction(
        start=i0, t=tt, v_measured=vv, v_predicted=sim.v, initial_states=init,
        errors=trajectory_errors(sim.v, vv), simulation=sim,
    )


def as_modal_sum(eom: EquationOfMotion, band_hz: tuple[float, float]) -> ModalSumModel:
    """Wrap a single equation of motion as a one-mode modal-sum model (for prediction)."""
    return ModalSumModel(modes=(eom,), bands_hz=(band_hz,))


__all__ = [
    "MODAL_DAMPING",
    "MODAL_STIFFNESS",
    "ModalComponents",
    "ModalSimulation",
    "ModalSumModel",
    "ModeFit",
    "Prediction",
    "TrajectoryErrors",
    "as_modal_sum",
    "estimate_initial_states",
    "identify_modes",
    "impact_index",
    "load_any_model",
    "predict_record",
    "separate_modes",
    "simulate_modal",
    "suggest_bands",
    "suggest_bands_many",
    "trajectory_errors",
    "welch_sum",
]

