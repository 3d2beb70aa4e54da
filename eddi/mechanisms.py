"""Catalogue of physical mechanisms that diagnosis can add to an equation of motion.

Each mechanism says three things (the physics is written out in ``docs/effects.md``):

* its **signature**: what a test engineer sees when the model lacks it (``symptom``);
* its **regressors**: columns that enter the equation of motion linearly,
  ``m a + sum_j b_j B_j + sum_n k_n K_n + sum_i c_i C_i(x, v; h) = F``, for a given value
  of its few *shape* parameters ``h`` (a gap, a frequency...), found by a small search
  (:meth:`Mechanism.shape_grid`);
* how to turn fitted coefficients into a named :class:`~eddi.model.Effect` of
  :data:`eddi.model.EFFECTS` (:meth:`Mechanism.to_model`), so the extended model is plain
  data the simulator and the simulated rig load.

Everything is pure numerics: arrays in, arrays and models out.
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

from eddi.identify_many import Basis, gap_basis, tanh_basis, term_basis
from eddi.model import Effect, EquationOfMotion
from eddi.terms import parse_term


@dataclass(frozen=True)
class Signal:
    """One measured record as the mechanisms see it.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
        Uniform sample times.
    x, v, a : ndarray, shape (n,)
        Coordinate [m], rate [m/s] and its derivative [m/s^2].
    force : ndarray, shape (n,), [N]
        External force (zeros when not measured).
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    force: np.ndarray

    @property
    def dt(self) -> float:
        return float(self.t[1] - self.t[0])


@dataclass(frozen=True)
class Context:
    """What a mechanism may look at to choose its shape parameters (training data only).

    Attributes
    ----------
    signals : tuple of Signal
        Training records (whole records; the mask says which samples are used).
    masks : tuple of ndarray of bool
        Training samples of each record.
    residual : tuple of ndarray
        Equation-error residual of the baseline fit on each record (``F - m a - base``),
        NaN outside the training samples.
    mass : float
    x_peak, v_peak : float
        Largest ``|x|`` and ``|v|`` over the training samples.
    base_frequency_hz : float
        Linearised natural frequency of the baseline model.
    """

    signals: tuple[Signal, ...]
    masks: tuple[np.ndarray, ...]
    residual: tuple[np.ndarray, ...]
    mass: float
    x_peak: float
    v_peak: float
    base_frequency_hz: float


@dataclass(frozen=True)
class MechanismFit:
    """A mechanism's fitted parameters.

    Attributes
    ----------
    effect : Effect
        The named effect added to the model.
    linear_stiffness_shift : float
        Amount to subtract from the model's ``x`` coefficient (second mode only) [N/m].
    """

    effect: Effect
    linear_stiffness_shift: float = 0.0


class Mechanism(abc.ABC):
    """A physical mechanism: its signature, regressors and conversion to an effect."""

    #: Name, one of :data:`eddi.model.EFFECTS`.
    name: str = ""
    #: One-line physics, for people.
    physics: str = ""
    #: Shape parameters refined continuously (on a log scale) after the grid search.
    refine: tuple[str, ...] = ()
    #: The parameter that says how strong the mechanism is (its spread over folds is checked).
    strength: str = ""
    #: How EDDI fits it natively: ``"damping"`` (phase one), ``"stiffness"`` (phase two) or
    #: ``""`` (not a single-coordinate term: fitted on the baseline's residual force).
    native: str = ""

    def bases(self, shape: dict[str, float], stiffness: tuple[str, ...]) -> tuple[Basis, ...]:
        """EDDI bases of the mechanism, in the order of :meth:`columns` (native ones only)."""
        return ()

    def strength_key(self, stiffness: tuple[str, ...]) -> str:
        """Name of the strength parameter for a baseline with these stiffness terms."""
        return self.strength

    def skip_reason(self, damping: tuple[str, ...], stiffness: tuple[str, ...],
                    effects: tuple[str, ...]) -> str | None:
        """Why this mechanism cannot be added to a model with these terms (None: it can)."""
        if self.name in effects:
            return "already in the model"
        return None

    def shape_grid(self, ctx: Context) -> list[dict[str, float]]:
        """Values of the shape parameters to try (one empty dict when there are none)."""
        return [{}]

    @abc.abstractmethod
    def columns(self, sig: Signal, shape: dict[str, float], stiffness: tuple[str, ...]) -> np.ndarray:
        """Regressors, shape (n, p), for one record."""

    @abc.abstractmethod
    def to_fit(self, coefs: np.ndarray, shape: dict[str, float], mass: float,
               stiffness: tuple[str, ...]) -> MechanismFit | None:
        """The effect for fitted coefficients (None when they are not physical)."""

    @abc.abstractmethod
    def symptom(self, fit: MechanismFit) -> str:
        """What the baseline got wrong, in a test engineer's words."""


