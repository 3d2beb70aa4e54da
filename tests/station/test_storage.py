"""HDF5 capture files: bit-exact round trip, schema readable with plain h5py, faults, real kills."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

from drivers.channels import ChannelInfo
from station.errors import CaptureFormatError, InputFileError
from station.storage import (
    FORMAT_NAME,
    CaptureWriter,
    StorageError,
    check_file,
    list_captures,
    read_capture,
    sha256_of,
)
from station.trigger import Capture

REPO = Path(__file__).resolve().parents[2]
FORCE = ChannelInfo("force", "force", "N", scale=2.5e-4, offset=0.125, range_si=2000.0, adc_bits=24,
                    sensitivity=2.25, sensitivity_unit="mV/N")
ACC = ChannelInfo("acc", "acceleration", "m/s^2", scale=3.0e-5, offset=-0.01, range_si=250.0, adc_bits=24,
                  sensitivity=1.0, sensitivity_unit="mV/(m/s^2)")


def make_capture(seed: int, n: int = 5000, pre: int = 1000, **flags: object) -> Capture:
    """A deterministic capture: regenerating it from ``seed`` gives the same bytes."""
    rng = np.random.default_rng(seed)
    counts = rng.integers(-(2**23), 2**23 - 1, size=(n, 2), dtype=np.int64).astype(np.int32)
    si = np.stack([FORCE.to_si(counts[:, 0]), ACC.to_si(counts[:, 1])], axis=1)
    gaps = flags.pop("gaps", ())
    for row, length in gaps:  # type: ignore[attr-defined]
        counts[row : row + length] = 0
        si[row : row + length] = np.nan
    return Capture(counts, si, (FORCE, ACC), 19200.0, 10_000 + seed, 10_000 + seed + pre, pre,
                   gaps=tuple(gaps), dropped_samples=sum(g[1] for g in gaps), **flags)  # type: ignore[arg-type]


def test_round_trip_bit_exact_with_metadata(tmp_path: Path) -> None:
    path = tmp_path / "session.h5"
    w = CaptureWriter(path, session={"session_notes": "bench A"})
    caps = [make_capture(1), make_capture(2, double_hit=True), make_capture(3, overload=True, overload_channels=("acc",)),
            make_capture(4, gaps=((100, 7), (4000, 3)), partial=True)]
    dev = {"model": "EDDI-DAQ-sim", "serial": "SIM0001", "firmware": "1.0", "protocol_version": 1, "url": "sim://duffing"}
    for i, c in enumerate(caps):
        assert w.append(c, device=dev, rig={"scenario": "duffing", "peak_force_n": 50.0 + i} if i < 2 else None,
                        notes=f"hit {i}", mass_kg=0.815, source="sim://duffing", dropped_before_total=3 * i) == i
    assert w.count == 4 and check_file(path) == 4
    for i, c in enumerate(caps):
        r = read_capture(path, i)
        np.testing.assert_array_equal(r.channels["force"].counts, c.counts[:, 0])
        np.testing.assert_array_equal(r.channels["acc"].counts, c.counts[:, 1])
        # SI reproduced exactly from counts * scale + offset
        np.testing.assert_array_equal(r.channels["force"].si, c.si[:, 0])
        np.testing.assert_array_equal(r.channels["acc"].si, c.si[:, 1])
        assert r.channels["force"].info == FORCE and r.channels["acc"].info == ACC
        assert (r.rate_hz, r.pretrigger_samples, r.trigger_sample, r.first_sample, r.n_samples) == (
            19200.0, 1000, c.trigger_sample, c.first_sample, 5000)
        assert (r.double_hit, r.overload, r.partial) == (c.double_hit, c.overload, c.partial)
        assert r.overload_channels == c.overload_channels
        assert r.dropped_samples == c.dropped_samples and [tuple(g) for g in r.gaps] == list(c.gaps)
        assert r.notes == f"hit {i}" and r.mass_kg == 0.815 and r.device["serial"] == "SIM0001"
        assert (r.rig is not None) == (i < 2)
    assert read_capture(path, -1).index == 3
    assert read_capture(path, "2").double_hit is False and read_capture(path, "1").double_hit is True
    summary = list_captures(path)
    assert [s.dropped_samples for s in summary] == [0, 0, 0, 10]


def test_readable_with_plain_h5py_as_documented(tmp_path: Path) -> None:
    path = tmp_path / "s.h5"
    cap = make_capture(7)
    CaptureWriter(path).append(cap, mass_kg=0.088)
    # the example of docs/capture-format.md, verbatim in spirit
    with h5py.File(path, "r") as f:
        assert f.attrs["format"] == FORMAT_NAME and f.attrs["format_version"] == 2
        g = f["captures/0000"]
        ds = g["channels/force"]
        force_n = ds[:] * ds.attrs["scale"] + ds.attrs["offset"]
        t = (np.arange(g.attrs["n_samples"]) - g.attrs["pretrigger_samples"]) / g.attrs["rate_hz"]
        assert json.loads(g.attrs["channel_order"]) == ["force", "acc"]
        import hashlib
        assert hashlib.sha256(ds[:].astype("<i4").tobytes()).hexdigest() == ds.attrs["sha256"]
    np.testing.assert_array_equal(force_n, cap.si[:, 0])
    assert t[1000] == 0.0


def test_import_si_values_exact(tmp_path: Path) -> None:
    path = tmp_path / "imp.h5"
    vel = np.sin(np.arange(1000) / 7.0) * 1e-3
    w = CaptureWriter(path)
    w.append_si({"vel": vel}, rate_hz=5120.33, source="ringdown.csv", mass_kg=1.0)
    r = read_capture(path)
    assert r.channels["vel"].counts is None and r.channels["vel"].info.unit == "m/s"
    np.testing.assert_array_equal(r.channels["vel"].si, vel)
    with pytest.raises(InputFileError, match="expected one of"):
        w.append_si({"speed": vel}, rate_hz=1.0)


def test_foreign_unreadable_missing_and_out_of_range(tmp_path: Path) -> None:
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["x"] = np.arange(3)
    with pytest.raises(CaptureFormatError, match="foreign HDF5"):
        read_capture(foreign)
    with pytest.raises(CaptureFormatError, match="foreign HDF5"):
        CaptureWriter(foreign)  # never append to someone else's file
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"not an hdf5 file at all" * 10)
    with pytest.raises(CaptureFormatError, match="expected an HDF5 file"):
        read_capture(junk)
    with pytest.raises(InputFileError, match="no such file"):
        read_capture(tmp_path / "missing.h5")
    path = tmp_path / "s.h5"
    w = CaptureWriter(path)
    w.append(make_capture(1))
    w.append(make_capture(2))
    with pytest.raises(InputFileError, match=r"expected an index 0\.\.1, the file s.h5 holds 2"):
        read_capture(path, 2)
    with pytest.raises(InputFileError, match="expected an index"):
        read_capture(path, "last")
    with pytest.raises(InputFileError, match="output file"):
        CaptureWriter(tmp_path / "nodir" / "x.h5")


def test_checksum_detects_damage(tmp_path: Path) -> None:
    path = tmp_path / "s.h5"
    CaptureWriter(path).append(make_capture(1))
    with h5py.File(path, "r+") as f:
        ds = f["captures/0000/channels/acc"]
        ds[10] = ds[10] + 1
    with pytest.raises(CaptureFormatError, match="'acc' fails its SHA-256"):
        read_capture(path)
    assert read_capture(path, verify=False).n_samples == 5000


def test_sha256_is_of_little_endian_bytes() -> None:
    a = np.arange(5, dtype=">i4")
    import hashlib
    assert sha256_of(a) == hashlib.sha256(np.arange(5, dtype="<i4").tobytes()).hexdigest()


# --------------------------------------------------------------------------- crash safety
CHILD = textwrap.dedent(
    """
    import os, signal, sys
    sys.path.insert(0, {tests!r})
    import h5py
    from test_storage import make_capture
    from station import journal, storage
    path, n_before, point = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    w = storage.CaptureWriter(path)
    for i in range(n_before):
        w.append(make_capture(i, n=40000))
    def die(*a, **k):
        os.kill(os.getpid(), signal.SIGKILL)
    real_pwrite = journal.pwrite_all
    calls = []
    def half_then_die(fd, data, offset, chunk=1 << 22):
        calls.append(1)
        if len(calls) == (1 if point == "mid_tail" else 2):
            real_pwrite(fd, memoryview(data)[: len(data) // 2], offset); os.fsync(fd); die()
        real_pwrite(fd, data, offset, chunk)
    if point in ("mid_tail", "mid_journal"):
        journal.pwrite_all = half_then_die
    elif point == "mid_channels":
        real_ds = h5py.Group.create_dataset
        def ds_then_die(self, name, *a, **k):
            out = real_ds(self, name, *a, **k)
            if name == "acc":
                self.file.flush(); die()
            return out
        h5py.Group.create_dataset = ds_then_die
    elif point in ("in_place", "mid_patch"):
        w.hooks[point] = die
    print("writing", n_before, flush=True)
    w.append(make_capture(n_before, n=40000))
    print("survived", flush=True)
    """
)
#: Kill points: before the journal is durable the save is lost (the old file stays), after
#: it the save is complete (the next open replays the journal).
KILL_POINTS = {"mid_channels": 0, "mid_tail": 0, "mid_journal": 0, "in_place": 1, "mid_patch": 1,
               "external": None, "external_in_tail": None}


@pytest.mark.parametrize("point", list(KILL_POINTS))
def test_kill_9_while_writing_keeps_earlier_captures_bit_exact(tmp_path: Path, point: str) -> None:
    path = tmp_path / "s.h5"
    script = tmp_path / "child.py"
    script.write_text(CHILD.format(tests=str(Path(__file__).parent)))
    n_before = 3
    proc = subprocess.Popen([sys.executable, str(script), str(path), str(n_before), point],
                            stdout=subprocess.PIPE, text=True, cwd=REPO)
    assert proc.stdout is not None
    line = proc.stdout.readline()
    assert line.startswith("writing")
    if point.startswith("external"):
        # killed from outside: at once (while h5py builds the capture), or once the new bytes
        # are being appended to the file on disk
        size = path.stat().st_size
        while point == "external_in_tail" and path.stat().st_size == size and proc.poll() is None:
            pass
        proc.send_signal(signal.SIGKILL)
    rc = proc.wait(timeout=60)
    assert rc == -signal.SIGKILL
    n = check_file(path)  # finishes or discards the interrupted commit first
    assert n == n_before + KILL_POINTS[point] if KILL_POINTS[point] is not None else n in (n_before, n_before + 1)
    for i in range(n):
        expected = make_capture(i, n=40000)
        r = read_capture(path, i)  # verifies SHA-256 too
        np.testing.assert_array_equal(r.channels["force"].counts, expected.counts[:, 0])
        np.testing.assert_array_equal(r.channels["acc"].counts, expected.counts[:, 1])
    # the next session appends normally; no journal or temporary file is left
    assert CaptureWriter(path).append(make_capture(99)) == n
    assert check_file(path) == n + 1
    assert read_capture(path, n).trigger_sample == make_capture(99).trigger_sample
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == [".s.h5.lock"]


# --------------------------------------------------------------------------- disk full
FSIZE_CHILD = textwrap.dedent(
    """
    import resource, signal, sys
    sys.path.insert(0, {tests!r})
    from test_storage import make_capture
    from station.storage import CaptureWriter
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # writes beyond the limit fail with EFBIG
    path, limit = sys.argv[1], int(sys.argv[2])
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    w = CaptureWriter(path)
    for i in range(100):
        w.append(make_capture(i, n=20000))
    """
)


def test_file_size_limit_gives_one_line_error_and_keeps_earlier(tmp_path: Path) -> None:
    """RLIMIT_FSIZE (no root needed): the save that crosses the limit fails with EFBIG."""
    path = tmp_path / "s.h5"
    script = tmp_path / "child.py"
    script.write_text(FSIZE_CHILD.format(tests=str(Path(__file__).parent)))
    limit = 700_000  # each capture stores ~ 2 x 20000 x 4 bytes of incompressible counts (~160 kB)
    res = subprocess.run([sys.executable, str(script), str(path), str(limit)], capture_output=True, text=True,
                         cwd=REPO, timeout=120)
    assert res.returncode != 0
    last = res.stderr.strip().splitlines()[-1]
    assert "StorageError: cannot save capture" in last and "file size limit reached" in last
    n = check_file(path)
    assert 1 <= n < 100 and os.path.getsize(path) <= limit
    for i in range(n):
        np.testing.assert_array_equal(read_capture(path, i).channels["acc"].counts, make_capture(i, n=20000).counts[:, 1])


def _mount_tmpfs(where: Path, size: str) -> bool:
    where.mkdir()
    res = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)], capture_output=True)
    return res.returncode == 0


def test_real_disk_full_on_tiny_tmpfs(tmp_path: Path) -> None:
    """A real full file system (needs mount permission, else skipped: the RLIMIT test covers it)."""
    mnt = tmp_path / "tiny"
    if not _mount_tmpfs(mnt, "1m"):
        pytest.skip("cannot mount a tmpfs here (not root)")
    try:
        path = mnt / "s.h5"
        w = CaptureWriter(path)
        saved = 0
        with pytest.raises(StorageError, match="disk full; captures saved before are intact") as info:
            for i in range(100):
                w.append(make_capture(i, n=20000))
                saved += 1
        assert info.value.errno == 28  # ENOSPC
        assert check_file(path) == saved >= 1
        for i in range(saved):
            np.testing.assert_array_equal(read_capture(path, i).channels["force"].counts,
                                          make_capture(i, n=20000).counts[:, 0])
        assert sorted(p.name for p in mnt.iterdir()) == [".s.h5.lock", "s.h5"]  # no temporary left behind
    finally:
        subprocess.run(["umount", str(mnt)], check=False)
