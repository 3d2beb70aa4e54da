"""The acquisition loop on a scripted device (sample time, no wall clock), then the real CLI path."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from drivers.channels import ChannelInfo
from drivers.errors import DriverError
from station.capture import ImpactPlan, acquire
from station.config import parse_config
from station.storage import CaptureWriter, check_file, list_captures, read_capture

RATE = 1000.0
FORCE = ChannelInfo("force", "force", "N", scale=0.01, range_si=2000.0, adc_bits=24, sensitivity=2.25, sensitivity_unit="mV/N")
ACC = ChannelInfo("acc", "acceleration", "m/s^2", scale=0.001, range_si=500.0, adc_bits=24, sensitivity=1.0)


class GoneError(DriverError, OSError):
    pass


@dataclass
class Info:
    model: str = "scripted"
    serial: str = "S1"
    firmware: str = "0"
    protocol_version: int = 1
    rate_hz: float = RATE
    channels: tuple = (FORCE, ACC)
    scenario_json: str | None = '{"system": "scripted"}'


@dataclass
class ScriptedDaq:
    """A device whose sample time advances one block per read; impacts are pulses at the counter."""

    block: int = 64
    gone_at: int | None = None  # raise once the counter passes this sample
    interrupt_at: int | None = None
    drop: tuple[tuple[int, int], ...] = ()  # (first, length) of samples never delivered
    url: str = "scripted://"
    info: Info = field(default_factory=Info)
    sample: int = 0
    impacts: list[tuple[int, float, bool]] = field(default_factory=list)
    started: bool = False
    pending: list = field(default_factory=list)

    def start(self) -> None:
        self.started = True

    def stop(self) -> None:
        self.started = False

    def stats(self) -> object:
        return None

    def impact(self, peak: float, double_hit: bool = False) -> None:
        self.impacts.append((self.sample, peak, double_hit))

    def force(self, k: np.ndarray) -> np.ndarray:
        f = np.zeros(k.shape)
        for s, peak, dh in self.impacts:
            for start, p in [(s, peak)] + ([(s + 30, 0.8 * peak)] if dh else []):
                inside = (k >= start) & (k < start + 5)
                f += np.where(inside, p * np.sin(np.pi * (k - start + 0.5) / 5), 0.0)
        return f

    def read_block(self, timeout_s: float | None = None) -> object:
        if self.gone_at is not None and self.sample >= self.gone_at:
            raise GoneError("scripted://: device unplugged")
        if self.interrupt_at is not None and self.sample >= self.interrupt_at:
            raise KeyboardInterrupt
        if not self.pending:
            k = np.arange(self.sample, self.sample + self.block)
            self.sample += self.block
            keep = np.ones(k.shape, dtype=bool)
            for a, n in self.drop:
                keep &= ~((k >= a) & (k < a + n))
            # split into runs of delivered samples (lost ones never arrive)
            edges = np.flatnonzero(np.diff(np.concatenate([[0], keep.astype(np.int8), [0]])))
            self.pending = [k[a:b] for a, b in zip(edges[::2], edges[1::2])]
            if not self.pending:
                return None
        k = self.pending.pop(0)
        counts = np.stack([np.rint(self.force(k) / FORCE.scale), k % 1000], axis=1).astype(np.int32)
        si = counts * np.array([FORCE.scale, ACC.scale])
        return type("B", (), {"first_sample": int(k[0]), "counts": counts, "si": si, "dropped_before": 0})()


def first_at_or_above(peak: float, level: float = 10.0) -> int:
    """Offset of the first half-sine sample >= level (the contract's crossing)."""
    return next(j for j in range(5) if peak * np.sin(np.pi * (j + 0.5) / 5) >= level)


CFG = parse_config({"trigger": {"level_n": 10.0, "pretrigger_s": 0.1, "record_s": 0.3, "holdoff_s": 0.05},
                    "specimen": {"mass_kg": 0.815}, "notes": "bench A"})


def test_three_impacts_saved_with_known_trigger_samples(tmp_path: Path) -> None:
    daq = ScriptedDaq()
    plan = ImpactPlan.varied(3, 20.0, 80.0, seed=1)
    seen = []
    res = acquire(daq, CFG, CaptureWriter(tmp_path / "s.h5"), 3, impacts=plan, on_status=seen.append)
    assert res.error is None and not res.interrupted and res.indices == [0, 1, 2]
    assert len(daq.impacts) == 3 and sorted(p for _, p, _ in daq.impacts) == pytest.approx([20.0, 40.0, 80.0])
    for i, (s, peak, _) in enumerate(daq.impacts):
        r = read_capture(tmp_path / "s.h5", i)
        assert r.trigger_sample == s + first_at_or_above(peak) and r.pretrigger_samples == 100 and r.n_samples == 400
        assert r.rig is not None and r.rig["requested_peak_force_n"] == pytest.approx(peak)
        assert r.mass_kg == 0.815 and r.notes == "bench A" and r.device["serial"] == "S1"
        assert np.max(r.channels["force"].si) == pytest.approx(peak * np.sin(np.pi * 2.5 / 5), abs=0.01)
    assert {s.state for s in seen} >= {"waiting", "armed", "triggered"}
    assert not daq.started


def test_rejected_double_hits_are_replaced(tmp_path: Path) -> None:
    cfg = parse_config({**CFG.model_dump(), "trigger": {**CFG.trigger.model_dump(), "on_double_hit": "reject"}})
    plan = ImpactPlan.varied(3, 20.0, 80.0, double_hit_every=2, seed=0)
    daq = ScriptedDaq()
    res = acquire(daq, cfg, CaptureWriter(tmp_path / "s.h5"), 3, impacts=plan)
    assert res.captures == 3 and res.rejected == ["double hit"] * sum(dh for _, _, dh in daq.impacts)
    assert [dh for _, _, dh in daq.impacts] == [False, True, False, True, False]
    assert not any(s.double_hit for s in list_captures(tmp_path / "s.h5"))
    flag = ScriptedDaq()
    acquire(flag, CFG, CaptureWriter(tmp_path / "f.h5"), 2, impacts=plan)
    assert [s.double_hit for s in list_captures(tmp_path / "f.h5")] == [False, True]


def test_device_lost_mid_capture_keeps_earlier_and_flags_partial(tmp_path: Path) -> None:
    probe = ScriptedDaq()
    acquire(probe, CFG, CaptureWriter(tmp_path / "p.h5"), 2, impacts=ImpactPlan.varied(2, 30.0, 30.0))
    second = probe.impacts[1][0]
    daq = ScriptedDaq(gone_at=second + 150)  # 150 samples into the 2nd record (trigger + 300 long)
    res = acquire(daq, CFG, CaptureWriter(tmp_path / "s.h5"), 3, impacts=ImpactPlan.varied(3, 30.0, 30.0))
    assert res.error == "scripted://: device unplugged"
    assert res.indices == [0, 1] and res.partial_index == 1
    caps = list_captures(tmp_path / "s.h5")
    assert [c.partial for c in caps] == [False, True]
    assert caps[0].n_samples == 400 and 100 < caps[1].n_samples < 400


def test_ctrl_c_keeps_what_was_saved(tmp_path: Path) -> None:
    daq = ScriptedDaq(interrupt_at=2000)
    res = acquire(daq, CFG, CaptureWriter(tmp_path / "s.h5"), 100, impacts=ImpactPlan.varied(100, 30.0, 60.0))
    assert res.interrupted and res.error is None
    n = check_file(tmp_path / "s.h5")
    assert n == res.captures >= 2
    assert not daq.started


def test_dropped_samples_counted_exactly(tmp_path: Path) -> None:
    drops = ((250, 40), (600, 10))
    daq = ScriptedDaq(drop=drops)
    res = acquire(daq, CFG, CaptureWriter(tmp_path / "s.h5"), 3, impacts=ImpactPlan.varied(3, 30.0, 60.0))
    assert res.dropped_samples == 50
    for i in range(3):
        r = read_capture(tmp_path / "s.h5", i)
        lo, hi = r.first_sample, r.first_sample + r.n_samples
        expected = sum(max(0, min(hi, a + n) - max(lo, a)) for a, n in drops)
        assert r.dropped_samples == expected
        assert int(np.isnan(r.channels["acc"].si).sum()) == expected
    assert sum(read_capture(tmp_path / "s.h5", i).dropped_samples for i in range(3)) > 0


# --------------------------------------------------------------------- real driver, real pty
import json
import signal
import subprocess
import sys

from station.cli import main
from station.devices import open_device

REPO = Path(__file__).resolve().parents[2]
FAST = """
[trigger]
level_n = 5.0
pretrigger_s = 0.2
record_s = 0.5
holdoff_s = 0.05
[specimen]
mass_kg = 0.815
[simulation]
peak_force_n = [30.0, 120.0]
seed = 3
"""


def test_station_acquire_on_the_simulated_rig(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "bench.toml"
    cfg.write_text(FAST)
    out = tmp_path / "session.h5"
    rc = main(["acquire", "--device", "sim://duffing-smooth", "--impacts", "3", "--out", str(out),
               "--config", str(cfg), "--notes", "run 1", "--json"])
    got = json.loads(capsys.readouterr().out)
    assert rc == 0 and got["file"] == str(out) and got["captures"] == 3 and got["dropped_samples"] == 0
    peaks = []
    for i in range(3):
        r = read_capture(out, i)
        assert (r.rate_hz, r.pretrigger_samples, r.n_samples) == (19200.0, 3840, 3840 + 9600)
        force = r.channels["force"]
        assert force.info.sensitivity == 2.25 and force.info.unit == "N"
        # the rig delivered the requested peak (half-sine sampled at 19.2 kHz: within 1 %)
        assert np.max(force.si) == pytest.approx(r.rig["requested_peak_force_n"], rel=0.01)
        # the trigger sample is the first at or above the level, its predecessor below
        assert force.si[r.pretrigger_samples] >= 5.0 > force.si[r.pretrigger_samples - 1]
        assert np.all(force.si[: r.pretrigger_samples - 1] < 5.0)
        assert json.loads(r.rig["scenario"])["system"] == "duffing-smooth"
        assert r.notes == "run 1" and r.mass_kg == 0.815 and r.device["url"].startswith("sim://")
        peaks.append(r.rig["requested_peak_force_n"])
    assert len(set(peaks)) == 3 and min(peaks) >= 30.0 and max(peaks) <= 120.0  # varied levels


def test_device_unplugged_mid_capture(tmp_path: Path) -> None:
    """Close the rig's pty (the cable) while the second record is being filled."""
    from simulated_rig.serve import serve_source
    from simulated_rig.source import RigSource

    # paced (real time): the device is not far ahead of the host, so the cable goes mid-record
    server = serve_source(RigSource.from_system("duffing-smooth", seed=1), paced=True)
    cfg = parse_config({"trigger": {"level_n": 5.0, "pretrigger_s": 0.1, "record_s": 0.5}})
    unplugged = []

    def on_status(s: object) -> None:
        if s.saved == 1 and s.state == "triggered" and s.progress > 0.3 and not unplugged:  # type: ignore[attr-defined]
            server.close()
            unplugged.append(True)

    with open_device(f"serial://{server.port}") as daq:
        res = acquire(daq, cfg, CaptureWriter(tmp_path / "s.h5"), 3,
                      impacts=ImpactPlan.varied(3, 50.0, 50.0), on_status=on_status, idle_timeout_s=5.0)
    assert unplugged and res.error is not None and res.indices == [0, 1] and res.partial_index == 1
    caps = list_captures(tmp_path / "s.h5")
    assert [c.partial for c in caps] == [False, True]
    assert caps[0].n_samples == 1920 + 9600 and caps[1].n_samples < 1920 + 9600
    r0 = read_capture(tmp_path / "s.h5", 0)
    assert np.max(r0.channels["force"].si) == pytest.approx(50.0, rel=0.01)


def test_ctrl_c_real_sigint(tmp_path: Path) -> None:
    cfg = tmp_path / "bench.toml"
    cfg.write_text(FAST)
    out = tmp_path / "s.h5"
    proc = subprocess.Popen([sys.executable, "-m", "station.cli", "acquire", "--device", "sim://duffing-smooth",
                             "--impacts", "1000", "--out", str(out), "--config", str(cfg)],
                            stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True, cwd=REPO)
    assert proc.stderr is not None
    for line in proc.stderr:  # live status, one line per event when not a terminal
        if "capture 1 saved" in line:
            proc.send_signal(signal.SIGINT)
            break
    out_text, err = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith("station: interrupted;") and "are kept" in err
    n = check_file(out)
    assert n >= 2 and f"{n} capture(s) saved" in out_text
    for i in range(n):
        read_capture(out, i)  # every capture reads back with its checksums


def test_disk_full_during_acquire_is_one_line_and_keeps_earlier(tmp_path: Path) -> None:
    """A file-size limit (RLIMIT_FSIZE, EFBIG) hits ``station acquire`` in the middle of a run."""
    import resource

    cfg = tmp_path / "bench.toml"
    cfg.write_text(FAST)
    out = tmp_path / "s.h5"
    limit = 400_000  # bytes: a few captures of ~13k samples x 2 channels fit, not 50

    def limit_file_size() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # kept across exec: writes fail with EFBIG
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    res = subprocess.run([sys.executable, "-m", "station.cli", "acquire", "--device", "sim://duffing-smooth",
                          "--impacts", "50", "--out", str(out), "--config", str(cfg), "--json"],
                         capture_output=True, text=True, cwd=REPO, timeout=120, preexec_fn=limit_file_size)
    assert res.returncode == 2 and "Traceback" not in res.stderr
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith("station: error: cannot save capture") and "file size limit reached" in last
    got = json.loads(res.stdout)
    n = check_file(out)
    assert 1 <= n < 50 and got["captures"] == n
    for i in range(n):
        assert read_capture(out, i).n_samples == 3840 + 9600  # complete, checksums verified
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")] == []


def test_overload_rejected_on_the_simulated_rig(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A configured force range of 60 N: impacts above it are rejected and repeated."""
    cfg = tmp_path / "bench.toml"
    cfg.write_text(FAST.replace("[trigger]", '[[channels]]\nname = "force"\nquantity = "force"\nrange = 60.0\n'
                                "[[channels]]\nname = \"acc\"\nquantity = \"acceleration\"\n[trigger]\n"
                                'on_overload = "reject"'))
    out = tmp_path / "s.h5"
    assert main(["acquire", "--device", "sim://duffing-smooth", "--impacts", "2", "--out", str(out),
                 "--config", str(cfg), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert got["captures"] == 2 and got["rejected"] >= 1 and set(got["rejected_reasons"]) == {"overload on force"}
    for i in range(2):
        r = read_capture(out, i)
        assert not r.overload and r.rig["requested_peak_force_n"] <= 60.0
        assert np.max(np.abs(r.channels["force"].si)) <= 60.0 and r.channels["force"].info.range_si == 60.0
