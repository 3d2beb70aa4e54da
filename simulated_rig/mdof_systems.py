"""Multi-degree-of-freedom systems of the simulated rig, described as data.

A system file (TOML, in ``simulated_rig/mdof/``, or JSON with the same keys) lists lumped
masses and the elements joining them; node 0 is the ground, nodes 1..N the masses::

    masses_kg = [1.0, 0.5]
    driving_point = 1          # the mass the hammer hits (1-based)
    [[elements]]
    between = [1, 2]           # nodes
    k = 26000.0                # linear spring [N/m]
    k3 = 2.0e10                # cubic spring [N/m^3]
    c = 0.5                    # dashpot [N s/m]
    k2 = 3.0e6                 # quadratic (asymmetric) spring [N/m^2], optional
    c3 = 40.0                  # cubic damper [N s^3/m^3], optional

An element between nodes ``i`` and ``j`` with stretch ``d = x_i - x_j`` pushes node ``i`` with
``-(k d + k2 d^2 + k3 d^3 + c d' + c3 d'^3)`` and node ``j`` with the opposite. The system becomes a physical
:class:`eddi.mdof.model.MdofModel` (one coordinate per mass, the cubic springs expanded into
monomials ``x1^3, x1^2*x2, ...``), which is also what ``station validate`` and the rig load.

:func:`mdof_impact_test` hits the driving mass with the hammer, integrates the truth with
:func:`eddi.mdof.simulate.simulate_mdof` and measures the force and one accelerometer per
mass (``acc1..accN``) through the sensor and ADC models of :mod:`simulated_rig.sensors`
(noise at ``snr_db`` per channel, drawn ``default_rng(seed).standard_normal((n, 1 + N))``).
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import dataclass
from math import comb
from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError, model_validator

from drivers.channels import ChannelInfo
from eddi.mdof.model import MdofModel
from eddi.mdof.simulate import simulate_mdof
from eddi.mdof.terms import monomial
from simulated_rig.bench import measure
from simulated_rig.errors import ScenarioError
from simulated_rig.hammer import HammerSpec, hammer_force
from simulated_rig.sensors import SensorSpec, ac_couple, accelerometer, force_sensor, mains_tone

#: Folder of the built-in MDOF system files.
MDOF_DIR = Path(__file__).with_name("mdof")


class Element(BaseModel):
    """A spring/dashpot between two nodes (0 = ground)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    between: tuple[int, int]
    k: float = 0.0
    k3: float = 0.0
    c: float = 0.0
    k2: float = 0.0
    c3: float = 0.0


