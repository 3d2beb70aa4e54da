"""``audio://`` through the real PortAudio and ALSA: an ALSA ``file`` PCM whose capture side
reads a raw file (``infile``), defined in a test-local ~/.asoundrc, stands in for a USB audio
sensor, so no sound hardware is needed. The station's ``acquire`` runs unchanged on it."""

from __future__ import annotations

import ctypes.util
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from drivers.audio import audio_channels, parse_audio_url, samples_lost_on_overflow
from drivers.errors import BadUrlError

REPO = Path(__file__).resolve().parents[2]
HAVE_PORTAUDIO = ctypes.util.find_library("portaudio") is not None
HAVE_ALSA = ctypes.util.find_library("asound") is not None

HAMMER_MV_PER_N = 2.25
ACC_MV_PER_MS2 = 1.02


def test_url_parsing_and_scale():
    spec = parse_audio_url("audio://USB%20Audio?channels=force,acc,z:velocity&sensitivity=2.25,1.02,5&fullscale_v=2")
    assert spec.device == "USB Audio" and spec.names == ("force", "acc", "z")
    assert spec.quantities == ("force", "acceleration", "velocity")
    force, acc, z = audio_channels(spec)
    assert force.scale == pytest.approx(2.0 / 2**23 / 2.25e-3) and force.range_si == pytest.approx(2.0 / 2.25e-3)
    assert (acc.unit, acc.sensitivity_unit, z.unit) == ("m/s^2", "mV/(m/s^2)", "m/s")
    assert parse_audio_url("audio://3").device == 3
    for bad, why in [("audio://x?channels=foo", "cannot tell its quantity"), ("audio://x?rate=-1", "must be > 0"),
                     ("audio://x?channels=acc1,acc2&sensitivity=1,2,3", "expected 1 or 2"),
                     ("audio://x?gain=3", "unknown audio option"), ("audio://", "expected audio://DEVICE")]:
        with pytest.raises(BadUrlError, match=why):
            parse_audio_url(bad)


def _signal(rate: float) -> tuple[np.ndarray, list[int]]:
    """Two hammer blows (half-sine, 2 ms) on a decaying 12 Hz response, int32 frames (force, acc)."""
    n = int(6.0 * rate)
    t = np.arange(n) / rate
    force = np.zeros(n)
    acc = np.zeros(n)
    starts = []
    for t0, peak in [(1.0, 300.0), (3.5, 180.0)]:
        k0 = int(round(t0 * rate))
        starts.append(k0)
        tau = t - k0 / rate
        pulse = (tau >= 0) & (tau <= 2e-3)
        force[pulse] += peak * np.sin(np.pi * tau[pulse] / 2e-3)
        on = tau >= 0
        acc[on] += 0.2 * peak * np.exp(-3.0 * tau[on]) * np.sin(2 * np.pi * 12.0 * tau[on])
    volts = np.stack([force * HAMMER_MV_PER_N * 1e-3, acc * ACC_MV_PER_MS2 * 1e-3], axis=1)  # full scale 1 V
    counts24 = np.round(volts * 2**23).astype(np.int32)
    return counts24 * 256, starts  # 32-bit frames whose low byte is zero: exactly 24-bit counts


@pytest.mark.skipif(not (HAVE_PORTAUDIO and HAVE_ALSA), reason="needs libportaudio2 and ALSA (libasound2)")
def test_station_acquire_reads_an_alsa_file_pcm_through_portaudio(tmp_path):
    raw = tmp_path / "sensor.raw"
    (tmp_path / ".asoundrc").write_text(
        f'pcm.eddi_sensor {{\n  type file\n  slave.pcm "null"\n  file "/dev/null"\n'
        f'  infile "{raw}"\n  format "raw"\n}}\n')
    raw.write_bytes(bytes(8 * 4096))  # PortAudio lists the PCM only when its infile opens
    env = {**os.environ, "HOME": str(tmp_path), "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    probe = subprocess.run([sys.executable, "-c", "import sounddevice as sd; d = sd.query_devices('eddi_sensor', 'input');"
                            " print(d['default_samplerate'], d['max_input_channels'])"],
                           capture_output=True, text=True, env=env)
    assert probe.returncode == 0, probe.stderr[-2000:]
    rate = float(probe.stdout.split()[0])
    frames, starts = _signal(rate)
    frames.astype("<i4").tofile(raw)
    (tmp_path / "bench.toml").write_text(
        "[[channels]]\nname = \"force\"\nquantity = \"force\"\n"
        f"sensitivity = {HAMMER_MV_PER_N}\nsensitivity_unit = \"mV/N\"\n"
        "[[channels]]\nname = \"acc\"\nquantity = \"acceleration\"\n"
        f"sensitivity = {ACC_MV_PER_MS2}\n"
        "[trigger]\nlevel_n = 50.0\npretrigger_s = 0.25\nrecord_s = 1.5\n[specimen]\nmass_kg = 0.4\n")
    out = tmp_path / "audio.h5"
    # the URL says 1 mV/unit: the bench configuration's calibration must win
    url = "audio://eddi_sensor?channels=force,acc&sensitivity=1&blocksize=512"
    proc = subprocess.run([sys.executable, "-m", "station.cli", "acquire", "--device", url, "--impacts", "2",
                           "--out", str(out), "--config", str(tmp_path / "bench.toml"), "--idle-timeout", "10",
                           "--json"], capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    result = json.loads(proc.stdout)
    assert (result["captures"], result["dropped_samples"], result["link_dropped_samples"]) == (2, 0, 0)

    from station.storage import read_capture

    expected_si = frames / 256 / 2**23 / (np.array([HAMMER_MV_PER_N, ACC_MV_PER_MS2]) * 1e-3)
    pre, post = int(round(0.25 * rate)), int(round(1.5 * rate))
    for i, k0 in enumerate(starts):
        cap = read_capture(out, i)
        assert cap.rate_hz == rate  # the device's rate, as PortAudio reports it
        assert "eddi_sensor" in cap.device["model"]
        k = cap.trigger_sample
        assert k0 <= k <= k0 + int(2e-3 * rate)  # the first sample at or above 50 N
        got = np.stack([cap.channels["force"].si, cap.channels["acc"].si], axis=1)
        np.testing.assert_allclose(got, expected_si[k - pre:k + post], rtol=1e-12, atol=1e-12)


@pytest.mark.skipif(not HAVE_PORTAUDIO, reason="needs libportaudio2")
def test_acquire_from_a_missing_audio_device_is_one_line_and_exit_2(tmp_path):
    env = {**os.environ, "HOME": str(tmp_path), "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.run([sys.executable, "-m", "station.cli", "acquire", "--device", "audio://no-such-sensor",
                           "--impacts", "1", "--out", str(tmp_path / "x.h5")], capture_output=True, text=True,
                          env=env, timeout=60)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "no audio input 'no-such-sensor'" in lines[0]


def test_samples_lost_on_overflow_from_the_stream_clock():
    """An overflow 2 s into a 48 kHz stream, 90,000 samples taken before, 1024 now, 512 waiting:
    96,000 produced - 91,536 accounted = 4,464 lost; a lagging clock counts none."""
    assert samples_lost_on_overflow(12.0, 10.0, 48000.0, 0, 90_000, 1024, 512) == 4464
    assert samples_lost_on_overflow(12.0, 10.0, 48000.0, 500, 90_000, 1024, 512) == 4964  # counter after configure
    assert samples_lost_on_overflow(10.5, 10.0, 48000.0, 0, 90_000, 1024, 0) == 0
