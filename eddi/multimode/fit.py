"""Per-mode EDDI over several free decays: phase one stacked over records, phase two by the conservative force."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import interpolate, signal

from eddi.errors import IdentificationError
from eddi.model import EquationOfMotion
from eddi.multimode.model import MODAL_DAMPING, MODAL_STIFFNESS, ModalSumModel
from eddi.multimode.separate import (
    ModalComponents,
    band_filter,
    separate_components,
    zero_phase,
)
from eddi.terms import parse_term


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
    comps = [separate_components(t, v, bands_hz, filter_order, 0.5, 30, cache) for t, v in records]
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
            band = band_filter(bands_hz[k], 1.0 / float(c.t[1] - c.t[0]), filter_order)
            xf, vf = c.x[k], c.v[k]
            damp = sum((bj * term(xf, vf) for bj, term in zip(b, d_terms)), np.zeros_like(xf))
            kf = (-c.a[k] - zero_phase(band, damp))[span]
            ckey = ("phase-two columns", id(records[ri][1]), tuple(bands_hz[k]), filter_order,
                    tuple(stiffness)) if cache is not None else None
            full = cache.get(ckey) if cache is not None else None
            if full is None:  # depends on the component only: made once per record and band
                full = np.column_stack([zero_phase(band, term(xf, vf)) for term in k_terms])
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
