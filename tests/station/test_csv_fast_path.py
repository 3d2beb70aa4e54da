"""station.readers.read_csv: the compiled pass over a plain CSV (eddi.decimal_text) reads every
file as numpy.loadtxt did, and refuses every bad file with the same line (session 19)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from eddi import decimal_text
from station.errors import InputFileError
from station.readers import read_measurement
from test_bad_inputs import build_files


@pytest.fixture(scope="module")
def kernel():
    return decimal_text._KERNELS.jit_functions()["_parse_columns"]


def _read(spec: str) -> tuple[str, object]:
    try:
        m = read_measurement(spec)
    except InputFileError as exc:
        return "refused", str(exc)
    return "read", m


def _same(a: tuple[str, object], b: tuple[str, object]) -> bool:
    if a[0] != b[0]:
        return False
    if a[0] == "refused":
        return a[1] == b[1]
    ma, mb = a[1], b[1]
    return (np.array_equal(ma.t.view(np.int64), mb.t.view(np.int64)) and ma.rate_hz == mb.rate_hz
            and list(ma.channels) == list(mb.channels) and ma.metadata == mb.metadata
            and all(np.array_equal(ma.channels[k].view(np.int64), mb.channels[k].view(np.int64)) for k in ma.channels))


def _variants(d: Path) -> list[Path]:
    """The bad-input table's text records (17-digit numbers: most go to loadtxt), and each as a plain
    9-digit CSV (what the pass reads), and plain records in other dialects."""
    files = [p for p in build_files(d).values() if p.suffix in (".csv", ".tsv", ".txt") and p.is_file()]
    out = list(files)
    for p in files:
        lines = p.read_bytes().split(b"\n", 1)
        try:
            rows = np.loadtxt(p, delimiter=",", skiprows=1, ndmin=2)
        except ValueError:  # ragged, text in a number, empty: their own lines, as written
            continue
        if rows.size:
            rows[np.abs(rows) < 1e-12] = 0.0  # the table's pulses underflow to 1e-300s (each left to float)
            q = d / f"{p.stem}-9g.csv"
            np.savetxt(q, rows, delimiter=",", header=lines[0].decode("utf-8", "replace"), comments="", fmt="%.9g")
            out.append(q)
    rng = np.random.default_rng(19)
    t = np.arange(4000) / 19200.0
    acc = np.exp(-3 * t) * np.sin(2 * np.pi * 40 * t) + 1e-3 * rng.normal(size=t.size)
    force = 30.0 * np.exp(-(((t - 0.01) / 4e-4) ** 2)) + 1e-3 * rng.normal(size=t.size)
    for name, header, fmt, delim, nl in [("plain", "t,force,acc", "%.9g", ",", "\n"),
                                         ("crlf", "t,force,acc", "%.9g", ",", "\r\n"),
                                         ("tabs", "Time [s]\tForce [N]\tAcceleration [g]", "%.7g", "\t", "\n"),
                                         ("semis", "t;force;acc", "%.6e", ";", "\n"),
                                         ("ms", "Time (ms),Hammer (kN),Accel (g)", "%.8g", ",", "\n")]:
        q = d / f"{name}.csv"
        np.savetxt(q, np.column_stack([t, force, acc]), delimiter=delim, header=header, comments="", fmt=fmt,
                   newline=nl)
        out.append(q)
    notes = d / "notes.csv"
    notes.write_text("# logger v2\n# sensor 123\nt,acc\n" + "".join(f"{x:.9g},{y:.9g}\n" for x, y in zip(t, acc)))
    out.append(notes)
    return out


def test_the_pass_reads_and_refuses_every_record_as_loadtxt_does(tmp_path: Path, kernel,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    files = _variants(tmp_path)
    taken = []

    def counted(*args):
        nh = kernel(*args)
        taken.append(nh >= 0)
        return nh

    results = {}
    for how in ("pass", "loadtxt"):
        monkeypatch.setattr(decimal_text._KERNELS, "built", lambda name: counted if how == "pass" else None)
        results[how] = {p.name: _read(str(p)) for p in files}
    differ = [name for name in results["pass"] if not _same(results["pass"][name], results["loadtxt"][name])]
    assert differ == []
    assert sum(taken) >= 25  # the pass read these (the rest: 17-digit numbers, blanks, ... went to loadtxt)
    kinds = {r[0] for name, r in results["pass"].items() if name.endswith("-9g.csv")}
    assert kinds == {"read", "refused"}  # refusals after the parse (values, time grid, clipping) too


def test_a_file_above_the_pass_limit_is_read_by_loadtxt(tmp_path: Path, kernel,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    import station.readers as readers

    p = tmp_path / "plain.csv"
    p.write_text("t,force,acc\n" + "".join(f"{i / 1000:.9g},{np.exp(-i / 50):.9g},{np.sin(i / 7):.9g}\n"
                                          for i in range(600)))
    calls = []
    monkeypatch.setattr(decimal_text._KERNELS, "built", lambda name: (calls.append(1), kernel)[1])
    first = _read(str(p))
    monkeypatch.setattr(readers, "MAX_PASS_BYTES", p.stat().st_size - 1)
    second = _read(str(p))
    assert calls == [1] and first[0] == "read" and _same(first, second)