def _has(terms: tuple[str, ...], text: str) -> bool:
    key = parse_term(text).canonical()
    return any(parse_term(t).canonical() == key for t in terms)


class CoulombFriction(Mechanism):
    name = "coulomb_friction"
    strength = "force_n"
    physics = "dry (Coulomb) friction: a force of constant size opposing the motion, F_c sign(v)"

    def skip_reason(self, damping, stiffness, effects):
        if _has(damping, "sign(v)"):
            return "sign(v) is already a damping term"
        return super().skip_reason(damping, stiffness, effects)

    def shape_grid(self, ctx):
        # tanh regularisation well below the velocities that matter
        return [{"velocity_scale": float(np.clip(1e-3 * ctx.v_peak, 1e-7, 1e-4))}]

    native = "damping"

    def bases(self, shape, stiffness):
        return (tanh_basis(shape["velocity_scale"]),)

    def columns(self, sig, shape, stiffness):
        return np.tanh(sig.v / shape["velocity_scale"])[:, None]

    def to_fit(self, coefs, shape, mass, stiffness):
        if not coefs[0] > 0:
            return None
        return MechanismFit(Effect(name=self.name, params={
            "force_n": float(coefs[0]), "velocity_scale": shape["velocity_scale"]}))

    def symptom(self, fit):
        f = fit.effect.params["force_n"]
        return ("loses energy per cycle in proportion to amplitude, so the loss dominates at low "
                f"amplitude and the ring-down ends in a straight-line decay: dry friction "
                f"(about {f:.3g} N)")


class QuadraticDamping(Mechanism):
    name = "quadratic_damping"
    strength = "coefficient"
    physics = "quadratic (aerodynamic, turbulent) drag: c_q |v| v"

    def skip_reason(self, damping, stiffness, effects):
        if _has(damping, "abs(v)*v"):
            return "abs(v)*v is already a damping term"
        return super().skip_reason(damping, stiffness, effects)

    native = "damping"

    def bases(self, shape, stiffness):
        return (term_basis("abs(v)*v"),)

    def columns(self, sig, shape, stiffness):
        return (np.abs(sig.v) * sig.v)[:, None]

    def to_fit(self, coefs, shape, mass, stiffness):
        if not coefs[0] > 0:
            return None
        return MechanismFit(Effect(name=self.name, params={"coefficient": float(coefs[0])}))

    def symptom(self, fit):
        c = fit.effect.params["coefficient"]
        return ("loses energy per cycle growing like amplitude cubed, so it decays fast at high "
                f"amplitude and slows down at low amplitude: quadratic drag (about {c:.3g} N s^2/m^2)")


class Clearance(Mechanism):
    name = "clearance"
    strength = "stiffness_n_per_m"
    refine = ("gap_m",)
    physics = ("contact beyond a gap g: an extra spring k_c (|x| - g) sign(x) acts only when "
               "|x| > g")

    def shape_grid(self, ctx):
        # gaps between 5 % and 90 % of the largest training amplitude, denser at small gaps
        return [{"gap_m": float(ctx.x_peak * f)} for f in np.linspace(0.05, 0.9, 20)]

    native = "stiffness"

    def bases(self, shape, stiffness):
        return (gap_basis(shape["gap_m"]),)

    def columns(self, sig, shape, stiffness):
        g = shape["gap_m"]
        return (np.sign(sig.x) * np.maximum(np.abs(sig.x) - g, 0.0))[:, None]

    def to_fit(self, coefs, shape, mass, stiffness):
        if not coefs[0] > 0:
            return None
        return MechanismFit(Effect(name=self.name, params={
            "gap_m": shape["gap_m"], "stiffness_n_per_m": float(coefs[0])}))

    def symptom(self, fit):
        g = fit.effect.params["gap_m"]
        k = fit.effect.params["stiffness_n_per_m"]
        return (f"gets the frequency wrong once the amplitude passes about {g * 1e3:.3g} mm: the "
                f"stiffness steps up by about {k:.3g} N/m beyond a gap: clearance (contact)")


