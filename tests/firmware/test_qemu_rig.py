"""The open firmware (firmware/) in QEMU, read by the station's unchanged serial path.

Real QEMU (``qemu-system-arm -M netduinoplus2``), the real firmware image built with Debian's
``gcc-arm-none-eabi``, real ptys, the real ``station`` CLI and the real identification. Every
number on the wire (sequence numbers, CRC, sample counter, rate, the oscillator's samples)
comes from the firmware. Skipped only when the toolchain or QEMU is absent.
"""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import drivers
from drivers.errors import DeviceError
from simulated_rig.qemu import FIRMWARE_SYSTEMS, QemuRig, toolchain_missing

REPO = Path(__file__).resolve().parents[2]
MISSING = toolchain_missing()
pytestmark = pytest.mark.skipif(MISSING is not None, reason=f"firmware emulator unavailable: {MISSING}")


def _start_rig_cli(system: str) -> tuple[subprocess.Popen[str], dict]:
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.Popen([sys.executable, "-m", "station.cli", "rig", "qemu", "--system", system, "--json",
                             "--duration-s", "150"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, cwd=REPO)
    # the rig prints its port once QEMU runs (after building the image if needed)
    ready, _, _ = select.select([proc.stdout], [], [], 180.0)
    line = proc.stdout.readline() if ready else ""
    if not line:
        proc.kill()
        pytest.fail(f"station rig qemu printed nothing within 180 s: {proc.stderr.read()[-2000:]}")
    return proc, json.loads(line)


def test_rig_qemu_then_acquire_captures_impacts_without_loss_and_identifies_k1(tmp_path, capsys):
    """`station rig qemu` + `station acquire --device serial://PTY`: 3 impacts, 0 dropped, k1 within 5 %.

    The oscillator is not the firmware's built-in default: its parameters are written into the
    firmware's RAM before boot, and the firmware reports what it runs in its IDENTIFY reply.
    """
    from eddi.terms import DEFAULT_DAMPING, DEFAULT_STIFFNESS
    from station.cli import main
    from station.commands.identify import run_identify
    from station.readers import read_measurement
    from station.storage import read_capture

    system = FIRMWARE_SYSTEMS["duffing-soft"]
    proc, served = _start_rig_cli("duffing-soft")
    out = tmp_path / "session.h5"
    try:
        assert served["url"] == f"serial://{served['port']}"
        capsys.readouterr()
        code = main(["acquire", "--device", served["url"], "--impacts", "3", "--out", str(out),
                     "--mass", str(system.mass_kg), "--idle-timeout", "10", "--json"])
        result = json.loads(capsys.readouterr().out)
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=20)
    assert code == 0, result
    assert (result["captures"], result["dropped_samples"], result["link_dropped_samples"], result["crc_errors"]) \
        == (3, 0, 0, 0)
    assert proc.returncode == 0
    for i in range(3):
        cap = read_capture(out, i)
        assert cap.device["model"].startswith("EDDI-DAQ-F4 (QEMU")
        assert cap.rate_hz == 3906.25  # 4 MHz / OSR 1024, from the firmware
        truth = json.loads(cap.rig["scenario"])  # what the firmware says it integrates
        assert truth["k1"] == pytest.approx(system.k1) and truth["mass_kg"] == pytest.approx(system.mass_kg)
        meas = read_measurement(f"{out}:{i}")
        res = run_identify(meas, truth["mass_kg"], ",".join(DEFAULT_DAMPING), ",".join(DEFAULT_STIFFNESS))
        k1 = res.model.eom.stiffness["x"]
        assert abs(k1 / truth["k1"] - 1.0) < 0.05, (i, k1, truth["k1"])


def test_corrupted_byte_between_emulator_and_host_is_counted_not_delivered():
    """The relay flips one byte of the 4th DATA frame: the host counts one bad frame and exactly
    its samples as dropped, and every block it delivers equals what the firmware sent."""
    with QemuRig("duffing", corrupt_data_frame=4, tap=True) as rig:
        with drivers.open_device(rig.url, timeout_s=5.0) as daq:
            daq.start()
            blocks = []
            while len(blocks) < 12:
                b = daq.read_block(5.0)
                assert b is not None, "no data from the emulated firmware"
                blocks.append(b)
            daq.stop()
            while (b := daq.read_block(0.2)) is not None:
                blocks.append(b)
            stats = daq.stats
            next_sample = daq.status()["next_sample"]
        (bad,) = rig.relay.corruptions
        tap = rig.relay.tap_frames
    assert stats.crc_errors + stats.framing_errors == 1
    assert stats.dropped_samples == bad.n_samples > 0
    assert stats.lost_frames == 1
    firsts = [b.first_sample for b in blocks]
    assert bad.first_sample not in firsts
    assert [b.dropped_before for b in blocks if b.dropped_before] == [bad.n_samples]
    for b in blocks:  # CRC-checked: what arrives is exactly the firmware's
        assert np.array_equal(b.counts, tap[b.first_sample].counts)
    assert stats.samples + stats.dropped_samples == next_sample == sum(b.n_samples for b in blocks) + bad.n_samples


def test_firmware_commands_configure_refuse_and_hammer():
    """CONFIGURE rounds to the ADC's rates and refuses others; IMPACT lands a blow; a counter per configure."""
    with QemuRig("linear") as rig, drivers.open_device(rig.url, timeout_s=5.0) as daq:
        assert daq.info.rate_hz == 3906.25 and [c.name for c in daq.info.channels] == ["force", "acc"]
        with pytest.raises(DeviceError, match="rate must be within 5 % of one of"):
            daq.configure(rate_hz=5000.0)
        assert daq.info.rate_hz == 3906.25  # a refused command changes nothing
        info = daq.configure(rate_hz=7800.0, channels=["force"], block_size=100)
        assert (info.rate_hz, info.block_size, [c.name for c in info.channels]) == (7812.5, 100, ["force"])
        daq.start()
        at = daq.impact(900.0)
        first, counts, si, dropped = daq.read_samples(int(at) + 2000, timeout_s=5.0)
        daq.stop()
        assert (first, dropped) == (0, 0) and counts.shape[1] == 1
        k = int(np.argmax(si[:, 0]))
        assert at <= k <= at + 8 + int(0.002 * 7812.5)  # the 2 ms half-sine peaks 1 ms after it lands
        assert si[k, 0] == pytest.approx(900.0, rel=0.02)


@pytest.mark.parametrize("argv, why", [
    (["rig", "qemu", "--system", "nope"], "no firmware system 'nope'; known: duffing"),
    (["rig", "qemu", "--corrupt-data-frame", "0"], "expected a frame number >= 1"),
])
def test_rig_qemu_bad_input_is_one_line_and_exit_2(argv, why, capsys):
    from station.cli import main

    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and why in err[0]
