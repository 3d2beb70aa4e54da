"""The grid the output-error refinement compares on (:mod:`eddi.refine`): block means and RK4 steps.

A densely sampled record (19.2 kHz for a 4 Hz oscillator: thousands of samples per cycle) is
compared as block means of ``block`` samples (:func:`block_means`, ``block`` set by
:func:`block_size` so that a block spans at most :data:`BLOCK_H_OMEGA` rad of the fastest
local oscillation): with white sensor noise the block means carry the same information about
a signal whose band lies far below ``1 / (block dt)``, and every simulation runs on the grid
of the blocks' centres (``1 / block`` of the cost), with RK4 steps of ``omega h <=``
:data:`LOCAL_H_OMEGA` at the amplitude the record still reaches (:func:`local_substeps`).
:func:`smooth_model` says when the forward sensitivity equations (:mod:`eddi.sensitivity`)
give the Jacobian.
"""

from __future__ import annotations

import math

import numpy as np

from eddi.kernels import Kernels
from eddi.model import EquationOfMotion
from eddi.local_frequency import local_angular_frequencies, local_angular_frequency


#: Largest ``omega_max * block * dt`` (rad) of a block: the block mean then differs from the
#: curvature-corrected centre value by ~``(omega h)^4 / 339`` (4.7e-6 relative at 0.2), which
#: the fourth difference's term removes (:func:`eddi.intervals.sampling_quartic`; 2e-8 left).
BLOCK_H_OMEGA = 0.2
#: Fewest block means compared (short records keep every sample).
MIN_BLOCKS = 2000