class AsymmetricStiffness(Mechanism):
    name = "asymmetric_stiffness"
    strength = "k2"
    physics = "even-order stiffness k2 x^2 + k4 x^4: the spring is stiffer on one side"

    def _missing(self, stiffness: tuple[str, ...]) -> list[int]:
        return [p for p in (2, 4) if not _has(stiffness, f"x^{p}")]

    def strength_key(self, stiffness):
        missing = self._missing(stiffness)
        return f"k{missing[0]}" if missing else "k2"

    def skip_reason(self, damping, stiffness, effects):
        if not self._missing(stiffness):
            return "x^2 and x^4 are already stiffness terms"
        return super().skip_reason(damping, stiffness, effects)

    native = "stiffness"

    def bases(self, shape, stiffness):
        return tuple(term_basis(f"x^{p}") for p in self._missing(stiffness))

    def columns(self, sig, shape, stiffness):
        return np.column_stack([sig.x**p for p in self._missing(stiffness)])

    def to_fit(self, coefs, shape, mass, stiffness):
        params = {"k2": 0.0, "k4": 0.0}
        for p, c in zip(self._missing(stiffness), coefs):
            params[f"k{p}"] = float(c)
        return MechanismFit(Effect(name=self.name, params=params))

    def symptom(self, fit):
        k2 = fit.effect.params["k2"]
        side = "positive" if k2 > 0 else "negative"
        return ("drifts in phase and its response is lopsided: the restoring force is larger on "
                f"the {side} side than on the other (even-order stiffness, k2 about {k2:.3g} "
                "N/m^2): asymmetric stiffness")


class SecondMode(Mechanism):
    """A second, linear mode coupled to the measured coordinate.

    With symmetric coupling ``k_c`` the force on ``x`` is ``k_c x - k_c y`` and
    ``y = k_c x / (m2 s^2 + c2 s + k2m + k_c)``. Writing ``w2^2 = (k2m + k_c)/m2`` and
    ``g = G x`` with the unit-gain filter ``G = w2^2 / (s^2 + 2 z2 w2 s + w2^2)``, the force is
    ``k_c x - (k_c^2 / (m2 w2^2)) g``: linear in the columns ``x`` and ``g`` once ``(w2, z2)``
    are fixed. Only ``k_c^2 / m2`` is observable from ``x``; the modal mass is set to the
    main mass (raised if needed to keep ``k2m >= 0``).
    """

    name = "second_mode"
    strength = "coupling_n_per_m"
    refine = ("frequency_hz", "damping_ratio")
    physics = ("a second linear mode (mass m2, stiffness k2, damping c2) coupled to the measured "
               "coordinate by a spring k_c")

    def shape_grid(self, ctx):
        fs = 1.0 / ctx.signals[0].dt
        f1 = ctx.base_frequency_hz
        freqs, power = _residual_spectrum(ctx, fs)
        if freqs.size == 0:
            return []
        keep = (freqs > 0.3 * f1) & (freqs < 0.45 * fs)
        # away from the baseline's own frequency and its first harmonics
        for h in (1, 2, 3):
            keep &= np.abs(freqs - h * f1) > 0.15 * f1
        if not np.any(keep):
            return []
        idx = np.flatnonzero(keep)
        order = idx[np.argsort(power[idx])[::-1]]
        peaks: list[float] = []
        for i in order:
            f = float(freqs[i])
            if all(abs(f - p) > 0.1 * p for p in peaks):
                peaks.append(f)
            if len(peaks) == 1:
                break
        grid = []
        for fp in peaks:
            for f in fp * np.linspace(0.92, 1.08, 9):
                for z in (0.005, 0.02, 0.05):
                    grid.append({"frequency_hz": float(f), "damping_ratio": z})
        return grid

    # not a single-coordinate term: the force it puts on x depends on the history of x. In
    # EDDI its power v g is nearly collinear with v^2 (g ~ x - 2 z v / w2 + ...), so phase one
    # cannot tell it from viscous damping; it is refitted jointly with the baseline terms by
    # equation error instead (``native`` stays empty)

    def columns(self, sig, shape, stiffness):
        return _mode_filter(sig.x, shape["frequency_hz"], shape["damping_ratio"], sig.dt)[:, None]

    def to_fit(self, coefs, shape, mass, stiffness):
        cg = float(coefs[0])
        if not cg < 0:
            return None
        w = 2 * math.pi * shape["frequency_hz"]
        m2 = max(mass, 4.0 * -cg / (w * w))
        kc = math.sqrt(-cg * m2 * w * w)
        k2m = m2 * w * w - kc
        c2 = 2 * shape["damping_ratio"] * w * m2
        eff = Effect(name=self.name, params={
            "mass_kg": m2, "stiffness_n_per_m": k2m, "damping_n_s_per_m": c2,
            "coupling_n_per_m": kc})
        return MechanismFit(eff, linear_stiffness_shift=kc)

    def symptom(self, fit):
        p = fit.effect.params
        f2 = math.sqrt((p["stiffness_n_per_m"] + p["coupling_n_per_m"]) / p["mass_kg"]) / (2 * math.pi)
        return (f"misses response energy at a second frequency near {f2:.4g} Hz that a single "
                "mode cannot produce: a second mode")


