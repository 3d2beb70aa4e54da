"""Does one record look AC-coupled? The accelerometer's first-order high-pass, from the drive.

An IEPE accelerometer (or an AC-coupled conditioner) measures ``H(s) = s / (s + w_c)`` of the
acceleration, corner ``f_c = w_c / 2 pi`` typically 0.1-1 Hz. The conditioning integrates
what was measured, so acceleration, velocity and displacement all carry the same phase lead
``atan(f_c / f)`` and the free response alone hardly shows it (a consistent phase shift of
a linear oscillator's signals is another solution of the same equation): the coefficients
are biased through the nonlinear terms and the slow tail only (0.3 Hz on a 5 Hz, 500 kg
system: ``x^3`` +2 %, outside its interval), while the intervals stay tight. What does show
it is the *impact*: simulated from rest and driven by the measured force, the model's
acceleration lags the measured one by ``atan(f_c / f)`` (the drive judge's nrmse 0.033
against 0.010 without the coupling on that system, and the refinement rejected).

:func:`highpass_estimate` fits that lead: the validation simulation's acceleration ``a_s``
(already computed by the pipeline: no new simulation) passed through the coupling,

``y = a_s - w_c z``, ``z' = a_s - w_c z``, ``z(t_0) = v_s(t_0)``

(``z`` is the coupling's integrator, which holds the impulse's velocity at the end of the
short impact), is compared with the measured acceleration over the free response; ``w_c``
minimises the squared difference (a 1-D problem, a few O(n) passes). The coupling is
*evident* when that corner explains most of the drive misfit (:data:`EXPLAINED`), the
corner is plausible for a sensor (:data:`CORNER_RANGE_HZ`, and below :data:`MAX_CORNER_SHARE`
of the structure's frequency) and it stands far above its noise standard error
(:data:`CORNER_SIGMAS`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eddi.conditioning import ConditionedSignal
from eddi.energy import noise_level
from eddi.model import EquationOfMotion
from eddi.validate import Validation

#: Corners a sensor's AC coupling plausibly has [Hz] (IEPE: 0.1-1 Hz; some conditioners 3-5 Hz).
CORNER_RANGE_HZ = (0.05, 5.0)
#: The corner must be below this share of the structure's frequency (above it the coupling is
#: no longer a small phase lead, and the conditioning's drift removal takes part of it).
MAX_CORNER_SHARE = 0.2
#: Share of the drive misfit (squared, beyond the measured noise's) the fitted coupling must
#: remove to be evident.
EXPLAINED = 0.6
#: The corner must exceed this many of its white-noise standard errors.
CORNER_SIGMAS = 10.0


@dataclass(frozen=True)
class CouplingEstimate:
    """The first-order coupling that best explains the drive misfit of one record.

    Attributes
    ----------
    corner_hz : float
        Fitted corner ``f_c`` [Hz] (0 when none improves the fit; may be negative, a lag).
    nrmse_as_is, nrmse_coupled : float
        Acceleration nrmse of the driven simulation against the measured acceleration, as is
        and through the fitted coupling.
    corner_se_hz : float
        White-noise standard error of ``corner_hz`` [Hz].
    noise_nrmse : float
        The share of either nrmse the measured noise accounts for (``sigma sqrt(n) / ||y||``).
    evident : bool
        True when the record looks AC-coupled (see the module notes).
    """

    corner_hz: float
    nrmse_as_is: float
    nrmse_coupled: float
    corner_se_hz: float
    evident: bool
    noise_nrmse: float = 0.0


def _through(a: np.ndarray, z0: float, wc: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(y, z)``: ``a`` through the coupling ``w_c`` [rad/s], integrator starting at ``z0``.

    ``z' = a - w_c z``, trapezoidal (bilinear) steps ``z_n = g z_(n-1) + h (a_n + a_(n-1))``,
    summed in closed form per block (``g^-k`` bounded within a block; numpy only: identify on
    a CSV does not import scipy.signal, tests/station/test_cli_startup.py).
    """
    g = (1.0 - 0.5 * wc * dt) / (1.0 + 0.5 * wc * dt)
    h = 0.5 * dt / (1.0 + 0.5 * wc * dt)
    u = np.empty_like(a)
    u[0] = 0.0
    u[1:] = h * (a[1:] + a[:-1])
    z = np.empty_like(a)
    if g == 1.0:
        z[:] = z0 + np.cumsum(u)
        return a - wc * z, z
    block = max(1, int(30.0 / max(-math.log(abs(g)), 1e-300))) if g > 0 else 1
    start = z0
    for i0 in range(0, a.size, block):
        ub = u[i0:i0 + block]
        k = np.arange(ub.size, dtype=float)
        gk = g**k
        zb = gk * (start + np.cumsum(ub / gk))
        z[i0:i0 + block] = zb
        start = float(zb[-1]) * g  # the next block's first step: g z_last + its u (u sums from k = 0)
    return a - wc * z, z


