"""The modal-sum route on measured ring-downs of the resonant double beam.

Data: ``../shared/data/resonant-double-beam`` (see its README; Cenedese et al., Phil. Trans.
R. Soc. A 380 (2022), SSMLearn ``examples/resonantdoublebeam``), or the copies of records 01
and 05 in ``tests/data/resonant-double-beam`` (PROVENANCE.md there).

Record 01 trains, record 05 is predicted from its initial state. The thresholds are relations
between models measured on the same held-out record, not stored results.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from eddi.multimode import ModalSumModel, identify_modes, impact_index, load_any_model, predict_record
from tests.conftest import REPO, SHARED_DATA

LOCAL = REPO / "tests" / "data" / "resonant-double-beam"
DATA = SHARED_DATA / "resonant-double-beam"
# two dominant resonances (data README; SSMLearn's linear part gives 122.38 and 243.4 Hz)
F1_HZ, F2_HZ = 122.4, 243.4
TWO_BANDS = [(40.0, 180.0), (185.0, 400.0)]
WIDE_BAND = [(20.0, 600.0)]


def _path(name: str) -> Path:
    for folder in (DATA, LOCAL):
        p = folder / f"ringdown-{name}.csv"
        if p.is_file():
            return p
    pytest.skip(f"measured record ringdown-{name}.csv not found in {DATA} or {LOCAL}")


def _load(name: str) -> tuple[np.ndarray, np.ndarray]:
    d = np.loadtxt(_path(name), delimiter=",", skiprows=1)
    t, v = d[:, 0], d[:, 1]
    i0 = impact_index(v)
    return t[i0:] - t[i0], v[i0:]


@pytest.fixture(scope="module")
def records() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    return {n: _load(n) for n in ("01", "05")}


def test_local_copies_equal_the_shared_records() -> None:
    for name in ("01", "05"):
        shared = DATA / f"ringdown-{name}.csv"
        if not shared.is_file():
            pytest.skip(f"shared data not present at {DATA}")
        assert (LOCAL / f"ringdown-{name}.csv").read_bytes() == shared.read_bytes()


def test_two_modes_beat_one_on_a_record_not_used_for_fitting(records) -> None:
    train = [records["01"]]
    single, _ = identify_modes(train, WIDE_BAND)
    two, fits = identify_modes(train, TWO_BANDS)
    np.testing.assert_allclose(two.natural_frequencies_hz(), [F1_HZ, F2_HZ], rtol=0.01)
    held_t, held_v = records["05"]
    p1 = predict_record(single, held_t, held_v)
    p2 = predict_record(two, held_t, held_v)
    assert p2.errors.nmte < 0.5 * p1.errors.nmte
    assert p2.errors.nrmse < 0.5 * p1.errors.nrmse
    # the joint: both modes soften and lose more per cycle at larger amplitude
    for eom in two.modes:
        assert eom.stiffness["abs(x)*x"] < 0
        assert eom.damping["abs(v)*v"] > 0


def test_amplitude_terms_lower_the_held_out_error(records) -> None:
    train = [records["01"]]
    linear, _ = identify_modes(train, TWO_BANDS, damping=("v",), stiffness=("x",))
    joint, _ = identify_modes(train, TWO_BANDS)
    held = records["05"]
    assert predict_record(joint, *held).errors.nmte < 0.5 * predict_record(linear, *held).errors.nmte


def test_shipped_model_loads_and_names_the_two_resonances() -> None:
    path: Path = REPO / "models" / "double_beam_two_mode.json"
    model = load_any_model(path.read_text())
    assert isinstance(model, ModalSumModel)
    np.testing.assert_allclose(model.natural_frequencies_hz(), [F1_HZ, F2_HZ], rtol=0.01)
