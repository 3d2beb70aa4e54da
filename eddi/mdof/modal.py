"""Linear modal analysis of multi-channel free decays: the Eigensystem Realization Algorithm.

Why ERA (Juang & Pappa 1985) written here: the records are free decays (the impact is over),
several channels and several records share one set of poles, and what is needed is poles and
real mode shapes, not FRF curve fitting. ERA is a block-Hankel SVD and an eigenvalue problem
(numpy); sdypy-EMA fits poles to FRFs of one reference and pyoma2 targets operational data,
so neither fits a handful of ring-downs without first building FRFs from a nonlinear record.

Method: the low-amplitude tail of every record (where the response is below ``tail_fraction``
of its peak, so the nonlinear terms are small) is low-passed and decimated to about 5 times the
top of its band (the part of the spectrum 10 times above the noise floor; the decimating
filter's edge samples cut, :data:`DECIMATE_EDGE`), stacked as columns
of block Hankel matrices ``H0 = [y_{k+i+j}]`` and ``H1`` (shifted by one sample); the SVD of
``H0`` truncated at order ``n`` gives ``A = S^-1/2 U^T H1 V S^-1/2`` and ``C = U S^1/2``; the
eigenvalues of ``A`` are the discrete poles ``mu = exp(lambda dt)``.

**Order: a stabilisation diagram** (orders 2, 4, ..., ``max_order``), not a singular-value
threshold: the threshold (30 times the median of the trailing singular values) cut the order
to 3 at 30 dB and found one mode of three or four (measured on chains of 2-4 masses,
``benchmarks/bench_mdof_modal.py``). A pole is stable when the next lower order has one
within 1 % in frequency, 30 % in damping and MAC >= 0.9; a mode is a column of stable poles
present at half the orders or more, carrying at least ``min_energy`` of the tails' modal fit
(least squares of every mode's free decay); columns within 8 % whose shapes agree are one mode
gliding with amplitude (a nonlinear tail). Shapes are then re-estimated from the data (poles
fixed, one complex residue per channel, mode and segment; the leading singular vector of a
mode's residues), rotated to real, largest entry 1. The fit's residual gives each channel's
``unexplained`` part of the tail (noise floor taken off), the evidence of a motion no linear
mode describes. Why not sdypy-EMA / pyoma2: EMA fits FRFs of one reference and pyoma2 targets
operational (output-only, stationary) data; free decays sharing poles are what ERA is for,
and the diagram is a few dozen small eigenproblems in numpy.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import signal

from eddi.errors import IdentificationError


@dataclass(frozen=True)
class LinearModes:
    """Modes found in the low-amplitude tail.

    Attributes
    ----------
    frequencies_hz : ndarray, shape (r,)
        Damped natural frequencies [Hz], ascending.
    damping_ratios : ndarray, shape (r,)
    shapes : ndarray, shape (n_channels, r)
        Real mode shapes scaled to a largest magnitude of 1, signed so that the driving-point
        entry is positive.
    complexity : ndarray, shape (r,)
        Norm of the imaginary part of each rotated complex shape relative to its real part
        (0 for a classically damped mode).
    singular_values : ndarray
        Of the Hankel matrix, normalised by the first.
    order : int
        Model order used (twice the oscillating modes plus real poles).
    n_real : int
        Real (non-oscillating) poles in the realisation.
    unexplained : ndarray, shape (n_channels,)
        Part of each channel's tail energy (in the analysed band, the noise floor taken off)
        that the modes' free decays do not reproduce: near 0 when the modes describe the tail,
        large when some motion has no linear mode (an essentially nonlinear attachment).
    energy_share : ndarray, shape (r,)
        Each mode's share of the energy of the tails' modal fit.
    modal_masses : ndarray, shape (r,)
        Modal mass of each mode for its shape as given (largest entry 1) [kg], from the
        driving-point residue and the measured force (:func:`eddi.mdof.early.residue_masses`); NaN without a
        force or where the driving point is a node. Empty when not computed.
    modal_mass_spread : ndarray, shape (r,)
        Spread of the records' driving-point residues behind each modal mass,
        ``(max - min) / median`` (:func:`eddi.mdof.early.residue_masses`): small for a linear
        mode, large when the early residue moves with the blow (a nonlinear mode). Empty when
        not computed.
    pole_channels : tuple of int
        The channels the poles were realised from when not every channel (empty: all;
        :func:`eddi.mdof.early.era_windows`' fallback for an essentially nonlinear attachment).
    """

    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    shapes: np.ndarray
    complexity: np.ndarray
    singular_values: np.ndarray
    order: int
    n_real: int
    unexplained: np.ndarray = field(default_factory=lambda: np.zeros(0))
    energy_share: np.ndarray = field(default_factory=lambda: np.zeros(0))
    modal_masses: np.ndarray = field(default_factory=lambda: np.zeros(0))
    modal_mass_spread: np.ndarray = field(default_factory=lambda: np.zeros(0))
    pole_channels: tuple[int, ...] = ()


def tail_segments(y: np.ndarray, start: int, stop: int, fraction: float) -> np.ndarray:
    """The part of ``y[:, start:stop]`` after the envelope has fallen below ``fraction`` of its peak."""
    return y[:, tail_start(y, start, stop, fraction):stop]


#: The tail is at least this share of the free window (its quietest end): a lightly damped record
#: whose envelope never falls to the tail's fraction of its peak still has a low-amplitude end
#: (session 9: a 0.2 %-damped pair, 2 s records, ERA had an empty tail and failed).
MIN_TAIL_SHARE = 0.25


def tail_start(y: np.ndarray, start: int, stop: int, fraction: float) -> int:
    """Index of ``y`` where its envelope over ``[start, stop)`` has fallen below ``fraction`` of its peak for
    good, at the latest :data:`MIN_TAIL_SHARE` of the window before ``stop``."""
    env = np.max(np.abs(y[:, start:stop]), axis=0)
    if env.size == 0:
        return start
    later_max = np.maximum.accumulate(env[::-1])[::-1]  # largest |y| from each sample on
    quiet = later_max <= fraction * float(env.max())
    found = int(np.argmax(quiet)) if quiet.any() else env.size
    return start + min(found, env.size - int(MIN_TAIL_SHARE * env.size))


#: Output samples cut from each end of a decimated segment (half the length of the FIR filter of
#: ``scipy.signal.decimate``, ``ftype="fir"``: ``20 q + 1`` taps, i.e. 10 output samples).
DECIMATE_EDGE = 10


def era(
    segments: Sequence[np.ndarray],
    rate_hz: float,
    *,
    max_freq_hz: float | None = None,
    block_rows: int | None = None,
    max_order: int = 40,
    order_threshold: float = 30.0,
    max_zeta: float = 0.2,
    driving_point: int = 0,
    min_stable: int = 4,
    min_energy: float = 0.001,
    pole_channels: Sequence[int] | None = None,
) -> LinearModes:
    """Poles and real mode shapes of free decays (see the module docstring).

    Parameters
    ----------
    segments : sequence of ndarray, each (n_channels, n_k)
        Free-decay segments (same channels, same rate).
    rate_hz : float
        Sample rate [Hz].
    max_freq_hz : float, optional
        Highest frequency of interest [Hz]; the band actually used is the part of the tails'
        spectrum above the noise floor, at most this (:func:`response_band`). The segments are
        low-passed and decimated to about 5 times the band's top.
    block_rows : int, optional
        Block rows of the Hankel matrix (default: about one period of the lowest spectral
        peak, at least enough rows for ``max_order``).
    max_order : int
        Largest model order of the stabilisation diagram.
    order_threshold : float
        Only for ``n_real``: real poles counted at the order whose singular values stand
        this many times above the median of the trailing ones.
    max_zeta : float
        Poles more damped than this are not modes.
    driving_point : int
        Channel whose shape entry is made positive.
    min_stable : int
        A pole is a mode when it is stable (frequency within 1 %, damping ratio within 30 % or
        0.3 points, shape MAC >= 0.9 against the next lower order) at this many orders.
    min_energy : float
        ... and when its part of the tails (least-squares fit of every stable mode's free decay
        to the segments) carries at least this fraction of the fitted signal's energy.
    pole_channels : sequence of int, optional
        Realise the poles (Hankel matrices, stabilisation diagram, energy shares) from these
        channels only; the shapes and ``unexplained`` still come from every channel's residues.
        For a channel whose motion has no linear mode (an essentially nonlinear attachment: its
        gliding, amplitude-dependent response leaves no pole stable over the orders).

    Raises
    ------
    IdentificationError
        No segment long enough, or no mode stable in the stabilisation diagram.
    """
    segs = [np.asarray(s, float) for s in segments]
    segs = [s for s in segs if s.ndim == 2 and s.shape[1] > 8]
    if not segs:
        raise IdentificationError("no low-amplitude tail for ERA: every record ends before its envelope "
                                  "decays; record longer ring-downs")
    f_lo, f_hi, floor = response_band(segs, rate_hz)
    if f_hi <= 0:
        raise IdentificationError("ERA found no oscillating mode: the tails' spectrum has no peak 10 times "
                                  "above its noise floor")
    top = min(f_hi, max_freq_hz) if max_freq_hz else f_hi
    q = int(rate_hz // (5 * top)) if rate_hz > 10 * top else 1
    dt = q / rate_hz
    if q > 1:
        # without the filter's edges: decimate's FIR (20 q + 1 taps) sees zeros beyond each end of a
        # segment, so its first and last DECIMATE_EDGE output samples are not data. Kept, they biased
        # the residue shapes of a weak mode (session 10: a near-1:2 pair's upper mode 0.418 for 0.375
        # at acc1, its residue mass 24 % off; trimmed 0.375)
        segs = [signal.decimate(s, q, ftype="fir", axis=1, zero_phase=True)[:, DECIMATE_EDGE:-DECIMATE_EDGE]
                for s in segs if s.shape[1] > 30 * q]
    if not segs:
        raise IdentificationError("free decays too short for ERA after decimation; record longer ring-downs")
    every = segs
    if pole_channels is not None:
        segs = [s[list(pole_channels)] for s in segs]
    longest = max(s.shape[1] for s in segs)
    n_ch = segs[0].shape[0]
    p = block_rows or int(np.clip(math.ceil(1.0 / (max(f_lo, 1e-3) * dt)), max_order // n_ch + 2, 400 // n_ch))
    h0, h1 = _hankel(segs, p)
    u, sv = _gram_svd(h0)
    svn = sv / sv[0]
    noise = float(np.median(svn[len(svn) // 2:])) if len(svn) > 4 else 0.0
    order = max(1, min(int(np.sum(svn > order_threshold * max(noise, 1e-12))), len(sv)))
    rank = min(max(max_order, order), int(np.sum(svn > 1e-12)))
    vt = (u[:, :rank].T @ h0) / sv[:rank, None]  # the first right singular vectors
    g = (u[:, :rank].T @ h1) @ vt.T
    order = min(order, rank)
    f_min, f_max = 0.5 / (dt * longest), 1.2 * top
    diagram = [(n, _poles(u, sv, g, n, n_ch, dt)) for n in range(2, min(max_order, rank) + 1, 2)]
    modes = _stable_modes(diagram, f_min, f_max, max_zeta, min_stable)
    modes = _merge_gliding(significant(modes, segs, dt, min_energy))
    modes, unexplained = _shapes_from_residues(modes, every, dt, floor * 0.5 / dt)
    if not modes:
        raise IdentificationError(
            f"ERA found no oscillating mode stable over {min_stable} model orders in the free decays "
            f"({f_min:.3g}-{f_max:.3g} Hz): too noisy or too short a ring-down")
    lam_t = _poles(u, sv, g, order, n_ch, dt)[0]
    n_real = int(np.sum(np.abs(lam_t.imag) < 1e-9 * np.maximum(np.abs(lam_t), 1.0)))
    freqs, zetas, shapes, cplx = real_modes([m[:3] for m in modes], driving_point)
    return LinearModes(freqs, zetas, shapes, cplx, svn, max(n for n, _ in diagram), n_real, unexplained,
                       np.array([m[3] for m in modes]),
                       pole_channels=tuple(int(c) for c in pole_channels) if pole_channels is not None else ())


def response_band(segs: Sequence[np.ndarray], rate_hz: float) -> tuple[float, float, np.ndarray]:
    """``(f_lo, f_hi, floor)``: the lowest and highest frequency [Hz] where the tails' summed
    spectrum stands 10 times above its noise floor (median of the upper half of the spectrum),
    and each channel's noise floor (one-sided PSD, units^2/Hz, weighted by segment length).
    ``f_hi`` is 0 when nothing stands above the floor."""
    nper = int(min(1024, min(s.shape[1] for s in segs)))
    psd, chan, total = None, None, 0
    for s in segs:
        f, p = signal.welch(s, fs=rate_hz, nperseg=nper, axis=1)
        chan = p * s.shape[1] if chan is None else chan + p * s.shape[1]
        total += s.shape[1]
        p = p.sum(axis=0) * s.shape[1]
        psd = p if psd is None else psd + p
    chan_floor = np.median(chan[:, chan.shape[1] // 2:], axis=1) / total
    floor = float(np.median(psd[len(psd) // 2:]))
    above = np.flatnonzero(psd > 10 * max(floor, 1e-300 * psd.max()))
    above = above[above > 0]
    if above.size == 0:
        return float(f[1]), 0.0, chan_floor
    lo = float(f[int(np.argmax(psd[1:])) + 1]) if above.size < 2 else float(f[above[0]])
    hi = float(f[min(above[-1] + 1, len(f) - 1)])
    return max(lo, float(f[1])), max(hi, lo * 1.5), chan_floor


def _poles(u: np.ndarray, sv: np.ndarray, g: np.ndarray, order: int, n_ch: int, dt: float
           ) -> tuple[np.ndarray, np.ndarray]:
    """Continuous poles [1/s] and complex shapes (n_ch, order) of the order-``order`` realisation.

    ``g = U^T H1 V`` over the leading singular vectors (computed once for every order)."""
    ur, sr = u[:, :order], sv[:order]
    s_inv = 1.0 / np.sqrt(sr)
    a = (s_inv[:, None] * g[:order, :order]) * s_inv[None, :]
    c = (ur * np.sqrt(sr)[None, :])[:n_ch]
    mu, vec = np.linalg.eig(a)
    return np.log(mu.astype(complex)) / dt, c @ vec


def significant(modes: list[tuple[float, float, np.ndarray]], segs: Sequence[np.ndarray], dt: float,
                min_energy: float) -> list[tuple[float, float, np.ndarray]]:
    """The modes whose share of the tails (free decays fitted jointly by least squares, one complex
    amplitude per mode and segment) is at least ``min_energy`` of the fitted energy."""
    if len(modes) < 2:
        return [m + (1.0,) for m in modes]
    energy = np.zeros(len(modes))
    for s in segs:
        t = np.arange(s.shape[1]) * dt
        cols = []
        for fd, zeta, psi in modes:
            wn = 2 * math.pi * fd / math.sqrt(max(1 - zeta**2, 1e-12))
            z = np.exp((-zeta * wn + 2j * math.pi * fd) * t)
            w = psi[:, None] * z[None, :]
            cols += [w.real.ravel(), -w.imag.ravel()]
        basis = np.column_stack(cols)
        coef = np.linalg.lstsq(basis, s.ravel(), rcond=None)[0]
        for k in range(len(modes)):
            energy[k] += float(np.sum((basis[:, 2 * k:2 * k + 2] @ coef[2 * k:2 * k + 2]) ** 2))
    share = energy / max(energy.sum(), 1e-300)
    return [m + (float(e),) for m, e in zip(modes, share) if e >= min_energy]


def _decays(modes: list[tuple[float, float, np.ndarray]], n: int, dt: float) -> np.ndarray:
    """``exp(lambda_k t)`` of every mode over ``n`` samples, shape (n, n_modes)."""
    t = np.arange(n) * dt
    out = np.empty((n, len(modes)), complex)
    for k, (fd, zeta, *_rest) in enumerate(modes):
        wn = 2 * math.pi * fd / math.sqrt(max(1 - zeta**2, 1e-12))
        out[:, k] = np.exp((-zeta * wn + 2j * math.pi * fd) * t)
    return out


def _shapes_from_residues(modes: list[tuple[float, float, np.ndarray, float]], segs: Sequence[np.ndarray], dt: float,
                          noise_var: np.ndarray) -> tuple[list[tuple[float, float, np.ndarray, float]], np.ndarray]:
    """The modes with shapes re-estimated from the data: with the poles fixed, every channel of
    every segment is fitted by least squares (one complex residue per mode); a mode's shape is
    the leading singular vector of its residues over the segments (the realisation's ``C`` at
    one order is noisier on the weak channels). Also each channel's unexplained part (see
    :class:`LinearModes`), ``noise_var`` being the noise variance of the decimated segments."""
    n_ch = segs[0].shape[0]
    if not modes:
        return modes, np.ones(n_ch)
    res = [[] for _ in modes]
    resid, energy, count = np.zeros(n_ch), np.zeros(n_ch), 0
    for s in segs:
        z = _decays(modes, s.shape[1], dt)
        basis = np.hstack([z.real, -z.imag])
        coef = np.linalg.lstsq(basis, s.T, rcond=None)[0]  # (2 n_modes, n_ch)
        resid += np.sum((s.T - basis @ coef) ** 2, axis=0)
        energy += np.sum(s**2, axis=1)
        count += s.shape[1]
        r = coef[:len(modes)] + 1j * coef[len(modes):]
        for k in range(len(modes)):
            res[k].append(r[k])
    out = []
    for (fd, zeta, _psi, share), rk in zip(modes, res):
        u, _s, _vt = np.linalg.svd(np.array(rk).T, full_matrices=False)
        out.append((fd, zeta, u[:, 0], share))
    noise = noise_var * count
    unexplained = np.maximum(resid - noise, 0.0) / np.maximum(energy - noise, 1e-300)
    return out, np.clip(unexplained, 0.0, 1.0)


def _merge_gliding(modes: list[tuple[float, float, np.ndarray, float]]) -> list[tuple[float, float, np.ndarray, float]]:
    """One mode per column group: columns within 8 % in frequency whose shapes agree (MAC >= 0.9)
    are one mode whose frequency glides with amplitude (a nonlinear tail); the most energetic
    column represents it, with the group's summed share. ``(f_d, zeta, shape, energy share)``."""
    kept: list[tuple[float, float, np.ndarray, float]] = []
    for m in sorted(modes, key=lambda r: -r[3]):
        same = [j for j, k in enumerate(kept) if abs(m[0] - k[0]) <= 0.08 * k[0] and mac(m[2], k[2]) >= 0.9]
        if same:
            k = kept[same[0]]
            kept[same[0]] = (k[0], k[1], k[2], k[3] + m[3])
        else:
            kept.append(m)
    return _drop_combination_tones(sorted(kept, key=lambda r: r[0]))