def highpass_estimate(eom: EquationOfMotion, cond: ConditionedSignal, val: Validation,
                      structure_hz: float) -> CouplingEstimate | None:
    """Fit a first-order accelerometer coupling to one record's driven validation.

    Parameters
    ----------
    eom : EquationOfMotion
        The identified model.
    cond : ConditionedSignal
        Its record (measured acceleration).
    val : Validation
        ``validate_conditioned(eom, cond)[0]`` driven by the measured force (the pipeline's).
    structure_hz : float
        The structure's (lowest) frequency [Hz] in the record.

    Returns
    -------
    CouplingEstimate or None
        None when the record cannot show a coupling (no measured acceleration, a simulation
        that blew up, too short a window).
    """
    if cond.response != "acc" or not cond.acc_measured or not structure_hz > 0:
        return None
    if not (math.isfinite(val.nrmse) and np.all(np.isfinite(val.x_simulated))) or val.x_simulated.size < 20:
        return None
    from eddi.simulate import internal_force  # local: the simulator imports numba

    w0, w1 = val.window
    a_s = -internal_force(eom, val.x_simulated, val.v_simulated) / eom.mass  # after the impact: no force
    y = cond.a[w0:w1]
    if y.size != a_s.size:
        return None
    dt = 1.0 / cond.rate_hz
    z0 = float(val.v_simulated[0])
    norm2 = float(np.sum(y * y)) or 1.0
    sq0 = float(np.sum((a_s - y) ** 2))
    wc, z = 0.0, None
    for _ in range(4):  # Gauss-Newton on w_c: y ~ a_s - w_c z(w_c), z nearly independent of w_c
        ys, z = _through(a_s, z0, wc, dt)
        zz = float(np.sum(z * z))
        if zz <= 0:
            return None
        wc_new = wc + float(np.sum((ys - y) * z)) / zz
        wc_new = min(max(wc_new, -2 * math.pi * CORNER_RANGE_HZ[1]), 2 * math.pi * CORNER_RANGE_HZ[1])
        if abs(wc_new - wc) < 1e-6 * (abs(wc) + 1e-3):
            wc = wc_new
            break
        wc = wc_new
    ys, z = _through(a_s, z0, wc, dt)
    sq1 = float(np.sum((ys - y) ** 2))
    if not math.isfinite(sq1):
        return None
    sigma = noise_level(y)
    se = sigma / math.sqrt(float(np.sum(z * z))) / (2 * math.pi)
    fc = wc / (2 * math.pi)
    evident = bool(CORNER_RANGE_HZ[0] <= fc <= min(CORNER_RANGE_HZ[1], MAX_CORNER_SHARE * structure_hz)
                   and sq1 <= (1.0 - EXPLAINED) * sq0 and fc > CORNER_SIGMAS * se)
    return CouplingEstimate(corner_hz=fc, nrmse_as_is=math.sqrt(sq0 / norm2), nrmse_coupled=math.sqrt(sq1 / norm2),
                            corner_se_hz=se, evident=evident, noise_nrmse=sigma * math.sqrt(y.size / norm2))


def misfit_through(eom: EquationOfMotion, val: Validation, measured: ConditionedSignal, corner_hz: float) -> float:
    """Acceleration nrmse of ``eom``'s driven validation ``val`` (on a record conditioned with
    the coupling inverted) passed through the coupling ``corner_hz``, against the acceleration
    of ``measured`` (the record as measured): like for like with the pipeline's drive judge.
    ``inf`` when the windows differ or the simulation blew up."""
    from eddi.simulate import internal_force

    w0, w1 = val.window
    if not np.all(np.isfinite(val.x_simulated)) or w1 > measured.a.size:
        return math.inf
    a_s = -internal_force(eom, val.x_simulated, val.v_simulated) / eom.mass
    ys, _ = _through(a_s, float(val.v_simulated[0]), 2 * math.pi * corner_hz, 1.0 / measured.rate_hz)
    y = measured.a[w0:w1]
    return float(np.linalg.norm(ys - y) / (np.linalg.norm(y) or 1.0))
