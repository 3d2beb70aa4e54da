"""Is a model physically sound at the record's amplitudes, and does its response behave?

Two families of checks, each returning plain sentences (no printing):

* :func:`model_warnings`: the model's own forces over the measured range: a negative secant
  stiffness ``K(x) / x`` (the restoring force pushes away from equilibrium: a model that
  cannot ring down about ``x = 0``) or a negative damping power ``B(x, v) v`` (the model
  feeds energy in) at some ``|x| <= x_max``, ``|v| <= v_max``;
* :func:`response_warnings`: the simulated response against the measured one over the
  compared window: a simulation that blows up, exceeds the measurement's peak by
  :data:`PEAK_RATIO`, grows (late envelope above the early one by :data:`GROWTH`), or
  does not decay where the measurement does (:data:`DECAYS` / :data:`STEADY`).

Any response warning makes the validation ``diverged``: its nrmse is then not a
meaningful score of a good model (it says how far a wrong one went).
"""

from __future__ import annotations

import math

import numpy as np

from eddi.model import EquationOfMotion
from eddi.peaks import finite, peak_abs

#: A simulation whose peak exceeds the measured peak by this factor has diverged.
PEAK_RATIO = 2.0
#: A simulated envelope (last fifth / first fifth of the window) above this grows.
GROWTH = 1.1
#: A measured envelope ratio below this decays ...
DECAYS = 0.5
#: ... and a simulated one above this then does not.
STEADY = 0.9
#: Grid points per axis of the model checks.
GRID = 41
#: A displacement nrmse above this is a poor reproduction whatever the noise: 10 % of the
#: response unexplained is several times the error a 30 dB sensor alone leaves (~3 %).
POOR_FIT_NRMSE = 0.1


