"""Validation of an equation of motion against a measured response.

:func:`validate` simulates the model (compiled RK4, :func:`eddi.simulate.simulate`) and
compares it with the measurement over a window:

* with a measured ``force``: from rest (or ``x0, v0``) at ``t[0]``, driven by the force;
* without: a free response from the measured state at the start of the window.

Densely sampled records are simulated on a coarser grid after the force has ended and
interpolated back (:func:`eddi.simulate.simulate_dense`, ~1e-5 of the amplitude).

Figures of merit: ``nrmse = ||x_sim - x||_2 / ||x||_2`` and
``nmte = mean |v_sim - v| / max |v|`` over the window. :func:`spectra` and
:func:`cwt_map` give the Fourier and Morlet-wavelet views used in the paper's figures.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eddi.energy import check_series, sample_window
from eddi.errors import SignalError
from eddi.model import EquationOfMotion
from eddi.peaks import finite, misfit_sums, peak_abs
from eddi.simulate import simulate, simulate_dense
from eddi.stability import response_warnings


@dataclass(frozen=True)
class Validation:
    """A simulated response compared with the measured one, over a window.

    Attributes
    ----------
    nrmse : float
        ``||x_sim - x||_2 / ||x||_2`` over the window (``inf`` if the simulation diverged).
    nmte : float or None
        ``mean |v_sim - v| / max |v|`` over the window, when ``v`` was given.
    t : ndarray, shape (k,), [s]
        Times of the window.
    x_measured, x_simulated : ndarray, shape (k,)
    v_measured : ndarray, shape (k,) or None
    v_simulated : ndarray, shape (k,)
    window : tuple of int
        ``[start, stop)`` sample indices compared.
    diverged : bool
        True when the simulation blew up, exceeds the measured peak by
        :data:`eddi.stability.PEAK_RATIO`, grows, or does not decay where the measurement
        does (:func:`eddi.stability.response_warnings`).
    warnings : tuple of str
        Why it diverged, in plain sentences (empty otherwise).
    every : int
        The arrays hold every ``every``-th sample of the window from its first (1: all), and
        ``nrmse``, ``nmte``, ``diverged`` were computed on those (:func:`validate`'s ``every``).
    """

    nrmse: float
    nmte: float | None
    t: np.ndarray
    x_measured: np.ndarray
    x_simulated: np.ndarray
    v_measured: np.ndarray | None
    v_simulated: np.ndarray
    window: tuple[int, int]
    diverged: bool
    warnings: tuple[str, ...] = ()
    every: int = 1


def validate(
    eom: EquationOfMotion,
    t: np.ndarray,
    x: np.ndarray,
    *,
    v: np.ndarray | None = None,
    force: np.ndarray | None = None,
    window: tuple[int, int] | None = None,
    x0: float | None = None,
    v0: float | None = None,
    every: int = 1,
) -> Validation:
    """Simulate ``eom`` and compare it with a measured response.

    Parameters
    ----------
    eom : EquationOfMotion
    t : ndarray, shape (n,), [s]
        Uniform, increasing.
    x : ndarray, shape (n,)
        Measured coordinate.
    v : ndarray, shape (n,), optional
        Measured rate (needed for ``nmte``, and for the initial rate of a free response
        unless ``v0`` is given; otherwise estimated by ``numpy.gradient``).
    force : ndarray, shape (n,), [N], optional
        Measured external force. When given, the simulation starts at ``t[0]`` from
        ``(x0, v0)`` (default rest) and is driven by it.
    window : tuple of int, optional
        ``[start, stop)`` sample indices to compare (default: all).
    x0, v0 : float, optional
        Initial state, overriding the defaults above.
    every : int
        Compare every ``every``-th sample of the window only (from its first): a driven
        simulation is then interpolated at those samples alone (:func:`simulate_dense`'s
        ``at``); the refinement's judge reads no more of EDDI's validation (session 15).

    Returns
    -------
    Validation

    Raises
    ------
    SignalError
        On bad signals or window.
    """
    # the driven simulation's scales, read first: a finite peak says the array is finite, so
    # check_series skips that array's finite pass (a NaN or inf gives a NaN or inf peak: checked
    # there as before, with its message)
    amps = {name: peak_abs(y) for name, y in (("x", x), ("v", v)) if _plain(y, t)} if force is not None else {}
    t, sig = check_series(t, {"x": x, "v": v, "force": force}, min_samples=2,
                          finite=tuple(name for name, amp in amps.items() if math.isfinite(amp)))
    x = sig["x"]
    v = sig["v"]
    f = sig["force"]
    n = t.size
    w0, w1 = sample_window(window, n, 2)
    if f is not None:
        x_amp = amps["x"] if "x" in amps else peak_abs(x)
        v_amp = (amps["v"] if "v" in amps else peak_abs(v)) if v is not None else 0.0
        x0f, v0f = 0.0 if x0 is None else float(x0), 0.0 if v0 is None else float(v0)
        every = max(1, int(every))
        if x_amp > 0 and v_amp > 0:
            at = None if every == 1 else np.arange(w0, w1, every)
            sim = simulate_dense(eom, t, force=f, x0=x0f, v0=v0f, x_scale=x_amp, v_scale=v_amp, at=at)
            xs, vs, div = (sim.x[w0:w1], sim.v[w0:w1], sim.diverged) if at is None else (sim.x, sim.v, sim.diverged)
        else:
            sim = simulate(eom, t, force=f, x0=x0f, v0=v0f, x_scale=x_amp or None,
                           v_scale=v_amp if v is not None else None)
            xs, vs, div = sim.x[w0:w1:every], sim.v[w0:w1:every], sim.diverged
    else:
        every = 1  # a free response: every sample
        if v0 is None:
            v_est = v if v is not None else np.gradient(x, t)
            v0 = float(v_est[w0])
        x0 = float(x[w0]) if x0 is None else float(x0)
        tw = t[w0:w1]
        xw = x[w0:w1]
        x_amp = max(peak_abs(xw), abs(x0))
        if v is not None and x_amp > 0:
            v_amp = max(peak_abs(v[w0:w1]), abs(float(v0)))
            sim = simulate_dense(eom, tw - tw[0], x0=x0, v0=float(v0), x_scale=x_amp, v_scale=v_amp)
        else:
            sim = simulate(eom, tw - tw[0], x0=x0, v0=float(v0), x_scale=x_amp, v_scale=None)
        xs, vs, div = sim.x, sim.v, sim.diverged
    xm = x[w0:w1:every]
    vm = v[w0:w1:every] if v is not None else None
    warnings = response_warnings(xm, xs, blew_up=bool(div))
    denom = float(np.linalg.norm(xm)) or 1.0
    if div or not finite(xs):
        nrmse = float("inf")
        nmte = float("inf") if vm is not None else None
    else:
        # one pass, no record-length differences (eddi.peaks.misfit_sums: numpy's sums to rounding)
        sums = misfit_sums(xs, xm, vs, vm) if vm is not None else misfit_sums(xs, xm)
        nrmse = float(math.sqrt(sums[0]) / denom) if sums else float(np.linalg.norm(xs - xm) / denom)
        nmte = None
        if vm is not None:
            vmax = peak_abs(vm) or 1.0
            nmte = float(sums[1] / vm.size / vmax) if sums else float(np.mean(np.abs(vs - vm)) / vmax)
    return Validation(
        nrmse=nrmse, nmte=nmte, t=t[w0:w1:every], x_measured=xm, x_simulated=xs,
        v_measured=vm, v_simulated=vs, window=(w0, w1), diverged=bool(div) or bool(warnings),
        warnings=warnings, every=every,
    )


def _plain(y: np.ndarray | None, t: np.ndarray) -> bool:
    """``y`` is a 1-D float64 array of >= 2 samples as long as ``t`` (what :func:`validate` reads unchanged)."""
    return (isinstance(y, np.ndarray) and y.dtype == np.float64 and y.ndim == 1 and y.size >= 2
            and y.shape == np.shape(t))


def spectra(t: np.ndarray, x_measured: np.ndarray, x_simulated: np.ndarray) -> dict[str, np.ndarray]:
    """One-sided Fourier amplitude spectra of a measured and a simulated response.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Uniform time.
    x_measured, x_simulated : ndarray, shape (n,)

    Returns
    -------
    dict
        ``freq_hz`` (shape (n//2+1,)), ``measured`` and ``simulated`` amplitudes (same unit
        as ``x``; a sinusoid of amplitude A that fits the record gives a peak of A).
    """
    t, sig = check_series(t, {"x_measured": x_measured, "x_simulated": x_simulated}, min_samples=2)
    n = t.size
    dt = float(t[1] - t[0])
    freq = np.fft.rfftfreq(n, dt)

    def amp(y: np.ndarray) -> np.ndarray:
        s = np.abs(np.fft.rfft(y)) * 2.0 / n
        s[0] *= 0.5
        if n % 2 == 0:
            s[-1] *= 0.5
        return s

    return {"freq_hz": freq, "measured": amp(sig["x_measured"]), "simulated": amp(sig["x_simulated"])}


def cwt_map(t: np.ndarray, x: np.ndarray, freqs_hz: np.ndarray, omega0: float = 6.0) -> np.ndarray:
    """Magnitude of the Morlet continuous wavelet transform, computed with FFTs.

    Each scale is an analytic Gaussian band-pass ``G(w) = 2 exp(-(s w - omega0)^2 / 2)``
    for ``w > 0`` (zero otherwise) with ``s = omega0 / (2 pi f)``; the magnitude is
    normalised so a steady sinusoid of amplitude ``A`` at ``f`` gives about ``A``.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
        Uniform time.
    x : ndarray, shape (n,)
    freqs_hz : ndarray, shape (m,), [Hz]
        Positive analysis frequencies.
    omega0 : float
        Morlet centre frequency (6 trades time against frequency resolution).

    Returns
    -------
    ndarray, shape (m, n)
        ``|W(f, t)|``.
    """
    t, sig = check_series(t, {"x": x}, min_samples=2)
    freqs = np.atleast_1d(np.asarray(freqs_hz, dtype=float))
    if freqs.ndim != 1 or np.any(~np.isfinite(freqs)) or np.any(freqs <= 0):
        raise SignalError("freqs_hz must be positive, finite frequencies")
    n = t.size
    dt = float(t[1] - t[0])
    nfft = 1 << int(np.ceil(np.log2(2 * n)))  # zero-pad against wrap-around
    xf = np.fft.fft(sig["x"] - np.mean(sig["x"]), nfft)
    w = 2.0 * np.pi * np.fft.fftfreq(nfft, dt)
    out = np.empty((freqs.size, n))
    for i, f in enumerate(freqs):
        s = omega0 / (2.0 * np.pi * f)
        g = np.where(w > 0, 2.0 * np.exp(-0.5 * (s * w - omega0) ** 2), 0.0)
        out[i] = np.abs(np.fft.ifft(xf * g)[:n])
    return out
