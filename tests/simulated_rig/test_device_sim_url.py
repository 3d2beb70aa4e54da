"""``sim://`` URLs, ``station devices`` and ``station rig serve``: the rig through the real drivers."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import threading

import numpy as np
import pytest

import drivers
from drivers.errors import BadUrlError, DeviceNotFoundError
from station.cli import main
from station.devices import list_devices, open_device, parse_sim_url


def _rig_threads() -> list[str]:
    return [t.name for t in threading.enumerate() if t.name.startswith("rig ")]


@pytest.mark.parametrize("transport", ["pty", "usb"])
def test_sim_url_streams_an_impact_through_the_real_driver(transport):
    before = _rig_threads()
    with open_device(f"sim://duffing-smooth?seed=3&transport={transport}") as daq:
        assert daq.info.serial == "SIM-duffing-smooth"
        assert [c.name for c in daq.info.channels] == ["force", "acc"]
        assert json.loads(daq.info.scenario_json)["seed"] == 3
        rate = daq.info.rate_hz
        daq.start()
        at = daq.impact(300.0)  # unpaced: the rig may already be far ahead of what we read
        first, counts, si, dropped = daq.read_samples(at + int(0.5 * rate))
        daq.stop()
        assert first == 0 and dropped == 0 and daq.stats.crc_errors == 0
        counts, si = counts[at:], si[at:]
        force = si[:, 0]
        np.testing.assert_allclose(si[:, 0], counts[:, 0] * daq.info.channels[0].scale)
        assert 150.0 < force.max() < 450.0  # the hammer delivered about the 300 N asked for
        assert np.abs(si[:, 1]).max() > 1.0  # and the structure rang
    assert _rig_threads() == before  # closing the device stopped the rig


def test_sim_urls_bad_forms_are_one_line_errors():
    assert parse_sim_url("sim://paper-duffing?seed=4&paced=1").seed == 4
    for url, err, text in [
        ("sim://", BadUrlError, "expected sim://SYSTEM"),
        ("sim://nope", DeviceNotFoundError, "no simulated system 'nope'; known: paper-duffing"),
        ("sim://paper-duffing?fast=1", BadUrlError, "unknown sim option 'fast'"),
        ("sim://paper-duffing?seed=x", BadUrlError, "seed must be an integer"),
        ("sim://paper-duffing?transport=wifi", BadUrlError, "transport must be pty or usb"),
    ]:
        with pytest.raises(err, match=text) as info:
            open_device(url)
        assert "\n" not in str(info.value)


def test_list_devices_includes_simulated_systems_and_emulated_usb():
    from simulated_rig.device import EmulatedDaq, PatternSource
    from simulated_rig.usb import EmulatedUsbBackend

    backend = EmulatedUsbBackend(EmulatedDaq(PatternSource(1), serial="Z7"))
    entries = list_devices(usb_backend=backend)
    urls = [e.url for e in entries]
    assert "usb://1209:edd1/Z7" in urls
    assert {"sim://paper-duffing", "sim://duffing-smooth"} <= set(urls)
    assert all(e.kind in ("serial", "usb", "sim") for e in entries)


def test_station_devices_json(capsys):
    assert main(["devices", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert "sim://paper-pendulum" in [d["url"] for d in out["devices"]]


def test_station_rig_serve_prints_the_port_and_serves_until_interrupted():
    proc = subprocess.Popen(
        [sys.executable, "-m", "station.cli", "rig", "serve", "--system", "paper-duffing", "--json", "--unpaced"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    try:
        line = proc.stdout.readline()
        served = json.loads(line)
        assert served["system"] == "paper-duffing" and served["port"].startswith("/dev/")
        with drivers.open_device(served["url"], timeout_s=5.0) as daq:
            assert daq.info.serial == "SIM-paper-duffing"
            daq.start()
            assert daq.read_block(timeout_s=5.0).first_sample == 0
    finally:
        proc.send_signal(signal.SIGINT)
        rc = proc.wait(timeout=20)
    assert rc == 0 and "Traceback" not in proc.stderr.read()


def test_station_rig_serve_unknown_system_is_one_line(capsys):
    assert main(["rig", "serve", "--system", "nope"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no simulated system 'nope'" in err