def block_size(eom: EquationOfMotion, dt: float, x_amp: float, v_amp: float, n: int) -> int:
    """Samples per block mean (odd, >= 1): ``omega_max * block * dt <= BLOCK_H_OMEGA``.

    ``omega_max``: :func:`local_angular_frequency` over the record's amplitudes; at least
    :data:`MIN_BLOCKS` blocks are kept.
    """
    omega = local_angular_frequency(eom, x_amp, v_amp)
    if not (omega > 0 and math.isfinite(omega)):
        return 1
    b = min(int(BLOCK_H_OMEGA / (omega * dt)), n // MIN_BLOCKS)
    b = b if b % 2 == 1 else b - 1
    return max(1, b)


#: ``omega h`` of an RK4 step at the amplitude the record still reaches (:func:`local_substeps`):
#: the simulator's own 0.1, which the peak's steps already keep (``_OutputError.substeps``).
#: The fit's RK4 error (``(omega h)^4 / 120`` in frequency) is measured and removed at the
#: optimum by :func:`eddi.intervals.integration_shift` (Richardson against twice the steps; what
#: it leaves, 1/25 of the shift, is added to the intervals), so the step sets the cost, not the
#: result: 0.05 (sessions 9-16, ~1.5x the steps of a hardening ring-down's late cycles) and 0.1
#: give coefficients within 4.6e-3 of their ci95 and the same coverage on 58 records, 45-60 dB
#: (session 17, docs/speed.md); ~3 ms of the 45 s record's ~26 ms refinement.
LOCAL_H_OMEGA = 0.1


def local_substeps(eom: EquationOfMotion, h: float, x_abs: np.ndarray, v_abs: np.ndarray,
                   most: int) -> np.ndarray:
    """RK4 steps per interval of ``h`` so that ``omega h / steps <= LOCAL_H_OMEGA`` at the amplitude ahead.

    ``omega``: :func:`eddi.simulate.local_angular_frequency` at the largest ``|x|, |v|`` the
    record reaches from each interval on (a ring-down slows as it decays: a hardening spring's
    first peak sets ~110 rad/s, its late cycles ~25), on 12 amplitude levels, interpolated;
    at most ``most``.
    """
    ax = np.maximum.accumulate(np.asarray(x_abs, dtype=float)[::-1])[::-1]
    av = np.maximum.accumulate(np.asarray(v_abs, dtype=float)[::-1])[::-1]
    if ax.size < 2 or not (ax[0] > 0 and av[0] > 0):
        return np.full(max(1, ax.size - 1), most, dtype=np.int64)
    levels = np.geomspace(max(ax[0] * 1e-3, float(ax[-1]) or ax[0] * 1e-3), ax[0], 12)
    ratio = av[0] / ax[0]
    omega = local_angular_frequencies(eom, levels, levels * ratio)  # one evaluation of the 12 ranges
    om = np.interp(ax[:-1], levels, omega)
    # the next level up bounds the interpolation between levels
    steps = np.ceil(h * np.maximum(om, np.interp(ax[:-1] * 1.2, levels, omega)) / LOCAL_H_OMEGA).astype(np.int64)
    return np.clip(steps, 1, most)


def block_means(y: np.ndarray, block: int) -> np.ndarray:
    """Means of consecutive blocks of ``block`` samples (a shorter last block is dropped).

    With white noise of variance ``s^2`` on ``y`` the block means carry white noise of
    variance ``s^2 / block``: for a signal whose band is far below ``1 / (block dt)`` the
    least-squares fit to the block means keeps (nearly) all the information of the samples,
    at ``1 / block`` of the cost. The model is compared through its value at the block's
    centre sample plus the curvature inside the block,
    ``mean = y_c + (block^2 - 1) / (24 block^2) (y_{c+1} - 2 y_c + y_{c-1})`` on the grid of
    centres (exact for a quadratic), plus a fourth difference's term
    (:func:`eddi.intervals.sampling_quartic`; ``O((omega h)^6)`` left).
    """
    if block <= 1:
        return np.asarray(y, dtype=float)
    nb = y.size // block
    if 1 < block <= PAIRWISE_BLOCK and isinstance(y, np.ndarray) and y.dtype == np.float64 and y.ndim == 1 \
            and y.flags.c_contiguous and nb > 0:
        out = np.empty(nb)
        _KERNELS._block_means(y, block, 0, out)
        return out
    return np.asarray(y[: nb * block], dtype=float).reshape(nb, block).mean(axis=1)


def block_means_abs(y: np.ndarray, block: int) -> np.ndarray:
    """``block_means(np.abs(y), block)``, the same doubles, without the ``|y|`` temporary."""
    if 1 < block <= PAIRWISE_BLOCK and isinstance(y, np.ndarray) and y.dtype == np.float64 and y.ndim == 1 \
            and y.flags.c_contiguous and y.size >= block:
        out = np.empty(y.size // block)
        _KERNELS._block_means(y, block, 1, out)
        return out
    return block_means(np.abs(y), block)


def window_means(y: np.ndarray, first: np.ndarray, run: int) -> np.ndarray:
    """``y[first[:, None] + np.arange(run)].mean(axis=1)``, the same doubles, without the gathered
    ``(first.size, run)`` table (each window summed in place as numpy sums a row)."""
    first = np.asarray(first)
    if 1 < run <= PAIRWISE_BLOCK and isinstance(y, np.ndarray) and y.dtype == np.float64 and y.ndim == 1 \
            and y.flags.c_contiguous and first.ndim == 1 and first.size \
            and 0 <= int(first.min()) and int(first.max()) + run <= y.size:
        out = np.empty(first.size)
        _KERNELS._window_means(y, first.astype(np.int64), run, out)
        return out
    return y[first[:, None] + np.arange(run)[None, :]].mean(axis=1)


def _window_means(y, first, run, out):  # pragma: no cover - compiled
    """:func:`window_means`: :func:`_block_means`' sums over ``y[first[k]:first[k] + run]``."""
    r = np.empty(8)
    for k in range(out.shape[0]):
        base = first[k]
        if run < 8:
            s = 0.0
            for j in range(run):
                s += y[base + j]
        else:
            for j in range(8):
                r[j] = y[base + j]
            m = run - run % 8
            for i in range(8, m, 8):
                for j in range(8):
                    r[j] += y[base + i + j]
            s = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
            for i in range(m, run):
                s += y[base + i]
        out[k] = (0.0 + s) / run


#: Longest block :func:`_block_means` sums as numpy does (numpy's pairwise sum splits longer rows).
PAIRWISE_BLOCK = 128


def _block_means(y, block, absolute, out):  # pragma: no cover - compiled
    """:func:`block_means` (of ``|y|`` with ``absolute``): each row of the ``(nb, block)`` view
    summed as numpy's pairwise sum sums a row of up to 128 (fewer than 8: in turn; else eight
    running sums, added pairwise, then the rest in turn), plus numpy's initial 0.0, over ``block``."""
    r = np.empty(8)
    for k in range(out.shape[0]):
        base = k * block
        if block < 8:
            s = 0.0
            for j in range(block):
                s += abs(y[base + j]) if absolute else y[base + j]
        else:
            for j in range(8):
                r[j] = abs(y[base + j]) if absolute else y[base + j]
            m = block - block % 8
            for i in range(8, m, 8):
                for j in range(8):
                    r[j] += abs(y[base + i + j]) if absolute else y[base + i + j]
            s = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
            for i in range(m, block):
                s += abs(y[base + i]) if absolute else y[base + i]
        out[k] = (0.0 + s) / block


def smooth_model(eom: EquationOfMotion) -> bool:
    """True when the sensitivity equations give the Jacobian: no effects, no ``sign`` factor.

    A ``sign(v)`` (dry friction) switches the force at every reversal: the response's
    derivative then has jumps the sensitivity equations do not carry.
    """
    if eom.effects:
        return False
    return all(tm.exponents[4] % 2 == 0 and tm.exponents[5] % 2 == 0
               for tm in eom.damping_terms() + eom.stiffness_terms())


def through_sampling_pass(y: np.ndarray, curvature: float, quartic: float) -> np.ndarray | None:
    """:func:`eddi.intervals.through_sampling` of a Jacobian in one compiled pass (None: not for this input).

    For a C-contiguous float array of shape ``(n, k)`` with ``n >= 6`` and a curvature term:
    ``y + quartic * d4`` then ``+ curvature * d2``, each difference formed as numpy's passes form
    it (the same floats; 0.18 against 3.1 ms on a Jacobian of 9.4k x 14, where numpy's passes run
    down strided columns of temporaries; a vector stays with numpy, as fast there)."""
    if not (curvature and isinstance(y, np.ndarray) and y.dtype == np.float64 and y.ndim == 2
            and y.flags.c_contiguous and y.shape[0] >= 6):
        return None
    out = np.empty_like(y)
    _KERNELS._through_sampling(y, float(curvature), float(quartic), int(bool(quartic)), out)
    return out


def _through_sampling(y, c, q, use_q, out):  # pragma: no cover - compiled
    """``out = (y + q d4) + c d2`` along axis 0, the edges extrapolated (n >= 6; ``use_q`` 0: no d4)."""
    n, k = y.shape
    for i in range(1, n - 1):
        for j in range(k):
            out[i, j] = (y[i + 1, j] - 2.0 * y[i, j]) + y[i - 1, j]  # d2, kept in out for now
    for j in range(k):
        out[0, j] = 2.0 * out[1, j] - out[2, j]
        out[n - 1, j] = 2.0 * out[n - 2, j] - out[n - 3, j]
    for i in range(n):
        ii = min(max(i, 2), n - 3)  # d4 at the two first / last: its nearest interior value
        for j in range(k):
            if use_q:
                d4 = (((y[ii + 2, j] - 4.0 * y[ii + 1, j]) + 6.0 * y[ii, j]) - 4.0 * y[ii - 1, j]) + y[ii - 2, j]
                out[i, j] = (y[i, j] + q * d4) + c * out[i, j]
            else:
                out[i, j] = y[i, j] + c * out[i, j]


#: The compiled kernels (:mod:`eddi.kernels`: built ahead of time, else numba's JIT).
_KERNELS = Kernels(globals(), {"_through_sampling": ["void(f8[:, ::1], f8, f8, i8, f8[:, ::1])"],
                               "_block_means": ["void(f8[::1], i8, i8, f8[::1])"],
                               "_window_means": ["void(f8[::1], i8[::1], i8, f8[::1])"]})
