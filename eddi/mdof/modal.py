"""Linear modal analysis of multi-channel free decays: the Eigensystem Realization Algorithm.

Why ERA (Juang & Pappa 1985) written here: the records are free decays (the impact is over),
several channels and several records share one set of poles, and what is needed is poles and
real mode shapes, not FRF curve fitting. ERA is a block-Hankel SVD and an eigenvalue problem
(numpy); sdypy-EMA fits poles to FRFs of one reference and pyoma2 targets operational data,
so neither fits a handful of ring-downs without first building FRFs from a nonlinear record.

Method: the low-amplitude tail of every record (where the response is below ``tail_fraction``
of its peak, so the nonlinear terms are small) is decimated, stacked as columns of block
Hankel matrices ``H0 = [y_{k+i+j}]`` and ``H1`` (shifted by one sample); the SVD of ``H0``
truncated at the model order gives ``A = S^-1/2 U^T H1 V S^-1/2`` and ``C = U S^1/2``; the
eigenvalues of ``A`` are the discrete poles ``mu = exp(lambda dt)``, ``C`` times the
eigenvectors the complex mode shapes. The order is the number of singular values standing
out of the noise (``order_threshold`` times the median of the trailing ones). Complex pairs
with a damping ratio below ``max_zeta`` are modes; real poles (a mass that is held by no
linear spring, as a nonlinear energy sink) are reported as ``n_real``. Real mode shapes are
the complex ones rotated to their largest component, scaled to a largest entry of 1.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

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
    """

    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    shapes: np.ndarray
    complexity: np.ndarray
    singular_values: np.ndarray
    order: int
    n_real: int


def tail_segments(y: np.ndarray, start: int, stop: int, fraction: float) -> np.ndarray:
    """The part of ``y[:, start:stop]`` after the envelope has fallen below ``fraction`` of its peak."""
    seg = y[:, start:stop]
    env = np.max(np.abs(seg), axis=0)
    if env.size == 0:
        return seg
    later_max = np.maximum.accumulate(env[::-1])[::-1]  # largest |y| from each sample on
    quiet = later_max <= fraction * float(env.max())
    first = int(np.argmax(quiet)) if quiet.any() else seg.shape[1]
    return seg[:, first:]


def era(
    segments: Sequence[np.ndarray],
    rate_hz: float,
    *,
    max_freq_hz: float | None = None,
    block_rows: int | None = None,
    max_order: int = 20,
    order_threshold: float = 30.0,
    max_zeta: float = 0.2,
    driving_point: int = 0,
) -> LinearModes:
    """Poles and real mode shapes of free decays (see the module docstring).

    Parameters
    ----------
    segments : sequence of ndarray, each (n_channels, n_k)
        Free-decay segments (same channels, same rate).
    rate_hz : float
        Sample rate [Hz].
    max_freq_hz : float, optional
        Highest frequency of interest; the segments are low-passed and decimated to 5 times
        it (default: no decimation).
    block_rows : int, optional
        Block rows of the Hankel matrix (default: enough for 4 cycles of the lowest mode at
        most, at least ``max_order``).
    max_order : int
        Largest model order tried.
    order_threshold : float
        A singular value counts when above this many times the noise level (median of the
        second half of the singular values).
    max_zeta : float
        Poles more damped than this are not modes.
    driving_point : int
        Channel whose shape entry is made positive.

    Raises
    ------
    IdentificationError
        No segment long enough, or no mode found.
    """
    q = 1
    if max_freq_hz is not None and rate_hz > 10 * max_freq_hz:
        q = int(rate_hz // (5 * max_freq_hz))
    dt = q / rate_hz
    segs = []
    for s in segments:
        s = np.asarray(s, float)
        if q > 1 and s.shape[1] > 30 * q:
            s = signal.decimate(s, q, ftype="fir", axis=1, zero_phase=True)
        segs.append(s)
    segs = [s for s in segs if s.shape[1] > 0]
    if not segs:
        raise IdentificationError("no low-amplitude tail for ERA: every record ends before its envelope "
                                  "decays; record longer ring-downs")
    longest = max(s.shape[1] for s in segs)
    n_ch = segs[0].shape[0]
    p = block_rows or max(max_order, 40 // n_ch + 2)
    h0, h1 = _hankel(segs, p)
    u, sv, vt = np.linalg.svd(h0, full_matrices=False)
    svn = sv / sv[0]
    noise = float(np.median(svn[len(svn) // 2:])) if len(svn) > 4 else 0.0
    order = int(np.sum(svn > order_threshold * max(noise, 1e-12)))
    order = max(1, min(order, max_order, len(sv)))
    ur, sr, vr = u[:, :order], sv[:order], vt[:order].T
    s_inv = 1.0 / np.sqrt(sr)
    a = (s_inv[:, None] * (ur.T @ h1 @ vr)) * s_inv[None, :]
    c = (ur * np.sqrt(sr)[None, :])[:n_ch]
    mu, vec = np.linalg.eig(a)
    lam = np.log(mu.astype(complex)) / dt
    shapes_c = c @ vec
    keep = []
    n_real = 0
    for k, l in enumerate(lam):
        if abs(l.imag) < 1e-9 * max(abs(l), 1.0) or l.imag < 0:
            n_real += int(abs(l.imag) < 1e-9 * max(abs(l), 1.0))
            continue
        wn = abs(l)
        zeta = -l.real / wn
        fd = l.imag / (2 * math.pi)
        if 0 <= zeta < max_zeta and fd > 0.5 / (dt * longest) and (max_freq_hz is None or fd < 1.2 * max_freq_hz):
            keep.append((fd, zeta, k))
    if not keep:
        raise IdentificationError("ERA found no oscillating mode in the free decays")
    keep.sort()
    freqs, zetas, shapes, cplx = _real_modes(keep, shapes_c, driving_point)
    return LinearModes(freqs, zetas, shapes, cplx, svn, order, n_real)


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


def _real_modes(keep: list[tuple[float, float, int]], shapes_c: np.ndarray, driving_point: int
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Frequencies, damping ratios, real shapes (largest entry 1, positive at the driving point), complexity."""
    freqs, zetas, shapes, cplx = [], [], [], []
    for fd, zeta, k in keep:
        psi = shapes_c[:, k]
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