def _mode_filter(x: np.ndarray, frequency_hz: float, damping_ratio: float, dt: float) -> np.ndarray:
    """``g = G x`` with the unit-gain filter ``w^2 / (s^2 + 2 z w s + w^2)`` (bilinear transform)."""
    w = 2 * math.pi * frequency_hz
    z = damping_ratio
    k = 2.0 / dt
    a = np.array([k * k + 2 * z * w * k + w * w, 2 * (w * w - k * k), k * k - 2 * z * w * k + w * w])
    b = w * w * np.array([1.0, 2.0, 1.0])
    return signal.lfilter(b / a[0], a / a[0], x)


def _residual_spectrum(ctx: Context, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Energy spectrum of the baseline's equation-error residual over the training samples.

    One FFT per record over its training samples (zeros elsewhere), power summed over
    records: a decaying second mode puts its energy in a narrow peak even when it rings for
    a small part of the record, while the measurement noise spreads evenly.
    """
    n = max(s.x.size for s in ctx.signals)
    nfft = 1 << int(math.ceil(math.log2(max(n, 64))))
    total = np.zeros(nfft // 2 + 1)
    for r in ctx.residual:
        seg = np.nan_to_num(r, nan=0.0)
        total += np.abs(np.fft.rfft(seg, nfft)) ** 2
    freqs = np.fft.rfftfreq(nfft, 1.0 / fs)
    # smooth over about 1 Hz so one noisy bin does not win
    width = max(1, int(round(1.0 / (freqs[1] - freqs[0]))))
    kernel = np.ones(width) / width
    return freqs, np.convolve(total, kernel, mode="same")


def catalogue() -> tuple[Mechanism, ...]:
    """Every mechanism diagnosis tries, in a fixed order."""
    return (CoulombFriction(), QuadraticDamping(), Clearance(), AsymmetricStiffness(), SecondMode())


#: Names of the catalogue, in order.
MECHANISM_NAMES: tuple[str, ...] = (
    "coulomb_friction", "quadratic_damping", "clearance", "asymmetric_stiffness", "second_mode")


def extend(base: EquationOfMotion, fit: MechanismFit) -> EquationOfMotion:
    """``base`` with the fitted mechanism added (and its ``x`` coefficient shifted if needed)."""
    eom = base.with_effect(fit.effect)
    if fit.linear_stiffness_shift:
        stiff = dict(eom.stiffness)
        for text in stiff:
            if parse_term(text).exponents == (1, 0, 0, 0, 0, 0):
                stiff[text] = stiff[text] - fit.linear_stiffness_shift
                break
        else:
            stiff["x"] = -fit.linear_stiffness_shift
        eom = eom.model_copy(update={"stiffness": stiff})
    return eom
