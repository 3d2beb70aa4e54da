"""A record whose force and acceleration columns are swapped is refused in one line naming both
(session 16: blind unseen12 seed 2718, refused as "found 0 zero crossings of x"); clean records,
a heavily damped one and a double hit read as before."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test
from simulated_rig.hammer import HammerSpec
from station.errors import InputFileError
from station.readers import read_measurement


def _eom(mass: float, f_hz: float, zeta: float) -> EquationOfMotion:
    w = 2 * math.pi * f_hz
    return EquationOfMotion.create(mass=mass, damping={"v": 2 * zeta * mass * w},
                                   stiffness={"x": mass * w * w, "x^3": 0.2 * mass * w * w / 1e-6})


def _csv(tmp_path: Path, eom: EquationOfMotion, *, swap: bool, double_hit: bool = False, name: str = "r") -> Path:
    r = impact_test(eom, 30.0 * eom.mass, rate_hz=2000.0, pretrigger_s=0.1, record_s=2.0, seed=5,
                    hammer=HammerSpec(tip="plastic"), double_hit=double_hit)
    cols = (r.t, r.acc_m_s2, r.force_n) if swap else (r.t, r.force_n, r.acc_m_s2)
    path = tmp_path / f"{name}.csv"
    np.savetxt(path, np.column_stack(cols), delimiter=",", header="t,force,acc", comments="", fmt="%.10g")
    return path


def test_swapped_columns_are_refused_naming_both(tmp_path: Path) -> None:
    path = _csv(tmp_path, _eom(0.5, 30.0, 0.01), swap=True)
    with pytest.raises(InputFileError, match=r"columns 'force' and 'acc' look swapped") as err:
        read_measurement(str(path))
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("zeta,double_hit", [(0.01, False), (0.2, False), (0.2, True), (0.01, True)])
def test_clean_heavily_damped_and_double_hit_records_read(tmp_path: Path, zeta: float, double_hit: bool) -> None:
    meas = read_measurement(str(_csv(tmp_path, _eom(0.5, 30.0, zeta), swap=False, double_hit=double_hit)))
    assert set(meas.channels) == {"force", "acc"}