class MdofSystem(BaseModel):
    """A lumped-mass system and how to test it (see the module docstring)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str = ""
    description: str = ""
    masses_kg: tuple[float, ...]
    elements: tuple[Element, ...]
    driving_point: int = 1
    rate_hz: float = 2048.0
    pretrigger_s: float = 0.05
    record_s: float = 3.0
    impacts_n: tuple[float, ...] = (50.0, 150.0, 300.0)
    tip: str = "rubber"

    @model_validator(mode="after")
    def _check(self) -> "MdofSystem":
        n = len(self.masses_kg)
        if n < 1 or any(not (m > 0 and math.isfinite(m)) for m in self.masses_kg):
            raise ValueError("masses_kg: expected at least one mass, each > 0")
        if not 1 <= self.driving_point <= n:
            raise ValueError(f"driving_point: expected 1..{n}, got {self.driving_point}")
        for e in self.elements:
            i, j = e.between
            if i == j or not (0 <= i <= n and 0 <= j <= n):
                raise ValueError(f"element between {list(e.between)}: expected two different nodes in 0..{n}")
        if not self.impacts_n or any(p <= 0 for p in self.impacts_n):
            raise ValueError("impacts_n: expected peak forces > 0 [N]")
        return self

    @property
    def channels(self) -> tuple[str, ...]:
        """Accelerometer channel names, one per mass."""
        return tuple(f"acc{i + 1}" for i in range(len(self.masses_kg)))

    def model(self) -> MdofModel:
        """The physical equation of motion (one coordinate per mass)."""
        n = len(self.masses_kg)
        damping: list[dict[str, float]] = [dict() for _ in range(n)]
        stiffness: list[dict[str, float]] = [dict() for _ in range(n)]
        for e in self.elements:
            nodes = [k - 1 for k in e.between]  # -1 = ground
            for side, node in enumerate(nodes):
                if node < 0:
                    continue
                sign = 1.0 if side == 0 else -1.0  # d = x_i - x_j; force on j is -force on i
                for (deg, coef, target, rate) in ((1, e.k, stiffness, False), (3, e.k3, stiffness, False),
                                                  (2, e.k2, stiffness, False), (1, e.c, damping, True),
                                                  (3, e.c3, damping, True)):
                    if coef == 0.0:
                        continue
                    for term, c in _power_of_difference(nodes, deg, n, rate).items():
                        target[node][term] = target[node].get(term, 0.0) + sign * coef * c
        clean = [{t: c for t, c in d.items() if c != 0.0} for d in damping]
        cleank = [{t: c for t, c in d.items() if c != 0.0} for d in stiffness]
        inp = tuple(1.0 if i == self.driving_point - 1 else 0.0 for i in range(n))
        return MdofModel.create(
            coordinates="physical", mass=self.masses_kg, input=inp, damping=tuple(clean),
            stiffness=tuple(cleank), channels=self.channels,
            shapes=tuple(tuple(float(i == j) for j in range(n)) for i in range(n)),
            driving_point=self.channels[self.driving_point - 1],
            notes=f"simulated rig system {self.name}: {self.description}")


def _power_of_difference(nodes: list[int], deg: int, n: int, rate: bool) -> dict[str, float]:
    """Monomials of ``(x_i - x_j)^deg`` (ground = -1 contributes 0)."""
    i, j = nodes
    out: dict[str, float] = {}
    for p in range(deg + 1):  # x_i^p (-x_j)^(deg-p)
        q = deg - p
        if (i < 0 and p) or (j < 0 and q):
            continue
        powers: dict[int, int] = {}
        if p:
            powers[i] = p
        if q:
            powers[j] = powers.get(j, 0) + q
        text = monomial(powers, n, rate)
        out[text] = out.get(text, 0.0) + comb(deg, p) * (-1.0) ** q
    return out


def mdof_systems() -> tuple[str, ...]:
    """Names of the built-in MDOF systems."""
    return tuple(sorted(p.stem for p in MDOF_DIR.glob("*.toml")))


def load_mdof_system(name_or_path: str | Path) -> MdofSystem:
    """A built-in system by name, or a TOML / JSON file.

    Raises
    ------
    ScenarioError
        Unknown name, unreadable file, invalid content (one line).
    """
    path = Path(name_or_path)
    if not path.suffix:
        path = MDOF_DIR / f"{name_or_path}.toml"
        if not path.is_file():
            raise ScenarioError(f"unknown MDOF system {str(name_or_path)!r}; known: {', '.join(mdof_systems())}")
    try:
        text = path.read_text()
        data = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise ScenarioError(f"{path}: cannot read the MDOF system: {exc}") from None
    data.setdefault("name", path.stem)
    try:
        return MdofSystem(**data)
    except ValidationError as exc:
        err = exc.errors()[0]
        where = ".".join(str(p) for p in err.get("loc", ()))
        raise ScenarioError(f"{path}: {where + ': ' if where else ''}"
                            f"{str(err.get('msg', 'invalid')).removeprefix('Value error, ')}") from None


@dataclass(frozen=True)
class MdofRecord:
    """A simulated multi-channel impact test.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
        Starts at ``-pretrigger_s``; the pulse starts at 0.
    force_n : ndarray, shape (n,), [N]
        Measured force.
    acc_m_s2 : ndarray, shape (N, n), [m/s^2]
        Measured accelerations, one row per mass (``channels``).
    channels : tuple of str
    rate_hz : float
    pretrigger_samples : int
    model : MdofModel
        The truth.
    truth_x, truth_v, truth_a : ndarray, shape (N, n)
    peak_force_n : float
    infos : tuple of ChannelInfo
        ADC channels (force first).
    sensors : tuple of SensorSpec
        The sensors resolved on this record (absolute noise and range; force first).
    """

    t: np.ndarray
    force_n: np.ndarray
    acc_m_s2: np.ndarray
    channels: tuple[str, ...]
    rate_hz: float
    pretrigger_samples: int
    model: MdofModel
    truth_x: np.ndarray
    truth_v: np.ndarray
    truth_a: np.ndarray
    peak_force_n: float
    infos: tuple[ChannelInfo, ...]
    sensors: tuple[SensorSpec, ...] = ()

    def columns(self) -> dict[str, np.ndarray]:
        """``force``, ``acc1``.. as a mapping (SI)."""
        out = {"force": self.force_n}
        out.update({c: self.acc_m_s2[k] for k, c in enumerate(self.channels)})
        return out

    def write_csv(self, path: str | Path) -> Path:
        """Write ``t,force,acc1,..,accN`` (SI) to ``path``."""
        path = Path(path)
        cols = self.columns()
        data = np.column_stack([self.t] + list(cols.values()))
        np.savetxt(path, data, delimiter=",", header="t," + ",".join(cols), comments="", fmt="%.10g")
        return path


def mdof_impact_test(system: str | MdofSystem, peak_force_n: float, *, snr_db: float | None = 45.0,
                     seed: int = 0, record_s: float | None = None, rate_hz: float | None = None,
                     model: MdofModel | None = None, mains: dict | None = None) -> MdofRecord:
    """Hit the driving mass once; measure force and every mass's acceleration.

    Parameters
    ----------
    system : str or MdofSystem
    peak_force_n : float
        Peak of the hammer pulse [N].
    snr_db : float or None
        SNR of each accelerometer [dB] (None: quantisation only).
    seed : int
    record_s, rate_hz : float, optional
        Override the system's.
    model : MdofModel, optional
        Physics to use instead of the system's (e.g. an identified model loaded in the rig).
    mains : dict, optional
        A mains tone on every accelerometer: :class:`simulated_rig.sensors.SensorSpec`'s
        ``mains_si`` [m/s^2], ``mains_hz``, ``mains_phase_rad``, ``mains_harmonics`` (one pick-up:
        the same phase on every channel).

    Raises
    ------
    ScenarioError
        Bad peak, or a blow that makes the system diverge.
    """
    sys_ = system if isinstance(system, MdofSystem) else load_mdof_system(system)
    if not (math.isfinite(peak_force_n) and peak_force_n > 0):
        raise ScenarioError(f"peak_force_n: must be > 0, got {peak_force_n}")
    eom = model if model is not None else sys_.model()
    rate = float(rate_hz or sys_.rate_hz)
    n_pre = int(round(sys_.pretrigger_s * rate))
    n = n_pre + int(round((record_s or sys_.record_s) * rate))
    t = (np.arange(n) - n_pre) / rate
    hammer = HammerSpec(tip=sys_.tip)
    force = hammer_force(t, peak_force_n, hammer)
    sim = simulate_mdof(eom, t, force, x_scale=_amplitude_guess(eom, peak_force_n, hammer))
    if sim.diverged:
        raise ScenarioError(f"impacts: {sys_.name} diverges under a {peak_force_n:.4g} N blow")
    acc_true = eom.phi @ sim.a
    sensors = (force_sensor(),) + tuple(accelerometer(name=c, snr_db=snr_db, **(mains or {})) for c in eom.channels)
    clean = np.column_stack([ac_couple(force, sensors[0].iepe_highpass_hz, rate)]
                            + [ac_couple(a, s.iepe_highpass_hz, rate) for a, s in zip(acc_true, sensors[1:])])
    resolved = tuple(s.resolved(clean[:, j], n_pre) for j, s in enumerate(sensors))
    clean = clean + np.column_stack([mains_tone(s, t, seed) for s in resolved])  # after the sensor
    normals = np.random.default_rng(seed).standard_normal((n, len(sensors)))
    counts, infos, _clipped = measure(resolved, clean, normals)
    si = np.column_stack([infos[j].to_si(counts[:, j]) for j in range(len(infos))])
    return MdofRecord(t=t, force_n=si[:, 0], acc_m_s2=si[:, 1:].T.copy(), channels=eom.channels, rate_hz=rate,
                      pretrigger_samples=n_pre, model=eom, truth_x=eom.phi @ sim.x, truth_v=eom.phi @ sim.v,
                      truth_a=acc_true, peak_force_n=float(peak_force_n), infos=infos, sensors=resolved)


def _amplitude_guess(eom: MdofModel, peak_n: float, hammer: HammerSpec) -> float:
    """Peak coordinate guess [m]: impulse / (smallest mass * lowest linear frequency)."""
    impulse = 2.0 * peak_n * hammer.width_s / math.pi
    f = eom.natural_frequencies_hz()
    w = 2 * math.pi * max(float(f[f > 0].min()) if np.any(f > 0) else 1.0, 1.0)
    return impulse / (min(eom.mass) * w)


def system_and_model(spec: str) -> tuple[MdofSystem, MdofModel]:
    """A built-in name, a system file, or a model JSON (``"kind": "mdof"``, e.g. an identified one).

    A model runs with the default test settings (rate, record, hammer) of :class:`MdofSystem`.

    Raises
    ------
    ScenarioError
    """
    path = Path(spec)
    if path.suffix.lower() == ".json" and path.is_file():
        from eddi.errors import ModelError
        from eddi.mdof.model import is_mdof_json

        text = path.read_text()
        if is_mdof_json(text):
            try:
                model = MdofModel.from_json(text)
            except ModelError as exc:
                raise ScenarioError(f"{path}: {exc}") from None
            system = MdofSystem(name=path.stem, description=model.notes, masses_kg=model.mass, elements=(),
                                driving_point=model.channels.index(model.driving_point) + 1)
            return system, model
    system = load_mdof_system(spec)
    return system, system.model()


def main(argv: list[str] | None = None) -> int:
    """``python -m simulated_rig.mdof_systems SYSTEM|FILE --out DIR``: write impact records as CSV."""
    import argparse
    import sys

    ap = argparse.ArgumentParser(
        prog="python -m simulated_rig.mdof_systems",
        description="Hit a multi-DOF system of the simulated rig (a built-in name, a system TOML/JSON, or an "
                    "mdof model JSON such as one `station diagnose --save-model` wrote) and write each "
                    "record as CSV t,force,acc1..accN.")
    ap.add_argument("system", help=f"one of {', '.join(mdof_systems())}, or a file")
    ap.add_argument("--out", required=True, help="existing directory for the CSV files")
    ap.add_argument("--peaks", help="peak forces [N], comma-separated (default: the system's)")
    ap.add_argument("--snr-db", type=float, default=45.0, help="SNR of every accelerometer [dB] (default 45)")
    ap.add_argument("--seed", type=int, default=0, help="noise seed of the first record (then +1 each)")
    args = ap.parse_args(argv)
    try:
        system, model = system_and_model(args.system)
        peaks = [float(p) for p in args.peaks.split(",")] if args.peaks else list(system.impacts_n)
        out = Path(args.out)
        if not out.is_dir():
            raise ScenarioError(f"--out {out}: expected an existing directory")
        for k, peak in enumerate(peaks):
            rec = mdof_impact_test(system, peak, snr_db=args.snr_db, seed=args.seed + k, model=model)
            print(rec.write_csv(out / f"{system.name}-{k}.csv"))
    except (ScenarioError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
