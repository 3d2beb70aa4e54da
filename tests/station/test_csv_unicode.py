"""CSV files in UTF-16 or UTF-32 with their byte-order mark (Excel's "Unicode text" export: UTF-16 LE,
tab-separated, CRLF lines) read as their UTF-8 twin, bit for bit, through every command that reads a
CSV (identify, validate, replay, diagnose); UTF-16 without the mark refused in one line (session 20:
before, every Unicode text was refused as "not a text CSV file")."""

from __future__ import annotations

import contextlib
import io
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from station.cli import main
from station.errors import InputFileError
from station.readers import read_measurement

MASS = 0.4


def _csv_text(seed: int, force_n: float) -> str:
    """A rig capture of a 0.4 kg, 25 Hz, 2 % oscillator as the station's CSV (t,force,acc)."""
    from eddi.model import EquationOfMotion
    from simulated_rig.bench import impact_test

    w = 2 * math.pi * 25.0
    eom = EquationOfMotion.create(mass=MASS, damping={"v": 2 * 0.02 * w * MASS}, stiffness={"x": MASS * w * w})
    r = impact_test(eom, force_n, rate_hz=2048.0, pretrigger_s=0.05, record_s=1.5, snr_db=50.0, seed=seed)
    buf = io.StringIO()
    np.savetxt(buf, np.column_stack((r.t, r.force_n, r.acc_m_s2)), delimiter=",", header="t,force,acc",
               comments="", fmt="%.17g")
    return buf.getvalue()


def _excel_unicode(text: str) -> bytes:
    """Excel's "Unicode text": UTF-16 LE with its mark, tabs, CRLF."""
    return b"\xff\xfe" + text.replace(",", "\t").replace("\n", "\r\n").encode("utf-16-le")


def _channels(path: Path) -> dict[str, bytes]:
    m = read_measurement(str(path))
    return {"t": m.t.tobytes(), **{k: np.asarray(v).tobytes() for k, v in m.channels.items()}}


@pytest.mark.parametrize("fast", [True, False])
def test_unicode_texts_read_as_their_utf8_twin_bit_for_bit(tmp_path: Path, fast: bool,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    if not fast:  # the general reader (numpy.loadtxt), as without the compiled pass
        monkeypatch.setattr("station.readers._plain_columns", lambda *a, **k: None)
    text = _csv_text(1, 20.0)
    ref = tmp_path / "utf8.csv"
    ref.write_text(text)
    want = _channels(ref)
    files = {"excel.txt": _excel_unicode(text), "be.csv": b"\xfe\xff" + text.encode("utf-16-be"),
             "u32.csv": text.encode("utf-32"),
             # a decimal comma and semicolons (a European spreadsheet's export), in UTF-16
             "comma.csv": b"\xff\xfe" + text.replace(",", ";").replace(".", ",").encode("utf-16-le")}
    for name, raw in files.items():
        (tmp_path / name).write_bytes(raw)
        assert _channels(tmp_path / name) == want, name


def test_utf16_refusals_are_one_clear_line(tmp_path: Path) -> None:
    text = _csv_text(2, 20.0)
    bad_row = text.splitlines()
    bad_row[40] = bad_row[40].replace(",", ",x", 1)
    cases = {
        "nobom.csv": (text.encode("utf-16-le"), "UTF-16 text without a byte-order mark"),
        "nobom_be.csv": (text.encode("utf-16-be"), "UTF-16 text without a byte-order mark"),
        "cut.csv": (_excel_unicode(text)[:-1], "not valid UTF-16"),
        "row.txt": (_excel_unicode("\n".join(bad_row) + "\n"), "line 41"),
    }
    for name, (raw, said) in cases.items():
        (tmp_path / name).write_bytes(raw)
        with pytest.raises(InputFileError, match=said):
            read_measurement(str(tmp_path / name))
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(["identify", str(tmp_path / name), "--mass", str(MASS)])
        lines = [ln for ln in err.getvalue().splitlines() if ln.strip()]
        assert code == 2 and len(lines) == 1 and said in lines[0], (name, lines)


def _json(argv: list[str]) -> dict[str, Any]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([*argv, "--json"])
    assert code == 0, (argv, err.getvalue())
    return json.loads(out.getvalue())


def _numbers(obj: Any) -> Any:
    """The object without its file names (the only thing the encodings may change)."""
    if isinstance(obj, dict):
        return {k: _numbers(v) for k, v in obj.items() if k not in ("file", "files", "path", "capture", "label",
                                                                    "captures", "source", "model_path")}
    if isinstance(obj, list):
        return [_numbers(v) for v in obj]
    if isinstance(obj, str):
        return obj.replace(".txt", "").replace(".csv", "").replace("u16_", "").replace("u8_", "")
    return obj


def test_every_command_that_reads_a_csv_answers_the_same_on_utf16(tmp_path: Path) -> None:
    u8, u16 = [], []
    for i, f in enumerate((14.0, 20.0, 28.0)):
        text = _csv_text(10 + i, f)
        (tmp_path / f"u8_{i}.csv").write_text(text)
        (tmp_path / f"u16_{i}.txt").write_bytes(_excel_unicode(text))
        u8.append(str(tmp_path / f"u8_{i}.csv"))
        u16.append(str(tmp_path / f"u16_{i}.txt"))
    a = _json(["identify", u16[1], "--mass", str(MASS)])
    b = _json(["identify", u8[1], "--mass", str(MASS)])
    assert _numbers(a) == _numbers(b)
    assert a["stiffness"]["x"] == pytest.approx(MASS * (2 * math.pi * 25.0) ** 2, rel=0.02)
    assert _numbers(_json(["replay", u16[1], "--mass", str(MASS)])) == _numbers(
        _json(["replay", u8[1], "--mass", str(MASS)]))
    model = tmp_path / "m.json"
    d16 = _json(["diagnose", *u16, "--mass", str(MASS), "--save-model", str(model)])
    d8 = _json(["diagnose", *u8, "--mass", str(MASS)])
    assert (d16["cause"], d16["baseline"]) == (d8["cause"], d8["baseline"])
    assert _numbers(_json(["validate", str(model), u16[0], u16[2]])) == _numbers(
        _json(["validate", str(model), u8[0], u8[2]]))