def _drop_combination_tones(modes: list[tuple[float, float, np.ndarray, float]], weak: float = 0.01, tol: float = 0.01
                            ) -> list[tuple[float, float, np.ndarray, float]]:
    """Without the weak columns (share below ``weak``) within ``tol`` of ``3 f_i`` or ``2 f_i +- f_j``
    of stronger modes: the tones a cubic force puts in the tail, not linear modes."""
    out = []
    for m in modes:
        strong = [k[0] for k in modes if k[3] > m[3] and k[3] >= weak]
        tones = [3 * a for a in strong] + [abs(2 * a + sgn * b) for a in strong for b in strong if a != b
                                           for sgn in (1, -1)]
        if m[3] < weak and any(abs(m[0] - t) <= tol * m[0] for t in tones):
            continue
        out.append(m)
    return out


def mac(a: np.ndarray, b: np.ndarray) -> float:
    """Modal assurance criterion of two (complex) shapes, 0 to 1."""
    return float(abs(np.vdot(a, b)) ** 2 / max(np.vdot(a, a).real * np.vdot(b, b).real, 1e-300))


def _stable_modes(diagram: list[tuple[int, tuple[np.ndarray, np.ndarray]]], f_min: float, f_max: float,
                  max_zeta: float, min_stable: int) -> list[tuple[float, float, np.ndarray]]:
    """Modes of the stabilisation diagram: ``(f_d, zeta, complex shape)`` per mode, ascending.

    A pole is stable when the next lower order has one within 1 % in frequency, 30 % (or 0.003)
    in damping ratio and MAC >= 0.9; stable poles within 1 % of each other form a column; a
    column with stable poles at ``min_stable`` or more orders is a mode, represented by its
    pole at the median frequency.
    """
    per_order = []
    for _n, (lam, shp) in diagram:
        rows = []
        for k, lm in enumerate(lam):
            if lm.imag <= 1e-9 * max(abs(lm), 1.0):
                continue
            wn = abs(lm)
            zeta, fd = -lm.real / wn, lm.imag / (2 * math.pi)
            if 0 <= zeta < max_zeta and f_min < fd < f_max:
                rows.append((fd, zeta, shp[:, k]))
        per_order.append(rows)
    stable = []
    for j in range(1, len(per_order)):
        for fd, zeta, psi in per_order[j]:
            if any(abs(f0 - fd) <= 0.01 * fd and abs(z0 - zeta) <= max(0.3 * zeta, 0.003) and mac(p0, psi) >= 0.9
                   for f0, z0, p0 in per_order[j - 1]):
                stable.append((fd, zeta, psi, j))
    stable.sort(key=lambda r: r[0])
    columns: list[list] = []
    for row in stable:
        if columns and row[0] - columns[-1][-1][0] <= 0.01 * row[0]:
            columns[-1].append(row)
        else:
            columns.append([row])
    modes = []
    for col in columns:
        if len({r[3] for r in col}) < max(min_stable, 0.5 * (len(diagram) - 1)):
            continue
        mid = col[len(col) // 2]
        modes.append((mid[0], float(np.median([r[1] for r in col])), mid[2]))
    return modes


def _gram_svd(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Left singular vectors and singular values (descending) of a wide matrix ``h``.

    Through the eigen-decomposition of the small Gram matrix ``h h^T`` (rows = block rows x
    channels, a few hundred; columns = tens of thousands of time shifts): numpy's SVD of ``h``
    cost about 1 s per call and :func:`era` needs only the first right singular vectors
    (``V^T = S^-1 U^T h``). The squared condition number is harmless here: the singular values
    used stand above the noise (1e-4 of the first or more), far above the Gram matrix's
    rounding (1e-16 of the first squared); measured on ``benchmarks/bench_mdof_modal.py``,
    every frequency printed is the same to the digits shown.
    """
    lam, u = np.linalg.eigh(h @ h.T)
    order = np.argsort(lam)[::-1]
    return u[:, order], np.sqrt(np.maximum(lam[order], 0.0))


def _hankel(segs: list[np.ndarray], p: int) -> tuple[np.ndarray, np.ndarray]:
    """Block Hankel matrices ``H0`` and ``H1`` (shifted one sample) of every segment, side by side."""
    cols0, cols1 = [], []
    for s in segs:
        m = s.shape[1] - p - 1
        if m < p:
            continue
        idx = np.arange(p)[:, None] + np.arange(m)[None, :]
        cols0.append(s[:, idx].transpose(1, 0, 2).reshape(p * s.shape[0], m))
        cols1.append(s[:, idx + 1].transpose(1, 0, 2).reshape(p * s.shape[0], m))
    if not cols0:
        raise IdentificationError(f"free decays too short for ERA: need more than {2 * p + 1} samples after decimation")
    return np.hstack(cols0), np.hstack(cols1)


def real_modes(modes: list[tuple[float, float, np.ndarray]], driving_point: int
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Frequencies, damping ratios, real shapes (largest entry 1, positive at the driving point), complexity."""
    freqs, zetas, shapes, cplx = [], [], [], []
    for fd, zeta, psi in modes:
        big = int(np.argmax(np.abs(psi)))
        psi = psi * np.exp(-1j * np.angle(psi[big]))
        re = psi.real / np.max(np.abs(psi.real))
        if re[driving_point] < 0:
            re = -re
        freqs.append(fd)
        zetas.append(zeta)
        shapes.append(re)
        cplx.append(float(np.linalg.norm(psi.imag) / max(np.linalg.norm(psi.real), 1e-300)))
    return np.array(freqs), np.array(zetas), np.array(shapes).T, np.array(cplx)
