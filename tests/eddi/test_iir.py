"""eddi.iir: scipy.signal.lfilter's numbers bit for bit for a biquad, and the diagnosis' path
for one-mode records does not import scipy.signal (it imports scipy.stats: ~0.45 s)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from eddi.diagnosis.catalogue.second_mode import _mode_filter
from eddi.iir import biquad

REPO = Path(__file__).resolve().parents[2]


def _mode_coefficients(f: float, z: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    w, k = 2 * np.pi * f, 2.0 / dt
    a = np.array([k * k + 2 * z * w * k + w * w, 2 * (w * w - k * k), k * k - 2 * z * w * k + w * w])
    return w * w * np.array([1.0, 2.0, 1.0]) / a[0], a / a[0]


@pytest.mark.parametrize("f, z, dt", [(37.0, 0.005, 1e-4), (240.0, 0.02, 1 / 5120), (3.0, 0.05, 5e-5),
                                      (1900.0, 0.2, 1 / 4096)])
def test_mode_filter_is_lfilter_bit_for_bit(f: float, z: float, dt: float) -> None:
    rng = np.random.default_rng(int(f))
    x = np.cumsum(rng.normal(size=20000)) * 1e-4
    x[5000:5010] = 0.0
    b, a = _mode_coefficients(f, z, dt)
    want = signal.lfilter(b, a, x)
    assert biquad(b, a, x).tobytes() == want.tobytes()
    assert _mode_filter(x, f, z, dt).tobytes() == want.tobytes()
    strided = x[::3]  # a view: copied to a contiguous array first, same numbers
    assert biquad(b, a, strided).tobytes() == signal.lfilter(b, a, strided).tobytes()


def test_general_coefficients_and_special_values_match_lfilter() -> None:
    rng = np.random.default_rng(3)
    x = rng.normal(size=4000)
    x[[7, 9]] = np.inf, np.nan
    for _ in range(20):
        b = rng.normal(size=3)
        a = np.array([1.0, *rng.uniform(-0.9, 0.9, size=2)])
        assert np.array_equal(biquad(b, a, x), signal.lfilter(b, a, x), equal_nan=True)
    assert biquad([1.0, 0.0, 0.0], [1.0, 0.0, 0.0], np.zeros(0)).size == 0


def test_bad_coefficients_or_signal_raise() -> None:
    with pytest.raises(ValueError, match="a\\[0\\] == 1"):
        biquad([1.0, 0.0, 0.0], [2.0, 0.0, 0.0], np.ones(4))
    with pytest.raises(ValueError, match="length 3"):
        biquad([1.0, 0.0], [1.0, 0.0, 0.0], np.ones(4))
    with pytest.raises(ValueError, match="1-D"):
        biquad([1.0, 0.0, 0.0], [1.0, 0.0, 0.0], np.ones((2, 2)))


def test_one_mode_diagnosis_path_does_not_import_scipy_signal() -> None:
    """The modules `station diagnose` loads for one-mode captures, the second-mode filter, the
    capture span and the model class of modal sums; the separation still loads on demand."""
    code = (
        "import sys, json, numpy as np\n"
        "import station.commands.diagnose as d, eddi.diagnosis, eddi.multimode as mm\n"
        "from eddi.diagnosis.catalogue.second_mode import _mode_filter\n"
        "from eddi.mdof.amplitude import span_of\n"
        "_mode_filter(np.linspace(0, 1, 100), 30.0, 0.02, 1e-3)\n"
        "span_of([1.0, 2.0], 'acc'); mm.ModalSumModel; mm.trajectory_errors\n"
        "before = 'scipy.signal' in sys.modules\n"
        "mm.welch_sum\n"
        "print(json.dumps([before, 'scipy.signal' in sys.modules, 'welch_sum' in dir(mm)]))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout.strip().splitlines()[-1]) == [False, True, True]
