"""Named oscillators of the paper, as :class:`~eddi.model.EquationOfMotion` data.

Every number carries its source in the paper (``/work/shared/seed/eddi-paper.md``):

``paper-duffing``
    Sec. 3.1, Eq. 17: ``m=0.05 kg, b=0.5 N s/m, b_nl=4000 N s/m^3 (x^2*v), k=300 N/m,
    k_nl=3e8 N/m^3``. The paper starts it from ``v(0)=10 m/s``; an impulse ``m*v = 0.5 N s``
    gives the same state (see :attr:`SystemInfo.demo_forces_n`).
``paper-pendulum``
    Sec. 3.2, Eq. 19: ``m=2 kg, l=0.8 m, b=0.1 kg/s^2, g=9.81``; inertia ``m l^2 = 1.28``,
    damping ``b l^2 = 0.064`` (Table 3), ``m g l = 15.696`` (Table 4). ``sin`` is replaced by
    its Taylor series up to ``x^9`` (error < 4e-6 N m at ``pi/2``; the ``+x^9`` term keeps the
    potential bounded below, which the series cut at ``x^7`` would not).
``duffing-smooth``
    Sec. 3.3.1, Eq. 23 with the identified values: ``m=0.815 kg``, ``b1=0.196, b2(x^2*v)=-20441,
    b3(v^3)=9.96`` (Eq. 21), ``k1=390, k2=-1.4e3, k3=1.3e7, k4=-5.5e7, k5=6.2e10`` (Eq. 22).
``duffing-struts``
    Sec. 3.3.2, Eqs. 24-25: ``m=0.088 kg``, ``b1=0.48, b2(x^2*v)=-4.07e5, b3(v^3)=27.7``,
    ``k1=1064, k2=9257, k3=-4.4e7, k4=-9.4e8, k5=8.49e11`` plus a ``clearance`` effect
    (gap 2.5 mm, contact stiffness 400 N/m). The clearance is OUR ASSUMPTION: the paper only
    says "there is a clearance effect when the mass is not in contact with [the struts]"
    (Sec. 3.3.2) and gives no values.

Stability (checked by ``tests/simulated_rig/test_physics.py``): ``duffing-smooth`` has a
negative ``x^2*v`` damping; averaged over a cycle the loss is still positive at every
amplitude because the ``v^3`` term and the hardening frequency win (response at 3000 N with
the plastic tip stays bounded and decays). ``duffing-struts`` is stable up to the 37 N of
the paper's Fig. 16(b) and beyond (checked to 150 N); its demo levels are the paper's 11 N
and 37 N (Sec. 3.3.2, Fig. 16) and 60 N (ours, to reach the softening region).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from eddi.model import EFFECTS, Effect, EquationOfMotion
from simulated_rig.errors import ScenarioError


@dataclass(frozen=True)
class SystemInfo:
    """A named system with what a bench needs to test it.

    Attributes
    ----------
    name : str
    eom : EquationOfMotion
        The true physics.
    record_s : float
        Suggested record length after the trigger [s] (the ring-down fits in it).
    demo_forces_n : tuple of float
        Peak hammer forces [N] (torques [N m] for the pendulum) for a low, middle and high
        impact; the middle one defines the system's typical amplitude.
    tip : str
        Suggested hammer tip (see :mod:`simulated_rig.hammer`).
    source : str
        Where the numbers come from.
    """

    name: str
    eom: EquationOfMotion
    record_s: float
    demo_forces_n: tuple[float, ...]
    tip: str
    source: str


def _paper_duffing() -> SystemInfo:
    eom = EquationOfMotion.create(
        mass=0.05,  # paper Sec. 3.1, Eq. 17
        damping={"v": 0.5, "x^2*v": 4000.0},  # paper Eq. 17, Table 1
        stiffness={"x": 300.0, "x^3": 3.0e8},  # paper Eq. 17, Table 2
        notes="paper Sec. 3.1, Eq. 17 (simulated Duffing oscillator)",
    )
    # v(0) = 10 m/s of Eq. 17 is an impulse of 0.5 N s; a 1 ms half-sine of peak P gives
    # 2 P T / pi, so P = 785 N reproduces it. Lower levels give weaker nonlinearity.
    return SystemInfo("paper-duffing", eom, 1.0, (80.0, 250.0, 785.0), "plastic",
                      "paper Sec. 3.1, Eq. 17")


def _paper_pendulum() -> SystemInfo:
    mgl = 2.0 * 9.81 * 0.8  # paper Sec. 3.2: m=2 kg, g=9.81, l=0.8 m -> 15.696 (Table 4)
    stiffness = {
        "x": mgl,
        "x^3": -mgl / math.factorial(3),
        "x^5": mgl / math.factorial(5),
        "x^7": -mgl / math.factorial(7),
        "x^9": mgl / math.factorial(9),
    }
    eom = EquationOfMotion.create(
        mass=2.0 * 0.8**2,  # m l^2 = 1.28, paper Eq. 19
        damping={"v": 0.1 * 0.8**2},  # b l^2 = 0.064, paper Table 3
        stiffness=stiffness,
        coordinate="angle [rad]",
        notes="paper Sec. 3.2, Eq. 19 with sin(theta) as its Taylor series to theta^9",
    )
    # theta = pi/2 (paper Eq. 19) needs E = mgl (1 - cos) = 15.7 J: omega0 = 4.95 rad/s,
    # an angular impulse of 6.34 N m s, i.e. a 3 ms half-sine torque of 3320 N m.
    return SystemInfo("paper-pendulum", eom, 100.0, (800.0, 2000.0, 3320.0), "rubber",
                      "paper Sec. 3.2, Eq. 19")


def _duffing_smooth() -> SystemInfo:
    eom = EquationOfMotion.create(
        mass=0.815,  # paper Sec. 3.3.1
        damping={"v": 0.196, "x^2*v": -20441.0, "v^3": 9.96},  # paper Eq. 21
        stiffness={"x": 390.0, "x^2": -1.4e3, "x^3": 1.3e7, "x^4": -5.5e7, "x^5": 6.2e10},  # Eq. 22
        notes="paper Sec. 3.3.1, Eq. 23 (identified model of the smooth Duffing rig)",
    )
    # paper Sec. 3.3.1 / Fig. 12: impacts of 246 N and 1110 N (and the identification case
    # in between, level not stated); 45 s records with 1 s pre-trigger at 19200 Hz.
    return SystemInfo("duffing-smooth", eom, 45.0, (246.0, 600.0, 1110.0), "plastic",
                      "paper Sec. 3.3.1, Eqs. 21-23, Fig. 12")


def _duffing_struts() -> SystemInfo:
    eom = EquationOfMotion.create(
        mass=0.088,  # paper Sec. 3.3.2
        damping={"v": 0.48, "x^2*v": -4.07e5, "v^3": 27.7},  # paper Eq. 24
        stiffness={"x": 1064.0, "x^2": 9257.0, "x^3": -4.4e7, "x^4": -9.4e8, "x^5": 8.49e11},  # Eq. 25
        effects=(
            # ASSUMPTION (paper Sec. 3.3.2 names a clearance but gives no numbers): the struts
            # touch the mass beyond 2.5 mm with a contact stiffness of 400 N/m.
            Effect(name="clearance", params={"gap_m": 2.5e-3, "stiffness_n_per_m": 400.0}),
        ),
        notes="paper Sec. 3.3.2, Eqs. 24-25, plus an assumed strut clearance",
    )
    # paper Sec. 3.3.2 / Fig. 16: impacts of 11 N and 37 N; 4 s records.
    # 60 N is ours: it reaches the softening region (|x| ~ 3-4 mm) and stays stable.
    return SystemInfo("duffing-struts", eom, 4.0, (11.0, 37.0, 60.0), "plastic",
                      "paper Sec. 3.3.2, Eqs. 24-26, Fig. 16")


_BUILDERS = {
    "paper-duffing": _paper_duffing,
    "paper-pendulum": _paper_pendulum,
    "duffing-smooth": _duffing_smooth,
    "duffing-struts": _duffing_struts,
}

#: Names of the known systems.
SYSTEMS: tuple[str, ...] = tuple(_BUILDERS)

#: The system of the demo and of the default scenario.
DEFAULT_SYSTEM = "duffing-smooth"


def system_info(name: str) -> SystemInfo:
    """The named system with its suggested test settings.

    Raises
    ------
    ScenarioError
        For an unknown name (the message lists the known ones).
    """
    builder = _BUILDERS.get(name)
    if builder is None:
        raise ScenarioError(f"unknown system {name!r}; known: {', '.join(SYSTEMS)}")
    return builder()


def get_system(name: str) -> EquationOfMotion:
    """The true equation of motion of a named system (see the module docstring)."""
    return system_info(name).eom


# -- hidden effects ------------------------------------------------------------------------

#: Frequency ratio of a hidden second mode to the first (non-integer: no internal resonance).
SECOND_MODE_RATIO = 2.7
#: Mass of a hidden second mode relative to the main mass.
SECOND_MODE_MASS_RATIO = 0.1
#: Damping ratio of a hidden second mode.
SECOND_MODE_ZETA = 0.02


def typical_state(system: str | EquationOfMotion, *, rate_hz: float = 19200.0) -> tuple[float, float]:
    """Peak displacement and velocity of a named system under its middle demo blow.

    Simulated without noise from rest for three linear periods (at least 50 ms) with the
    system's suggested tip.

    Returns
    -------
    amplitude_m : float
        Peak ``|x|`` [m] (rad for the pendulum).
    velocity_m_s : float
        Peak ``|v|`` [m/s].
    """
    from eddi.simulate import simulate  # local: keeps the catalogue import cheap
    from simulated_rig.hammer import HammerSpec, hammer_force

    if isinstance(system, EquationOfMotion):
        raise ScenarioError("hide_effect: give amplitude_m for a system that is not named")
    info = system_info(system)
    k1 = info.eom.linear_stiffness()
    period = 2 * math.pi * math.sqrt(info.eom.mass / k1) if k1 > 0 else 1.0
    n = int(max(0.05, 3 * period) * rate_hz)
    t = np.arange(n) / rate_hz
    f = hammer_force(t, info.demo_forces_n[len(info.demo_forces_n) // 2], HammerSpec(tip=info.tip))
    res = simulate(info.eom, t, force=f)
    return float(np.max(np.abs(res.x))), float(np.max(np.abs(res.v)))


def hide_effect(system: str | EquationOfMotion, name: str, magnitude: float, seed: int = 0, *,
                amplitude_m: float | None = None, velocity_m_s: float | None = None
                ) -> EquationOfMotion:
    """The system with one hidden effect of the catalogue :data:`eddi.model.EFFECTS` added.

    ``magnitude`` is the effect's force at the typical state as a fraction of the linear
    spring force there, ``k1 * A`` (``A``, ``V``: peak displacement and velocity under the
    system's middle demo blow, :func:`typical_state`). Each value is then multiplied by a
    factor drawn uniformly in [0.8, 1.2] from ``seed``, so different seeds hide different
    (but equally sized) effects:

    - ``coulomb_friction``: ``force_n = mag k1 A``; ``velocity_scale = 1e-3 V``.
    - ``quadratic_damping``: ``coefficient = mag k1 A / V^2``.
    - ``clearance``: ``gap_m = A / 2``, ``stiffness_n_per_m = 2 mag k1`` (so the contact force
      at ``|x| = A`` is ``mag k1 A``).
    - ``asymmetric_stiffness``: ``k2 = mag k1 / A``, ``k4 = 0``.
    - ``second_mode``: ``mass_kg = 0.1 m``, coupling ``mag k1``, own stiffness so that its
      frequency is 2.7 times the first linear one, 2 % damping.
    - ``hysteresis``: a Bouc-Wen element in parallel, ``yield_force_n = mag k1 A``,
      ``yield_displacement_m = A / 3``, ``exponent`` 1.5 (its initial stiffness ``3 mag k1``
      adds to the spring's).

    Parameters
    ----------
    system : str or EquationOfMotion
        A named system, or a model together with ``amplitude_m``.
    name : str
        Effect name.
    magnitude : float
        In (0, 10].
    seed : int
    amplitude_m, velocity_m_s : float, optional
        Typical state; default from :func:`typical_state` (velocity: ``A sqrt(k1/m)``
        when only the amplitude is given).

    Raises
    ------
    ScenarioError
        Unknown effect, magnitude out of range, unnamed system without amplitude.
    """
    if name not in EFFECTS:
        raise ScenarioError(f"hidden effect {name!r} is unknown; known: {', '.join(EFFECTS)}")
    if not (0.0 < magnitude <= 10.0):
        raise ScenarioError(f"hidden effect {name!r}: magnitude must be in (0, 10], got {magnitude}")
    eom = system if isinstance(system, EquationOfMotion) else get_system(system)
    k1 = eom.linear_stiffness()
    if k1 <= 0:
        raise ScenarioError(f"hidden effect {name!r}: the system has no positive linear stiffness")
    w1 = math.sqrt(k1 / eom.mass)
    if amplitude_m is None:
        amplitude_m, v_typ = typical_state(system)
        velocity_m_s = velocity_m_s or v_typ
    if velocity_m_s is None:
        velocity_m_s = amplitude_m * w1
    a, v = float(amplitude_m), float(velocity_m_s)
    jitter = float(np.random.default_rng(seed).uniform(0.8, 1.2))
    mag = magnitude * jitter
    if name == "coulomb_friction":
        params = {"force_n": mag * k1 * a, "velocity_scale": 1e-3 * v}
    elif name == "quadratic_damping":
        params = {"coefficient": mag * k1 * a / v**2}
    elif name == "clearance":
        params = {"gap_m": 0.5 * a, "stiffness_n_per_m": 2.0 * mag * k1}
    elif name == "asymmetric_stiffness":
        params = {"k2": mag * k1 / a, "k4": 0.0}
    elif name == "hysteresis":
        params = {"yield_force_n": mag * k1 * a, "yield_displacement_m": a / 3.0, "exponent": 1.5}
    else:  # second_mode
        m2 = SECOND_MODE_MASS_RATIO * eom.mass
        kc = mag * k1
        k_total = m2 * (SECOND_MODE_RATIO * w1) ** 2
        k_own = max(k_total - kc, 0.1 * k_total)
        c2 = 2 * SECOND_MODE_ZETA * math.sqrt((k_own + kc) * m2)
        params = {"mass_kg": m2, "stiffness_n_per_m": k_own, "damping_n_s_per_m": c2,
                  "coupling_n_per_m": kc}
    return eom.with_effect(Effect(name=name, params=params))
