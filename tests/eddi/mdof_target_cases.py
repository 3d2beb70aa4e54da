"""The captures of a ``benchmarks/bench_mdof_target.py`` case (or of any rig system) as the
multi-DOF tests read them: one rig capture per blow of the system (45 dB, seeds 100, 101, ...)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from bench_mdof_leak import TUNE as LEAK_TUNE  # noqa: E402
from bench_mdof_target import draw  # noqa: E402
from simulated_rig.mdof_systems import mdof_impact_test  # noqa: E402
from station.readers import Measurement  # noqa: E402


def target_measurements(index: int, seed: int, name: str | None = None, snr_db: float = 45.0):
    """``(case, measurements)`` of case ``index`` of the draw ``seed`` (``name``: asserted)."""
    case = draw(index, seed)
    assert name is None or case.name == name
    return case, system_measurements(case.system, snr_db=snr_db)


def leak_system(name: str):
    """A tuning system of ``benchmarks/bench_mdof_leak.py`` (``t3c``, ``t3d``, ...): a low, large
    mode beside heavily damped upper ones."""
    return LEAK_TUNE[name]()


def system_measurements(system, snr_db: float = 45.0, seed: int = 100) -> list:
    """One :class:`Measurement` per blow of ``system`` (no mass), seeds ``seed``, ``seed + 1``, ..."""
    meas = []
    for k, peak in enumerate(system.impacts_n):
        r = mdof_impact_test(system, peak, snr_db=snr_db, seed=seed + k)
        meas.append(Measurement(t=r.t, channels=r.columns(), rate_hz=r.rate_hz,
                                pretrigger_samples=r.pretrigger_samples, mass=None, source=f"{peak} N", metadata={}))
    return meas
