"""Modes the low-amplitude tail no longer holds, and modal masses from the driving-point residue.

:func:`eddi.mdof.modal.era` reads the tail of the free decays, where the nonlinear terms are
small; a mode that decays faster than the others (a higher frequency, a larger damping ratio)
can be gone by then. :func:`era_windows` also reads windows that start earlier and adds such
a mode; :func:`residue_masses` gives every mode's modal mass from the measured force and the
driving-point residue at the start of the free response (session 7, issue 14 item 1).

No I/O: arrays in, frozen results out.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from eddi.errors import IdentificationError
from eddi.mdof.modal import LinearModes, era, mac, real_modes, significant, tail_segments


#: Envelope fractions of the earlier windows :func:`era_windows` also analyses (latest first).
EARLY_FRACTIONS = (0.35, 0.5, 0.7, 1.0)
#: A mode found only in an earlier window is added when it carries at least this share of that
#: window's modal fit (a weaker column there is too close to the gliding modes' leakage).
EARLY_MIN_SHARE = 0.01
#: An earlier window's mode is the same as a later one's within this relative frequency (a
#: nonlinear mode glides with amplitude) when their shapes also agree (MAC).
SAME_MODE_TOL, SAME_MODE_MAC = 0.08, 0.8


def era_windows(records: Sequence[tuple[np.ndarray, int, int]], rate_hz: float, *, tail_fraction: float = 0.2,
                early_fractions: Sequence[float] = EARLY_FRACTIONS, forces: Sequence[np.ndarray] | None = None,
                **kwargs) -> LinearModes:
    """ERA on the low-amplitude tail, plus the modes only an earlier window holds.

    A mode that decays faster than the others (a higher frequency, a larger damping ratio) can be
    gone from the tail. So when the tail resolves fewer modes than there are channels, ERA also
    runs (same stabilisation diagram, same rejection of cubic tones within each window) on
    windows that start earlier: the part of each record after its envelope falls below each of
    ``early_fractions`` of its peak (1.0: the whole free window), visited from the latest to the
    earliest. Every mode already kept is tracked from window to window (its frequency glides
    with amplitude): a window's mode within :data:`SAME_MODE_TOL` of a tracked mode's latest
    frequency with a shape MAC of at least :data:`SAME_MODE_MAC` is that mode, seen at a larger
    amplitude. A mode that matches none and carries at least :data:`EARLY_MIN_SHARE` of its
    window's modal fit is added, with the frequency, damping and shape of the latest window that
    holds it (the lowest amplitude at which it stands above the noise: the amplitude-dependent
    shift is smallest there), until there are as many modes as channels (the most a modal basis
    of the channels holds; an early window of a strongly nonlinear record shows gliding and
    combination columns that are not modes, and the tail alone decides whether the motion needs
    more modes than channels). The tail's modes, shares and ``unexplained`` are unchanged; an
    added mode's ``energy_share`` is its share of the tails (fitted jointly with the tail's
    modes), so a mode that has died out before the tail does not count as motion beyond the
    channels (:func:`eddi.mdof.identify.modal_evidence`).

    Parameters
    ----------
    records : sequence of (ndarray (n_channels, n), int, int)
        Each record's response (accelerations) and its free window ``[start, stop)``.
    rate_hz : float
    tail_fraction : float
        Envelope fraction that starts the tail.
    early_fractions : sequence of float
        Envelope fractions that start the earlier windows (each above ``tail_fraction``).
    forces : sequence of ndarray (n,), optional
        The force at the driving point of each record [N], zero outside the pulse: with it,
        every mode's ``modal_masses`` (:func:`residue_masses`).
    **kwargs
        Passed to :func:`era` (``max_freq_hz``, ``driving_point``, ...).
    """
    modes, added = _era_windows(records, rate_hz, tail_fraction, early_fractions, **kwargs)
    if forces is None:
        return modes
    masses, shapes, spread = residue_masses(modes, records, forces, rate_hz, int(kwargs.get("driving_point", 0)),
                                            early_shapes=added, spread=True)
    return replace(modes, modal_masses=masses, shapes=shapes, modal_mass_spread=spread)


def _era_windows(records: Sequence[tuple[np.ndarray, int, int]], rate_hz: float, tail_fraction: float,
                 early_fractions: Sequence[float], **kwargs) -> tuple[LinearModes, np.ndarray]:
    """:func:`era_windows` without the masses; also which modes were added from earlier windows."""
    tails, base, kwargs = _tail_modes(records, rate_hz, tail_fraction, kwargs)
    if base.pole_channels:  # one channel's earlier windows hold its mode gliding with amplitude, not new modes
        return base, np.zeros(base.frequencies_hz.size, bool)
    n_ch = base.shapes.shape[0]
    tracked = [(float(f), base.shapes[:, k]) for k, f in enumerate(base.frequencies_hz)]
    added: list[tuple[float, float, np.ndarray]] = []
    for frac in sorted(f for f in early_fractions if f > tail_fraction):
        if len(tracked) >= n_ch:
            break
        segs = [tail_segments(y, s, e, frac) for y, s, e in records]
        try:
            got = era(segs, rate_hz, **kwargs)
        except IdentificationError:
            continue
        for k in np.argsort(-got.energy_share):
            f, psi = float(got.frequencies_hz[k]), got.shapes[:, k]
            near = [j for j, (f0, p0) in enumerate(tracked)
                    if abs(f - f0) <= SAME_MODE_TOL * f0 and mac(psi, p0) >= SAME_MODE_MAC]
            if near:
                j = min(near, key=lambda j: abs(f - tracked[j][0]))
                tracked[j] = (f, psi)  # the same mode at a larger amplitude
            elif got.energy_share[k] >= EARLY_MIN_SHARE and len(tracked) < n_ch:
                tracked.append((f, psi))
                added.append((f, float(got.damping_ratios[k]), psi))
    if not added:
        return base, np.zeros(base.frequencies_hz.size, bool)
    out = _with_added(base, added, tails, rate_hz)
    return out, np.isin(out.frequencies_hz, [a[0] for a in added])


def _tail_modes(records: Sequence[tuple[np.ndarray, int, int]], rate_hz: float, tail_fraction: float,
                kwargs: dict) -> tuple[list[np.ndarray], LinearModes, dict]:
    """ERA on the tails: ``(tails, modes, kwargs)`` (``kwargs`` as used, for the earlier windows).

    A lightly damped record never decays to a tail long enough for ERA: then the whole free window
    is the lowest amplitude these records hold (session 9: 0.2 % damping, 2 s records). When
    neither finds a pole stable over the orders, the poles come from the driving-point channel
    alone (``pole_channels``; shapes still from every channel's residues): an essentially
    nonlinear attachment (the energy sink, no linear stiffness) has no linear mode, and its
    gliding, amplitude-dependent motion can leave no pole stable in a realisation of every
    channel (session 16, nes-5-6: the struck primary's mode at 15.6 Hz from its own channel;
    every channel together: no stable pole, exit 2). The struck mass carries the primary's mode.
    """
    last: IdentificationError | None = None
    for kw in (kwargs, {**kwargs, "pole_channels": (int(kwargs.get("driving_point", 0)),)}):
        for frac in (tail_fraction, 1.0):
            tails = [tail_segments(y, s, e, frac) for y, s, e in records]
            try:
                return tails, era(tails, rate_hz, **kw), kw
            except IdentificationError as exc:
                last = exc
        if records and records[0][0].shape[0] < 2:
            raise last
    raise IdentificationError(f"{last} - on every channel and on the driving-point channel alone")


#: Periods of the lowest mode over which :func:`residue_masses` fits the start of each free decay.
RESIDUE_PERIODS = 3.0


def residue_masses(modes: LinearModes, records: Sequence[tuple[np.ndarray, int, int]], forces: Sequence[np.ndarray],
                   rate_hz: float, driving_point: int, periods: float = RESIDUE_PERIODS,
                   early_shapes: np.ndarray | None = None, spread: bool = False) -> tuple[np.ndarray, ...]:
    """Modal mass of every mode [kg] (for its shape as given) from the driving-point residue.

    For a mode ``r`` with real shape ``psi_r`` and modal mass ``m_r``, a force ``F`` at the
    driving point ``d`` leaves, after the pulse, the acceleration
    ``a_d(t) = (psi_dr^2 / m_r) Im[lambda_r^2 Phi_r e^(lambda_r t)] / omega_dr`` with
    ``Phi_r = int F(tau) e^(-lambda_r tau) d tau`` (the pulse's Laplace transform at the pole).
    The residue ``R_r`` of ``a_d = Re[sum_r R_r e^(lambda_r (t - t_0))]`` is fitted by least
    squares (poles fixed, every mode jointly) over the first ``periods`` periods of the lowest
    mode after the pulse, where every mode still stands above the noise (a fast-decaying one
    included) and the extrapolation back to the blow is short; then
    ``1 / m_r = Re(sum_k conj(P_rk) R_rk) / (psi_dr^2 sum_k |P_rk|^2)`` over the records ``k``,
    ``P_rk = -i lambda_r^2 Phi_rk e^(lambda_r t_0) / omega_dr``. Linear: at large amplitude a
    nonlinear mode's residue carries its amplitude-dependent frequency; the modal masses are a
    first estimate, as the frequencies are.

    Parameters
    ----------
    modes : LinearModes
    records : sequence of (ndarray (n_channels, n), int, int)
        Accelerations [m/s^2] and each record's free window ``[start, stop)``.
    forces : sequence of ndarray (n,)
        The force at the driving point [N], zero outside the pulse.
    rate_hz : float
    driving_point : int
    periods : float

    early_shapes : ndarray of bool, shape (r,), optional
        Modes whose shape is taken from these early residues (every channel fitted with the
        same poles; the leading singular vector over the records, rotated to real): a mode
        that only an early window holds has a poorer ERA shape there than its residues give.

    spread : bool
        Also return each mode's spread over the records.

    Returns
    -------
    masses : ndarray, shape (r,)
        NaN for a mode with a node at the driving point or no consistent residue. The median
        over the records of each record's estimate.
    shapes : ndarray, shape (n_channels, r)
        ``modes.shapes`` with the ``early_shapes`` columns replaced.
    spread : ndarray, shape (r,)
        (with ``spread=True``) ``(max - min) / median`` of the records' estimates of
        ``psi_d^2 / m`` (NaN with fewer than two records): blows of different strength agree on a
        linear mode's residue; a nonlinear mode's early residue moves with the blow.
    """
    lam = np.array([complex(-z * 2 * math.pi * f / math.sqrt(max(1 - z * z, 1e-12)), 2 * math.pi * f)
                    for f, z in zip(modes.frequencies_hz, modes.damping_ratios)])
    if lam.size == 0:
        return (np.zeros(0), modes.shapes) + ((np.zeros(0),) if spread else ())
    per_record, residues = [], []
    f_low = float(np.min(modes.frequencies_hz))
    for (y, start, stop), force in zip(records, forces):
        stop = min(stop, start + int(periods * rate_hz / f_low))
        on = np.flatnonzero(force)
        if on.size == 0 or stop - start < 4 * lam.size:
            continue
        t = np.arange(stop - start) / rate_hz
        lam_k, res = _early_poles(lam, t, y[:, start:stop])
        tau = (np.arange(on[0], on[-1] + 1) - start) / rate_hz  # pulse time relative to the window start
        phi = np.exp(-np.outer(lam_k, tau)) @ force[on[0]:on[-1] + 1] / rate_hz
        p = -1j * lam_k**2 * phi / lam_k.imag
        per_record.append((np.conj(p) * res[:, driving_point]).real / np.abs(p) ** 2)  # psi_d^2 / m per mode
        residues.append(res)
    shapes = modes.shapes.copy()
    if not per_record:
        return (np.full(lam.size, math.nan), shapes) + ((np.full(lam.size, math.nan),) if spread else ())
    for r in np.flatnonzero(early_shapes if early_shapes is not None else np.zeros(lam.size, bool)):
        u = np.linalg.svd(np.array([res[r] for res in residues]).T, full_matrices=False)[0][:, 0]
        shapes[:, r] = real_modes([(0.0, 0.0, u)], driving_point)[2][:, 0]
    psi_d = shapes[driving_point] ** 2
    inv = np.median(np.array(per_record), axis=0) / np.maximum(psi_d, 1e-300)  # the median record: a
    ok = (inv > 0) & (psi_d > 1e-4)  # large blow of a strongly nonlinear mode leaves no linear residue
    masses = np.where(ok, 1.0 / np.where(ok, inv, 1.0), math.nan)
    if not spread:
        return masses, shapes
    est = np.array(per_record)
    med = np.median(est, axis=0)
    rel = (np.ptp(est, axis=0) / np.maximum(np.abs(med), 1e-300)) if est.shape[0] > 1 else np.full(lam.size, math.nan)
    return masses, shapes, np.where(ok, rel, math.nan)


def _early_poles(lam: np.ndarray, t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Poles and complex residues ``(r, n_channels)`` of ``y_c(t) = Re sum R_rc e^(lambda_r t)`` over a short early window.

    Variable projection (residues by linear least squares for given poles; the poles by
    ``scipy.optimize.least_squares`` from ERA's, frequencies within 5 %, decay rates 0.2-5x):
    at the start of a record a nonlinear mode oscillates at its large-amplitude frequency and
    ERA's damping of a gliding or fast mode is a poor guide, and a fixed pole there leaks into
    the residues.
    """
    from scipy.optimize import least_squares

    def resid(p: np.ndarray) -> np.ndarray:
        z = np.exp(np.outer(t, -p[:lam.size] + 1j * p[lam.size:]))
        basis = np.hstack([z.real, -z.imag])
        return (basis @ np.linalg.lstsq(basis, y.T, rcond=None)[0] - y.T).ravel()

    sig, om = np.maximum(-lam.real, 1e-3), lam.imag
    x0 = np.concatenate([sig, om])
    lo = np.concatenate([0.2 * sig, 0.95 * om])
    hi = np.concatenate([5.0 * sig, 1.05 * om])
    try:
        x = least_squares(resid, x0, bounds=(lo, hi), x_scale=np.concatenate([sig, 0.01 * om]), max_nfev=200).x
    except ValueError:
        x = x0
    lam_k = -x[:lam.size] + 1j * x[lam.size:]
    z = np.exp(np.outer(t, lam_k))
    coef = np.linalg.lstsq(np.hstack([z.real, -z.imag]), y.T, rcond=None)[0]
    return lam_k, coef[:lam.size] + 1j * coef[lam.size:]


def _with_added(base: LinearModes, added: list[tuple[float, float, np.ndarray]], tails: list[np.ndarray],
                rate_hz: float) -> LinearModes:
    """``base`` with the ``added`` modes merged in ascending frequency; their tail shares from a joint fit."""
    freqs = np.concatenate([base.frequencies_hz, [a[0] for a in added]])
    order = np.argsort(freqs)
    zetas = np.concatenate([base.damping_ratios, [a[1] for a in added]])
    shapes = np.hstack([base.shapes, np.column_stack([a[2] for a in added])])
    cplx = np.concatenate([base.complexity, np.zeros(len(added))])
    segs = [s for s in tails if s.ndim == 2 and s.shape[1] > 8]
    share = np.concatenate([base.energy_share, np.zeros(len(added))])
    if segs:
        dt = 1.0 / rate_hz
        joint = significant([(f, z, shapes[:, k].astype(complex)) for k, (f, z) in enumerate(zip(freqs, zetas))],
                             segs, dt, 0.0)
        share[base.frequencies_hz.size:] = [m[3] for m in joint[base.frequencies_hz.size:]]
    return replace(base, frequencies_hz=freqs[order], damping_ratios=zetas[order], shapes=shapes[:, order],
                   complexity=cplx[order], energy_share=share[order])
