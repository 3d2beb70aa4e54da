"""A second-order recursive (IIR) filter, compiled: ``scipy.signal.lfilter`` for a biquad.

The diagnosis' hidden-second-mode candidate filters the coordinate through a unit-gain
second-order section for every shape it tries (hundreds of calls per diagnosis).
``scipy.signal.lfilter`` gives the numbers, but importing ``scipy.signal`` imports
``scipy.stats`` with it: ~0.45 s of CPU at the start of every ``station diagnose``, 10 % of
the three-capture diagnosis (session 10, ``benchmarks/bench_diagnose_speed.py``). This kernel
is lfilter's direct form II transposed for ``len(b) == len(a) == 3`` with ``a[0] == 1``, the
same operations in the same order (no fast-math): the same numbers bit for bit
(``tests/eddi/test_iir.py``), at about half lfilter's time per call. It is compiled like the
simulator's kernels (:mod:`eddi.kernels`).
"""

from __future__ import annotations

import numpy as np

from eddi.kernels import Kernels


def _biquad(b0: float, b1: float, b2: float, a1: float, a2: float, x: np.ndarray, y: np.ndarray) -> None:
    z0 = 0.0
    z1 = 0.0
    for n in range(x.size):
        xn = x[n]
        yn = z0 + b0 * xn
        z0 = z1 + xn * b1 - yn * a1
        z1 = xn * b2 - yn * a2
        y[n] = yn


def biquad(b: np.ndarray, a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``scipy.signal.lfilter(b, a, x)`` for a second-order section, from rest.

    Parameters
    ----------
    b, a : array_like, shape (3,)
        Numerator and denominator; ``a[0]`` must be 1 (normalise first).
    x : ndarray, shape (n,)
        Input.

    Returns
    -------
    ndarray, shape (n,)
    """
    b = np.asarray(b, dtype=float)
    a = np.asarray(a, dtype=float)
    if b.shape != (3,) or a.shape != (3,) or a[0] != 1.0:
        raise ValueError("biquad takes b and a of length 3 with a[0] == 1")
    x = np.ascontiguousarray(x, dtype=float)
    if x.ndim != 1:
        raise ValueError("biquad filters one 1-D signal")
    y = np.empty_like(x)
    _KERNELS._biquad(float(b[0]), float(b[1]), float(b[2]), float(a[1]), float(a[2]), x, y)
    return y


#: The compiled kernel (:mod:`eddi.kernels`: built ahead of time, else numba's JIT).
_KERNELS = Kernels(globals(), {
    "_biquad": ["void(f8, f8, f8, f8, f8, f8[::1], f8[::1])"],
})
