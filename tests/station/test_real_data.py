"""Measured velocity-only ring-downs through the station's readers and the shipped model.

Data: ``../shared/data/resonant-double-beam`` (README there; Cenedese et al. 2022). Tests that
need it are skipped when it is absent.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddi.multimode import (
    ModalSumModel, load_any_model, predict_record, separate_modes, simulate_modal,
)
from station.readers import read_measurement
from tests.conftest import REPO, SHARED_DATA

DATA = SHARED_DATA / "resonant-double-beam"
MODEL = REPO / "models" / "double_beam_two_mode.json"
needs_data = pytest.mark.skipif(not DATA.is_dir(), reason=f"measured data not present at {DATA}")


@needs_data
def test_velocity_only_csv_reads_as_published() -> None:
    path = DATA / "ringdown-01.csv"
    m = read_measurement(str(path))
    raw = np.loadtxt(path, delimiter=",", skiprows=1)
    assert list(m.channels) == ["vel"]
    np.testing.assert_array_equal(m.channels["vel"], raw[:, 1])
    # the time column is printed with 7 decimals; the rate comes from its whole span
    assert m.rate_hz == pytest.approx((raw.shape[0] - 1) / (raw[-1, 0] - raw[0, 0]), rel=1e-9)


@needs_data
def test_second_mode_is_what_a_single_mode_misses_on_every_record() -> None:
    model = load_any_model(MODEL.read_text())
    assert isinstance(model, ModalSumModel)
    one = model.model_copy(update={"modes": model.modes[:1], "bands_hz": model.bands_hz[:1]})
    files = sorted(DATA.glob("ringdown-*.csv"))
    assert len(files) == 9
    for f in files:
        m = read_measurement(str(f))
        v = m.channels["vel"]
        two_err = predict_record(model, m.t, v).errors
        one_err = predict_record(one, m.t, v).errors
        assert two_err.nmte < 0.5 * one_err.nmte, f.name
        assert two_err.nrmse < 0.5 * one_err.nrmse, f.name


def _ringdown_in_motion() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A two-mode free decay sampled like the double beam, starting at full velocity."""
    model = load_any_model(MODEL.read_text())
    t = np.arange(15719) / 5120.0
    sim = simulate_modal(model, t, np.array([[0.0, 0.6], [0.0, 1.4]]))
    return t, sim.v, sim.x_modes.sum(axis=0)


def test_modal_separation_derives_displacement_of_a_record_starting_in_motion() -> None:
    t, v, x_true = _ringdown_in_motion()
    comp = separate_modes(t, v, [(20.0, 600.0)])
    inner = slice(300, -300)
    err = np.linalg.norm(comp.x[0][inner] - x_true[inner]) / np.linalg.norm(x_true[inner])
    assert err < 1e-3


def test_conditioning_derives_displacement_of_a_record_starting_in_motion() -> None:
    from eddi.conditioning import condition

    t, v, x_true = _ringdown_in_motion()
    sig = condition(t, vel=v)
    inner = slice(300, -300)
    err = np.linalg.norm(sig.x[inner] - x_true[inner]) / np.linalg.norm(x_true[inner])
    assert err < 0.01