def envelope_ratio(y: np.ndarray) -> float:
    """Peak ``|y|`` over the last fifth of ``y`` over that of the first fifth (inf for 0 start)."""
    y = np.asarray(y, dtype=float)
    k = max(1, y.size // 5)
    early = peak_abs(y[:k])  # the two fifths only (not |y| of all of it)
    late = peak_abs(y[-k:])
    return late / early if early > 0 else (np.inf if late > 0 else 1.0)


def response_warnings(x_measured: np.ndarray, x_simulated: np.ndarray, blew_up: bool = False) -> tuple[str, ...]:
    """Why a simulated response is not a valid prediction (empty when it is fine).

    Parameters
    ----------
    x_measured, x_simulated : ndarray, shape (k,)
        Over the compared window.
    blew_up : bool
        The simulator stopped on a non-finite or runaway state.

    Returns
    -------
    tuple of str
    """
    xs = np.asarray(x_simulated, dtype=float)
    xm = np.asarray(x_measured, dtype=float)
    peak_s = peak_abs(xs) if xs.size else 0.0  # NaN or inf exactly when xs holds one
    if blew_up or not math.isfinite(peak_s):
        return ("the simulated response blows up (non-finite or runaway)",)
    out: list[str] = []
    peak_m = peak_abs(xm) if xm.size else 0.0
    if peak_m > 0 and peak_s > PEAK_RATIO * peak_m:
        out.append(f"the simulated response reaches {peak_s / peak_m:.3g}x the measured peak")
    rm, rs = envelope_ratio(xm), envelope_ratio(xs)
    if rs > GROWTH and rs > 1.5 * rm:
        out.append(f"the simulated free response grows (envelope x{rs:.3g} from the first to the last fifth "
                   f"of the window; measured x{rm:.3g})")
    elif rm < DECAYS and rs > STEADY:
        out.append(f"the simulated response does not decay (envelope x{rs:.3g}) where the measurement does "
                   f"(x{rm:.3g})")
    return tuple(out)


def poor_fit_warnings(fit_nrmse: float, held_out_nrmse: "list[float] | tuple[float, ...]" = ()) -> tuple[str, ...]:
    """A sentence when the model reproduces its own record or the held-out ones poorly.

    Parameters
    ----------
    fit_nrmse : float
        Displacement nrmse of the simulation of the record the model was fitted on.
    held_out_nrmse : sequence of float
        The same on each held-out record.

    Returns
    -------
    tuple of str
        Empty when every finite nrmse is within :data:`POOR_FIT_NRMSE`; a non-finite nrmse
        is left to the divergence warnings.
    """
    out = []
    if np.isfinite(fit_nrmse) and fit_nrmse > POOR_FIT_NRMSE:
        out.append(f"poor fit: the model reproduces the record it was fitted on with displacement nrmse "
                   f"{fit_nrmse:.3g} (> {POOR_FIT_NRMSE:g}): a mechanism outside the term library or a "
                   f"measurement problem; `station diagnose` on several captures names it or lists the symptoms")
    bad = [n for n in held_out_nrmse if np.isfinite(n) and n > POOR_FIT_NRMSE]
    if bad:
        out.append(f"poor prediction: held-out displacement nrmse up to {max(bad):.3g} (> {POOR_FIT_NRMSE:g}) "
                   f"on {len(bad)} of {len(held_out_nrmse)} held-out records")
    return tuple(out)


def model_warnings(eom: EquationOfMotion, x: np.ndarray, v: np.ndarray) -> tuple[str, ...]:
    """Negative stiffness or damping of ``eom`` along the measured trajectory.

    Parameters
    ----------
    eom : EquationOfMotion
    x, v : ndarray, shape (n,)
        Measured coordinate and rate over the free response.

    Returns
    -------
    tuple of str
        Empty when the linear stiffness and the secant stiffness ``K(x)/x`` over
        ``[min x, max x]`` are >= 0 and every half cycle of the record dissipates energy
        (``sum B(x, v) v >= 0`` between zero crossings of ``x``; the instantaneous power
        of a model such as ``b1 v - b2 x^2 v`` may be negative near the turning points).
    """
    x = np.asarray(x, dtype=float)
    v = np.asarray(v, dtype=float)
    out: list[str] = []
    if x.size < 4 or not (finite(x) and finite(v)):
        return ()
    k1 = eom.linear_stiffness()
    if k1 < 0:
        out.append(f"negative linear stiffness k[x] = {k1:.4g} N/m: the model has no stable equilibrium at "
                   f"x = 0 (friction or a missing term forced into the stiffness?)")
    grid = np.linspace(float(np.min(x)), float(np.max(x)), GRID)
    grid = grid[np.abs(grid) > 1e-12 * float(np.max(np.abs(grid)) or 1.0)]
    ks = np.zeros_like(grid)
    for text, c in eom.stiffness.items():
        ks = ks + c * _term(text)(grid, np.zeros_like(grid))
    secant = ks / grid
    if k1 >= 0 and np.any(secant < 0):
        bad = grid[secant < 0]
        out.append(f"negative stiffness K(x)/x < 0 at x = {float(bad[np.argmax(np.abs(bad))]):.3g} (the record "
                   f"spans {grid[0]:.3g} .. {grid[-1]:.3g}): the restoring force pushes away from equilibrium")
    neg = np.signbit(x)
    edges = np.flatnonzero(neg[1:] != neg[:-1]) + 1
    starts = np.concatenate(([0], edges))
    sizes = np.diff(np.concatenate((starts, [x.size])))
    sums = _half_cycle_power(eom, x, v, starts)[sizes > 1]
    scale = peak_abs(sums) if sums.size else 0.0
    if scale > 0 and np.any(sums < -1e-6 * scale):
        out.append(f"negative damping: the model feeds energy in over {int(np.sum(sums < -1e-6 * scale))} of "
                   f"{sums.size} half cycles of the record (b[v] = {eom.damping.get('v', 0.0):.4g} N s/m)")
    elif k1 > 0:
        cycle = self_excited_amplitude(eom, peak_abs(x))
        if cycle is not None:
            unit = "rad" if "rad" in eom.coordinate else "m"
            out.append(f"negative damping at small amplitude: below about {cycle:.3g} {unit} (the record reaches "
                       f"{peak_abs(x):.3g} {unit}) the model feeds energy in over every cycle (b[v] = "
                       f"{eom.damping.get('v', 0.0):.4g} N s/m), so its rest is unstable: it does not ring down "
                       f"to rest but grows to a limit cycle (a damping term of the wrong sign the fit needed "
                       f"for the record's amplitudes?)")
    return tuple(out)


#: Amplitudes (shares of the record's largest ``|x|``) at which :func:`self_excited_amplitude`
#: looks for a cycle that gains energy: down to this share (a limit cycle below a thousandth of
#: the record's amplitude is below the noise of any sensor a record here came from: 60 dB) ...
SELF_EXCITED_SHARE = 1e-3
#: ... on this many amplitudes (log grid) and phase points per cycle.
SELF_EXCITED_GRID = (48, 256)


def self_excited_amplitude(eom: EquationOfMotion, x_max: float) -> float | None:
    """The largest amplitude at or below ``x_max`` under which a harmonic cycle at the linear
    natural frequency gains energy from the damping (``sum B(x, v) v < 0`` over the cycle) while
    the cycle at :data:`SELF_EXCITED_SHARE` of ``x_max`` gains too: the model's rest is unstable
    and its response grows to a limit cycle of about that amplitude; None when the smallest
    cycle dissipates (a stable rest; a Coulomb term dominates there, for one) or there is no
    positive linear stiffness to set the frequency."""
    k1, m = eom.linear_stiffness(), float(eom.mass)
    if not (k1 > 0 and m > 0 and x_max > 0 and np.isfinite(x_max)):
        return None
    w = float(np.sqrt(k1 / m))
    n_amp, n_ph = SELF_EXCITED_GRID
    amps = np.geomspace(SELF_EXCITED_SHARE * x_max, x_max, n_amp)
    th = np.linspace(0.0, 2.0 * np.pi, n_ph, endpoint=False)
    xs = np.outer(amps, np.sin(th)).ravel()
    vs = np.outer(amps * w, np.cos(th)).ravel()
    work = (_damping_force(eom, xs, vs) * vs).reshape(n_amp, n_ph).sum(axis=1)
    scale = peak_abs(work) or 1.0
    gains = work < -1e-9 * scale * (amps / x_max) ** 2  # the work of a linear dashpot scales with A^2
    if not gains[0]:
        return None
    return float(amps[np.argmin(gains)]) if not gains.all() else float(x_max)


#: Samples per piece of :func:`_half_cycle_power` (0.5 MB an array: the pieces stay in cache).
POWER_CHUNK = 65536


def _half_cycle_power(eom: EquationOfMotion, x: np.ndarray, v: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """``np.add.reduceat(_damping_force(eom, x, v) * v, starts)``, the same doubles, in pieces
    of about :data:`POWER_CHUNK` samples that begin and end at ``starts`` (each sum reads its own
    half cycle alone, and the force is formed sample by sample: bit for bit), so the force, the
    power and their temporaries stay in cache instead of being record-length arrays."""
    n = x.size
    sums = np.empty(starts.size)
    i = 0
    while i < starts.size:
        lo = int(starts[i])
        j = max(i + 1, int(np.searchsorted(starts, lo + POWER_CHUNK, side="right")) - 1)
        hi = int(starts[j]) if j < starts.size else n
        xs, vs = x[lo:hi], v[lo:hi]
        sums[i:j] = np.add.reduceat(_damping_force(eom, xs, vs) * vs, starts[i:j] - lo)
        i = j
    return sums


def _damping_force(eom: EquationOfMotion, x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``sum b_j B_j(x, v)`` with integer powers as repeated products.

    For the sign of the damping power per half cycle only: the simulator's general compiled
    kernel (``eddi.simulate.internal_force``) took ~9 ms on 460k samples for three monomials and
    numpy's ``v**3`` (``pow``) ~19 ms; products take ~1 ms. The same sums to a few ulps.
    """
    out = None
    ax, av = None, None
    for text, c in eom.damping.items():
        px, pv, pax, pav, sx, sv = _term(text).exponents
        if pax and ax is None:
            ax = np.abs(x)
        if pav and av is None:
            av = np.abs(v)
        # c times each factor in turn (the first product formed from c directly: c * base is the
        # product a filled array times base gave); the first term starts the sum
        f = None
        for base, p in ((x, px), (v, pv), (ax, pax), (av, pav)):
            for _ in range(p):
                if f is None:
                    f = np.multiply(base, c, dtype=float)
                else:
                    f *= base
        if f is None:
            f = np.full_like(v, c)
        if sx % 2:
            f *= np.sign(x)
        if sv % 2:
            f *= np.sign(v)
        if out is None:
            out = f
            out += 0.0  # 0 + f, as the sum from zeros formed it (-0.0 becomes 0.0)
        else:
            out += f
    return np.zeros_like(v) if out is None else out


def _term(text: str):  # local import keeps this module light
    from eddi.terms import parse_term

    return parse_term(text)
