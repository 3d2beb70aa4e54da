"""``station report`` and :mod:`station.report`: figures, page, numbers, faults."""

from __future__ import annotations

import html
from pathlib import Path
from typing import Any

import matplotlib.image as mpimg
import numpy as np
import pytest

from eddi.model import EquationOfMotion
from station import figures
from station.cli import main
from station.report import analysis_band, cwt_view, potential_curve, stiffness_curve
from tests.station.test_demo import demo_run


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_report_of_the_demo_session(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    import json

    demo, demo_obj = demo_run()
    out = tmp_path / "rep"
    code, stdout, err = _run(["report", str(demo / "session.h5"), "--out", str(out), "--json",
                              "--stiffness", "x,x^2,x^3,x^4,x^5", "--refine"], capsys)
    assert code == 0, err
    obj = json.loads(stdout)
    # same pipeline as the demo: the same capture identified, the same coefficients
    assert obj["fit_record"].endswith(":1")
    assert obj["identified"]["stiffness"] == demo_obj["identified"]["stiffness"]
    page = (out / "index.html").read_text()
    names = ["force", "displacement", "kinetic", "dissipated", "mechanical", "restoring",
             "validation_1", "validation_2"]
    assert [Path(p).stem for p in obj["figures"]] == names
    for name in names:
        img = mpimg.imread(out / f"{name}.png")
        assert img.ndim == 3 and img.shape[0] > 250 and img.shape[1] > 450
        assert np.std(img[..., :3]) > 0.05  # not blank
        assert f"src='{name}.png'" in page
    # coefficient table: identified and the rig's true value (paper Eq. 22: k1 = 390)
    k1 = obj["identified"]["stiffness"]["x"]
    assert f"<td>{k1:+.6g}</td><td>± " in page  # with its 95 % interval and unit
    assert f"<td>N/m</td><td>+390</td><td>{100 * (k1 - 390) / 390:+.1f} %</td>" in page
    # validation table: every held-out nrmse printed as computed
    for h in obj["validation"]["held_out"]:
        assert f"<td>{html.escape(h['source'])}</td>" in page
        assert f"<td>{h['nrmse']:.4g}</td>" in page


def test_report_of_a_single_csv_record_validates_on_itself(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    from tests.conftest import REPO

    csv = REPO / "station" / "examples" / "duffing-impact.csv"
    code, stdout, err = _run(["report", str(csv), "--out", str(tmp_path), "--mass", "0.815"], capsys)
    assert code == 0, err
    assert "validated on itself" in stdout
    assert not list(tmp_path.glob("validation_*.png"))
    assert (tmp_path / "restoring.png").is_file() and (tmp_path / "index.html").is_file()


def test_cwt_view_finds_a_sinusoid_at_its_frequency_and_amplitude() -> None:
    rate, f0, amp = 2000.0, 7.0, 0.003
    t = np.arange(int(20 * rate)) / rate
    x = amp * np.sin(2 * np.pi * f0 * t)
    band = analysis_band(t, x)
    assert band[0] < f0 < band[1]
    assert band == pytest.approx((f0 / 4, 4 * f0), rel=0.01)
    tc, freqs, a = cwt_view(t, x, band)
    mid = a[:, a.shape[1] // 2]
    assert freqs[int(np.argmax(mid))] == pytest.approx(f0, abs=freqs[1] - freqs[0])
    assert mid.max() == pytest.approx(amp, rel=0.05)
    assert tc.size < t.size / 4  # averaged down before the transform


def test_stiffness_and_potential_curves_are_the_model_terms() -> None:
    eom = EquationOfMotion.create(mass=1.0, damping={"v": 0.5}, stiffness={"x": 390.0, "x^3": 1.3e7})
    x = np.linspace(-0.01, 0.01, 11)
    np.testing.assert_allclose(stiffness_curve(eom, x), 390.0 * x + 1.3e7 * x**3, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(potential_curve(eom, x), 195.0 * x**2 + 1.3e7 / 4 * x**4, rtol=1e-12, atol=1e-18)


def test_envelope_keeps_every_peak() -> None:
    t = np.arange(100_000) / 1000.0
    y = np.sin(2 * np.pi * 3.0 * t)
    y[12_345] = 5.0
    y[67_890] = -7.0
    te, ye = figures.envelope(t, y, max_points=2000)
    assert ye.size <= 2001
    assert ye.max() == 5.0 and ye.min() == -7.0
    assert te[int(np.argmax(ye))] == t[12_345]
    assert np.all(np.diff(te) >= 0)


@pytest.mark.parametrize("argv, expect", [
    (["report", "{tmp}/missing.h5", "--out", "{tmp}/r"], "no such file"),
    (["report", "{tmp}/garbage.h5", "--out", "{tmp}/r"], "expected an HDF5 file"),
    (["report", "{demo}/session.h5:3", "--out", "{tmp}/r"], "expected an index 0..2"),
    (["report", "{demo}/session.h5", "--out", "{tmp}/r", "--fit", "5"], "--fit: expected a record index 0..2"),
])
def test_report_faults_are_one_line_exit_2(argv: list[str], expect: str, capsys: pytest.CaptureFixture[str],
                                          tmp_path: Path) -> None:
    demo, _ = demo_run()
    (tmp_path / "garbage.h5").write_bytes(b"not hdf5")
    argv = [a.format(tmp=tmp_path, demo=demo) for a in argv]
    code, stdout, err = _run(argv, capsys)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("station: error:") and expect in err
    assert stdout == ""


def test_report_ctrl_c_exits_130(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                 monkeypatch: pytest.MonkeyPatch) -> None:
    import station.report

    demo, _ = demo_run()

    def interrupted(*a: Any, **k: Any) -> Any:
        raise KeyboardInterrupt

    monkeypatch.setattr(station.report, "write_report", interrupted)
    code, _, err = _run(["report", str(demo / "session.h5:0"), "--out", str(tmp_path)], capsys)
    assert code == 130 and err.count("\n") == 1 and "interrupted" in err
