"""UFF58 export: round trip through pyuff, exact in binary, 11 digits in ASCII."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import pyuff

from station.errors import InputFileError
from station.storage import CaptureWriter, read_capture
from station.uff import export_uff58
from test_storage import make_capture


@pytest.mark.parametrize("binary", [True, False])
def test_uff58_round_trip(tmp_path: Path, binary: bool) -> None:
    h5 = tmp_path / "s.h5"
    w = CaptureWriter(h5)
    w.append(make_capture(1, n=3000), notes="first")
    w.append(make_capture(2, n=2000))
    out = tmp_path / "s.uff"
    assert export_uff58(h5, out, binary=binary) == 4
    sets = pyuff.UFF(str(out)).read_sets()
    assert [(s["load_case_id"], s["rsp_ent_name"], s["ordinate_spec_data_type"]) for s in sets] == [
        (0, "force", 13), (0, "acc", 12), (1, "force", 13), (1, "acc", 12)]
    for s in sets:
        cap = read_capture(h5, s["load_case_id"])
        expected = cap.channels[s["rsp_ent_name"]].si
        assert s["func_type"] == 1 and s["num_pts"] == cap.n_samples and s["abscissa_spec_data_type"] == 17
        if binary:
            np.testing.assert_array_equal(s["data"], expected)
        else:
            np.testing.assert_allclose(s["data"], expected, rtol=1e-10, atol=1e-12)
        # UFF58 writes the abscissa increment with 6 digits (format E13.5): time is approximate
        np.testing.assert_allclose(s["x"], cap.t, rtol=1e-5)
    assert sets[1]["ordinate_axis_units_lab"] == "m/s^2" and sets[0]["id4"] == "first"


def test_uff58_selected_capture_and_refusals(tmp_path: Path) -> None:
    h5 = tmp_path / "s.h5"
    w = CaptureWriter(h5)
    w.append(make_capture(1, n=500))
    w.append(make_capture(2, n=500, gaps=((10, 5),)))
    assert export_uff58(h5, tmp_path / "one.uff", [0]) == 2
    with pytest.raises(InputFileError, match="5 samples missing"):
        export_uff58(h5, tmp_path / "two.uff", [1])
    with pytest.raises(InputFileError, match="no force_x channel"):
        export_uff58(h5, tmp_path / "x.uff", [0], quantities=("force_x",))


def test_station_export_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from station.cli import main

    h5 = tmp_path / "s.h5"
    w = CaptureWriter(h5)
    w.append(make_capture(1, n=400))
    w.append(make_capture(2, n=300))
    assert main(["export", f"{h5}:-1", "--uff", str(tmp_path / "last.uff"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == {"file": str(tmp_path / "last.uff"), "records": 2,
                                                    "source": str(h5), "captures": [1]}
    sets = pyuff.UFF(str(tmp_path / "last.uff")).read_sets()
    assert [s["num_pts"] for s in sets] == [300, 300]
    assert main(["export", str(h5), "--uff", str(tmp_path / "all.uff"), "--ascii"]) == 0
    assert "4 UFF58 record(s)" in capsys.readouterr().out
